#!/usr/bin/python3
"""Large-scale repetition of a height-field run, from field.h5 alone
(/field/levels, /source/levels): "the same mountain twice".

  analysis/field_repeats.py RUN_DIR [--tile]   -> one JSON line

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
--tile measures a 2x2 tiling of the example instead of the output (a
repetition the measure must flag).
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


def best_pair(W, w, st, floor, reach):
    x, y, rms, v = W
    ok = rms >= floor
    a = np.where(ok & (x % st == 0) & (y % st == 0))[0]
    b = np.where(ok)[0]
    best = -1.0
    for i in a:
        dx, dy = np.abs(x[b] - x[i]), np.abs(y[b] - y[i])
        sel = b[((dx >= w) | (dy >= w)) & (dx <= reach) & (dy <= reach)]
        if len(sel):
            best = max(best, float((v[sel] @ v[i]).max()))
    return best


def measure(hs, ho):
    sny, snx = hs.shape
    w = feature_size(hs)
    st = max(1, w // 4)
    reach = max(snx, sny)
    S, O = windows(hs, w), windows(ho, w)
    relief = float(np.median(S[2]))
    r = {"window": int(w), "stride": st, "relief": relief,
         "ncc_src": best_pair(S, w, st, relief, reach), "ncc_out": best_pair(O, w, st, relief, reach)}
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


def main():
    run = sys.argv[1]
    f = h5py.File(run + "/field.h5", "r")
    s, o = f["/source/levels"], f["/field/levels"]
    hs = heights(np.asarray(s), s.attrs["lo"], s.attrs["hi"])
    ho = heights(np.asarray(o), o.attrs["lo"], o.attrs["hi"])
    if "--tile" in sys.argv[2:]:
        ho = np.tile(hs, (2, 2))
    print(json.dumps(measure(hs, ho)))


if __name__ == "__main__":
    main()
