#!/usr/bin/python3
"""Large-scale repetition of a height-field run, from field.h5 alone
(/field/levels, /source/levels): "the same mountain twice".

  analysis/field_repeats.py RUN_DIR [--tile | --surrogates N]   -> one JSON line

The same figures as summary.json's repeat_* (src/measure/repeat.c,
gs_measure_repeats2): the surface height of every column (the highest
inside-to-outside crossing of the levels, linear between samples), windows of
w x w samples (w: the first lag at which the example's autocorrelation falls
below 1/e), each reduced to its residual after the least squares plane and
normalized (float32, as the C code stores them); windows whose residual RMS is
below the median of the example's are left out. A pair is a window on the
grid of stride max(1, w/4) and any other window at most the example's larger
side away along each axis that does not overlap it (origins w or more apart
along an axis).
  ncc_src: the most alike two places of the example (highest NCC of a pair);
  ncc_out: the same in the output (a tiling of the example: 1);
  recur_out: the largest number of output windows, none overlapping another,
    matching one example window (on the grid) with NCC >= ncc_src: how many
    times one example feature recurs (the example's own figure is 1).
  ncc_out_area, ncc_out_area_max, crops: the equal-area figure, ncc_out
    within each example-sized crop of the output (crops every half the
    example's side, the last flush with the far face), the median over the
    crops that hold a pair and the highest; compares with ncc_src (ncc_out is
    a maximum over 4x the example's area at 64^2 -> 128^2: more pairs).
--tile measures a 2x2 tiling of the example instead of the output (a
repetition the measure must flag; its crops score as the example).
--surrogates N: instead, the figures of N non-repeating random reliefs with
the example's spectrum and heights, the example's size and the output's
(how much a larger area alone raises ncc_out).
"""
import json
import sys

import h5py
import numpy as np


def heights(levels, lo, hi):
    table = np.array([np.float32(lo + q * (hi - lo) / 255.0) for q in range(256)], np.float32)
    d = table[levels].astype(np.float64)  # [z, y, x]
    nz, ny, nx = d.shape
    z = np.where(d[nz - 1] < 0, float(nz - 1), 0.0)
    found = np.zeros((ny, nx), bool)
    for k in range(nz - 2, -1, -1):
        a, b = d[k], d[k + 1]
        hit = (a < 0) & (b >= 0) & ~found
        z[hit] = k + a[hit] / (a[hit] - b[hit])
        found |= hit
    return z  # [y, x]


def feature_size(h):
    ny, nx = h.shape
    lim = min(nx, ny) // 2
    m = h - h.mean()
    var = (m * m).mean()
    if lim < 3:
        return lim
    if var <= 0:
        return 3
    L = 1
    while L < lim:
        cx = (m[:, L:] * m[:, :-L]).sum() / ((nx - L) * ny)
        cy = (m[L:, :] * m[:-L, :]).sum() / (nx * (ny - L))
        if 0.5 * (cx + cy) / var < np.exp(-1.0):
            break
        L += 1
    return max(L, 3)


def windows(h, w):
    ny, nx = h.shape
    c = 0.5 * (w - 1)
    i = np.arange(w) - c
    sxx = (i * i).sum() * w
    win = np.lib.stride_tricks.sliding_window_view(h, (w, w))  # [y0, x0, j, i]
    mean = win.mean(axis=(2, 3))
    bx = (win * i[None, None, None, :]).sum(axis=(2, 3)) / sxx
    by = (win * i[None, None, :, None]).sum(axis=(2, 3)) / sxx
    e = win - mean[..., None, None] - bx[..., None, None] * i[None, None, None, :] \
        - by[..., None, None] * i[None, None, :, None]
    ss = (e * e).sum(axis=(2, 3))
    norm = np.sqrt(ss)
    v = np.where(norm[..., None, None] > 0, e / np.where(norm > 0, norm, 1)[..., None, None], 0)
    py, px = mean.shape
    y0, x0 = np.mgrid[0:py, 0:px]
    return (x0.ravel(), y0.ravel(), np.sqrt(ss / (w * w)).ravel(),
            v.reshape(py * px, w * w).astype(np.float32).astype(np.float64))


def best_pair(W, w, st, floor, reach, box=None):
    x, y, rms, v = W
    ok = rms >= floor
    if box is not None:
        bx, by, cx, cy = box
        ok &= (x >= bx) & (y >= by) & (x + w <= bx + cx) & (y + w <= by + cy)
    else:
        bx = by = 0
    a = np.where(ok & ((x - bx) % st == 0) & ((y - by) % st == 0))[0]
    b = np.where(ok)[0]
    best = -1.0
    for i in a:
        dx, dy = np.abs(x[b] - x[i]), np.abs(y[b] - y[i])
        sel = b[((dx >= w) | (dy >= w)) & (dx <= reach) & (dy <= reach)]
        if len(sel):
            best = max(best, float((v[sel] @ v[i]).max()))
    return best


