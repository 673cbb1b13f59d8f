#!/usr/bin/python3
"""Copying in a height-field run that a remap of its heights cannot hide, from
field.h5 alone (/field/levels or another dataset, /source/levels). #19 asks for
measures that cannot be fooled: field.height_match moves every column along z
(a monotone map of the heights), so the exact copy measure (copy_*,
src/measure/copy.c) no longer finds the source's levels where a piece was
copied verbatim (field39: terrain.ini's copy_largest_region_of_source ~0.001
where the synthesis copied 0.056 of the example).

  analysis/field_copies.py RUN... [--dataset /synthesis/levels] [--window K]
  analysis/field_copies.py RUN --remapped-tiling   (the check below)

Each column's surface height (field_repeats.py's heights). Every K x K
window of heights (K = 8, half of terrain.ini's block) is replaced by its
ranks (ties averaged), centred and scaled to unit length, so a window and any
increasing map of it are the same vector; two windows are alike by the dot
product of their vectors (Spearman's rank correlation). An output window is
copied from the example window s it is most alike to when it is more alike
to s than any other example window at least 2 samples from s is (the
example's own threshold, window by window: a piece of the example that only
resembles s no better than the example's other places do is not a copy);
constant windows are never copied. Its offset is s - p; a copied region is a
4-connected set of output windows with one offset. Figures (windows counted
by position, as copy_*):

  largest_region_of_source  the largest region / the example's window positions
  large_share               output window positions in regions larger than one
                            block gives ((B - K + 1)^2, B = 16) / all
  matched_share             output window positions copied / all
  completeness              example window positions some output window was
                            copied from / all

--remapped-tiling: the run's example tiled 2 x 2 (4 verbatim copies) and its
heights remapped by an increasing map: onto the run's output's height
distribution (rank for rank, as field.height_match), then h -> exp(1.5 h)
(far from affine): largest_region_of_source must read about 1 (each tile a
whole copy of the example) where the exact copy measure would read 0 (with
windows of heights instead of ranks: 0.046).
"""
import json
import sys

import h5py
import numpy as np
from scipy import ndimage

from field_repeats import heights

BLOCK = 16


def ranked_windows(h, k):
    ny, nx = h.shape
    w = np.lib.stride_tricks.sliding_window_view(h, (k, k)).reshape(ny - k + 1, nx - k + 1, k * k)
    # ranks with ties averaged (scipy.stats.rankdata's "average")
    from scipy.stats import rankdata
    r = rankdata(w, axis=-1).astype(np.float64)
    r -= r.mean(-1, keepdims=True)
    n = np.sqrt((r * r).sum(-1, keepdims=True))
    flat = n[..., 0] <= 1e-9
    r = np.where(n > 1e-9, r / np.maximum(n, 1e-12), 0.0)
    return r.astype(np.float32), flat


def measure(ho, hs, k=8, maps=None):
    wo, fo = ranked_windows(ho, k)
    ws, fs = ranked_windows(hs, k)
    my, mx = ws.shape[:2]
    S = ws.reshape(-1, k * k)
    ns = S.shape[0]
    sy, sx = np.divmod(np.arange(ns), mx)
    # the example's own threshold: each example window's best likeness to
    # another example window at least 2 samples away (Chebyshev)
    thr = np.empty(ns, np.float32)
    for a in range(0, ns, 512):
        g = S[a:a + 512] @ S.T
        near = (np.abs(sy[a:a + 512, None] - sy[None, :]) < 2) & (np.abs(sx[a:a + 512, None] - sx[None, :]) < 2)
        g[near] = -2
        thr[a:a + 512] = g.max(1)
    thr[fs.ravel()] = 2  # constant example windows: never a source
    oy, ox = wo.shape[:2]
    O = wo.reshape(-1, k * k)
    best = np.full(O.shape[0], -1, np.int64)
    for a in range(0, O.shape[0], 512):
        g = O[a:a + 512] @ S.T
        j = g.argmax(1)
        ok = g[np.arange(len(j)), j] > thr[j]
        best[a:a + 512] = np.where(ok, j, -1)
    best[fo.ravel()] = -1
    best = best.reshape(oy, ox)
    py, px = np.indices((oy, ox))
    off = np.where(best >= 0, (sy[np.maximum(best, 0)] - py) * 100000 + (sx[np.maximum(best, 0)] - px), -(1 << 40))
    sizes = []
    size_at = np.zeros(off.shape, np.int64)  # each window position's region size
    for o in np.unique(off[best >= 0]):
        lab, n = ndimage.label(off == o)  # 4-connected
        if n:
            c = np.bincount(lab.ravel())
            sizes.extend(c[1:].tolist())
            size_at[lab > 0] = c[lab[lab > 0]]
    if maps is not None:  # for pictures: source window index (-1: none), region size
        maps["best"], maps["region_size"] = best, size_at
    sizes = np.array(sizes or [0])
    large = (BLOCK - k + 1) ** 2
    used = np.zeros(ns, bool)
    used[best[best >= 0]] = True
    return {"window": k, "positions": int(oy * ox), "source_positions": int(ns),
            "matched_share": float((best >= 0).mean()),
            "largest_region": int(sizes.max()),
            "largest_region_of_source": float(sizes.max() / ns),
            "large_share": float(sizes[sizes > large].sum() / (oy * ox)),
            "regions": int((sizes > 0).sum()),
            "completeness": float(used[~fs.ravel()].mean()) if (~fs).any() else 0.0}


def read(run, name):
    with h5py.File(run + "/field.h5", "r") as f:
        d = f[name]
        return heights(np.asarray(d), d.attrs["lo"], d.attrs["hi"])


def remap_onto(h, target):
    """h's values replaced rank for rank by target's quantiles (increasing)."""
    order = np.argsort(h, axis=None, kind="stable")
    t = np.sort(target, axis=None)
    q = (np.arange(h.size) + 0.5) / h.size * t.size - 0.5
    out = np.empty(h.size)
    out[order] = np.interp(q, np.arange(t.size), t)
    return out.reshape(h.shape)


def main():
    args = sys.argv[1:]
    if not args or args[0] in ("-h", "--help"):
        sys.exit(__doc__)
    dataset, k, tiling = "/field/levels", 8, False
    runs = []
    i = 0
    while i < len(args):
        if args[i] == "--dataset":
            dataset, i = args[i + 1], i + 2
        elif args[i] == "--window":
            k, i = int(args[i + 1]), i + 2
        elif args[i] == "--remapped-tiling":
            tiling, i = True, i + 1
        else:
            runs.append(args[i])
            i += 1
    for run in runs:
        hs = read(run, "/source/levels")
        if tiling:
            ho = remap_onto(np.tile(hs, (2, 2)), read(run, dataset))
            ho = np.exp(1.5 * (ho - ho.min()))  # and far from affine: still increasing
        else:
            ho = read(run, dataset)
        r = measure(ho, hs, k)
        r["run"], r["dataset"] = run, "remapped 2x2 tiling of /source/levels" if tiling else dataset
        print(json.dumps(r))


if __name__ == "__main__":
    main()
