#!/usr/bin/python3
"""Large-scale statistics of a field run against its example, from field.h5
alone (/field/levels, /source/levels): the autocorrelation of the inside
indicator (level < 128, i.e. distance < 0) as a function of the lag radius,
and its distance to the example's.

  analysis/field_autocorr.py RUN_DIR [RUN_DIR ...]   -> one JSON line per run

C(r) = mean over pairs of samples at distance ~r (non-periodic, every pair
inside the box counted once per direction; computed with zero-padded FFTs) of
I(x) I(x+d), divided by the volume fraction, so C(0) = 1 and C(r) -> volume
fraction at large r. autocorr_error = mean over r = 1..rmax of
|C_out(r) - C_src(r)| (rmax = a quarter of the example's shortest side);
autocorr_error_far the same over r = rmax/2..rmax, the scales of several
blocks, where multi-resolution has to act.
"""
import json
import sys

import h5py
import numpy as np


def inside(path, ds):
    with h5py.File(path, "r") as f:
        lv = f[ds][...]
        lo, hi = f[ds].attrs["lo"], f[ds].attrs["hi"]
    return (lo + lv.astype(np.float64) * (hi - lo) / 255.0 < 0).astype(np.float64)


def radial_autocorr(a, rmax):
    shape = [2 * n for n in a.shape]
    fa = np.fft.rfftn(a, shape)
    num = np.fft.irfftn(fa * np.conj(fa), shape)
    ones = np.ones_like(a)
    fo = np.fft.rfftn(ones, shape)
    cnt = np.fft.irfftn(fo * np.conj(fo), shape)
    idx = [np.fft.fftfreq(s, 1.0 / s) for s in shape]
    zz, yy, xx = np.meshgrid(*idx, indexing="ij")
    r = np.rint(np.sqrt(xx * xx + yy * yy + zz * zz)).astype(int)
    ok = (r <= rmax) & (cnt > 0.5)
    s = np.bincount(r[ok], weights=num[ok], minlength=rmax + 1)
    c = np.bincount(r[ok], weights=cnt[ok], minlength=rmax + 1)
    vf = a.mean()
    return s / np.maximum(c, 1) / max(vf, 1e-12)


def measure(run):
    h5 = run + "/field.h5"
    src = inside(h5, "/source/levels")
    out = inside(h5, "/field/levels")
    rmax = min(src.shape) // 4
    cs, co = radial_autocorr(src, rmax), radial_autocorr(out, rmax)
    d = np.abs(co - cs)
    return {"run": run, "rmax": int(rmax),
            "volume_fraction_out": round(float(out.mean()), 4),
            "volume_fraction_src": round(float(src.mean()), 4),
            "autocorr_error": round(float(d[1:].mean()), 4),
            "autocorr_error_far": round(float(d[rmax // 2:].mean()), 4),
            "autocorr_out": [round(float(v), 4) for v in co],
            "autocorr_src": [round(float(v), 4) for v in cs]}


if __name__ == "__main__":
    for run in sys.argv[1:]:
        print(json.dumps(measure(run)))