def crop_origins(n, c):
    if c >= n:
        return [0]
    o = list(range(0, n - c + 1, max(1, c // 2)))
    if o[-1] != n - c:
        o.append(n - c)
    return o


def area_figure(O, w, st, relief, reach, ho_shape, hs_shape):
    """ncc_out_area: median over the output's example-sized crops (every half
    the example's side, the last flush with the far face) of each crop's most
    alike two places; crops without a pair left out."""
    ony, onx = ho_shape
    cy, cx = min(hs_shape[0], ony), min(hs_shape[1], onx)
    f = [best_pair(O, w, st, relief, reach, (x0, y0, cx, cy))
         for y0 in crop_origins(ony, cy) for x0 in crop_origins(onx, cx)]
    n = len(f)
    f = sorted(c for c in f if c > -1)
    if not f:
        return -1.0, -1.0, n
    return float(np.median(f)), f[-1], n


def measure(hs, ho):
    sny, snx = hs.shape
    w = feature_size(hs)
    st = max(1, w // 4)
    reach = max(snx, sny)
    S, O = windows(hs, w), windows(ho, w)
    relief = float(np.median(S[2]))
    r = {"window": int(w), "stride": st, "relief": relief,
         "ncc_src": best_pair(S, w, st, relief, reach), "ncc_out": best_pair(O, w, st, relief, reach)}
    r["ncc_out_area"], r["ncc_out_area_max"], r["crops"] = area_figure(O, w, st, relief, reach,
                                                                      ho.shape, hs.shape)
    x, y, rms, v = O
    okb = np.where(rms >= relief)[0]
    sx, sy, srms, sv = S
    recur = 0
    for i in np.where((srms >= relief) & (sx % st == 0) & (sy % st == 0))[0]:
        c = v[okb] @ sv[i]
        hit = okb[c >= r["ncc_src"]]
        if len(hit) <= recur:
            continue
        order = sorted(range(len(hit)), key=lambda k: (-c[c >= r["ncc_src"]][k], hit[k]))
        took = []
        for k in order:
            j = hit[k]
            if all(abs(x[j] - x[t]) >= w or abs(y[j] - y[t]) >= w for t in took):
                took.append(j)
        recur = max(recur, len(took))
    r["recur_out"] = recur
    return r


def surrogate(hs, n, rng):
    """Non-repeating relief like the example: random phases on the example's
    radially averaged power spectrum (per cycle per sample: the same feature
    size at any n), heights rank-matched to the example's."""
    F = np.abs(np.fft.fft2(hs - hs.mean())) ** 2
    fy, fx = np.meshgrid(np.fft.fftfreq(hs.shape[0]), np.fft.fftfreq(hs.shape[1]), indexing="ij")
    fr = np.hypot(fx, fy).ravel()
    bins = np.linspace(0, fr.max() + 1e-9, 40)
    k = np.digitize(fr, bins)
    rad = np.array([F.ravel()[k == i].mean() if (k == i).any() else 0.0 for i in range(1, len(bins))])
    gy, gx = np.meshgrid(np.fft.fftfreq(n), np.fft.fftfreq(n), indexing="ij")
    amp = np.sqrt(np.interp(np.hypot(gx, gy), 0.5 * (bins[1:] + bins[:-1]), rad))
    amp[0, 0] = 0
    g = np.real(np.fft.ifft2(amp * np.exp(2j * np.pi * rng.random((n, n)))))
    q = np.interp(np.linspace(0, 1, n * n), np.linspace(0, 1, hs.size), np.sort(hs.ravel()))
    out = np.empty(n * n)
    out[np.argsort(g.ravel())] = q
    return out.reshape(n, n)


def surrogates(hs, ho, count):
    """The area bias of ncc_out: the figures of `count` surrogates the size
    of the example and `count` the size of the output (seeded: the same
    every time)."""
    rng = np.random.default_rng(1)
    small, large, area = [], [], []
    for _ in range(count):
        small.append(measure(hs, surrogate(hs, hs.shape[0], rng))["ncc_out"])
        r = measure(hs, surrogate(hs, ho.shape[0], rng))
        large.append(r["ncc_out"])
        area.append(r["ncc_out_area"])
    return {"count": count, "example_size": hs.shape[0], "output_size": ho.shape[0],
            "ncc_out_example_size": [round(c, 3) for c in small],
            "ncc_out_output_size": [round(c, 3) for c in large],
            "ncc_out_area_output_size": [round(c, 3) for c in area],
            "mean_example_size": float(np.mean(small)), "mean_output_size": float(np.mean(large)),
            "mean_area_output_size": float(np.mean(area))}


def main():
    run = sys.argv[1]
    f = h5py.File(run + "/field.h5", "r")
    s, o = f["/source/levels"], f["/field/levels"]
    hs = heights(np.asarray(s), s.attrs["lo"], s.attrs["hi"])
    ho = heights(np.asarray(o), o.attrs["lo"], o.attrs["hi"])
    if "--surrogates" in sys.argv[2:]:
        n = int(sys.argv[sys.argv.index("--surrogates") + 1])
        print(json.dumps(surrogates(hs, ho, n)))
        return
    if "--tile" in sys.argv[2:]:
        ho = np.tile(hs, (2, 2))
    print(json.dumps(measure(hs, ho)))


if __name__ == "__main__":
    main()
