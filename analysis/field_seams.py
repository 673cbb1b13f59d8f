#!/usr/bin/python3
"""Seams of a field run, from field.h5 alone (/field/levels, /source/levels):
how much larger the field's steps are across the planes where the last
iteration's pieces meet than elsewhere.

  analysis/field_seams.py RUN_DIR PERIOD [--dataset NAME]   -> one JSON line

The last iteration copies blocks at a stride of PERIOD = block/2 samples, so
neighbouring pieces meet between samples i and i+1 with i % PERIOD ==
PERIOD - 1 along every axis along which pieces meet. seam_ratio = mean
|level difference| of neighbours across those planes / mean elsewhere, over
the axes longer than 2 PERIOD samples (as plane_ratio_max below): 1 = no
seams, a rectangular patchwork is well above 1. An axis one block deep has
no seams (terrain.ini's 16-sample slab in z): counting it measured the
height distribution, not seams, since its steps across the surface are
about four times those along x and y (terrain seed 2: x and y 1.053 against
the example's 1.050, z 1.660 against 1.501, pooled 1.113). The example has
no pieces: its ratio at every phase of the same period (source_ratio_max,
the largest) on the same axes shows how far from 1 chance alone goes, the
threshold a test uses. axes: the axes counted (x, y, z).

plane_ratio_max: the largest mean step of one plane on the seam phase over the
mean of all planes of its axis, over the axes along which pieces meet (longer
than 2 PERIOD samples: a slab one block deep has no seams across z). A
straight seam along one whole plane (target regions used to leave them:
terrain.ini 2.6) stands out here while the mean over all planes hides it;
source_plane_max, the largest plane of the example on the same axes (any
phase), is the threshold.

--dataset NAME measures NAME instead of /field/levels: /synthesis/levels is
the synthesized field before field.complete_objects rebuilt it from whole
source objects (what the synthesis itself made). summary.json holds the same
seam_ratio as seam_ratio_out and synthesis_seam_ratio, the source's
largest phase as seam_ratio_src_max (src/field/report.c).
"""
import json
import sys

import h5py
import numpy as np


def seam_axes(shape, period):
    """axes (numpy order, z y x) longer than 2 periods: where pieces meet."""
    return [ax for ax in range(3) if shape[ax] > 2 * period]


def ratios(lv, period, axes):
    """ratio at each phase p: planes i % period == p against the others."""
    lv = lv.astype(np.float64)
    out = []
    for p in range(period):
        on = off = 0.0
        non = noff = 0
        for ax in axes:
            d = np.abs(np.diff(lv, axis=ax))
            idx = np.arange(d.shape[ax]) % period == p
            sel = [slice(None)] * 3
            sel[ax] = idx
            a = d[tuple(sel)]
            sel[ax] = ~idx
            b = d[tuple(sel)]
            on += a.sum(); non += a.size
            off += b.sum(); noff += b.size
        out.append((on / max(non, 1)) / max(off / max(noff, 1), 1e-12))
    return out


def plane_ratios(lv, period, grid_only):
    """largest plane step over its axis' mean, axes longer than 2 periods."""
    lv = lv.astype(np.float64)
    best = 0.0
    for ax in range(3):
        if lv.shape[ax] <= 2 * period:
            continue
        d = np.abs(np.diff(lv, axis=ax))
        m = d.mean(axis=tuple(a for a in range(3) if a != ax))
        r = m / max(m.mean(), 1e-12)
        if grid_only:
            r = r[period - 1::period]
        best = max(best, float(r.max()) if r.size else 0.0)
    return best


def main():
    run, period = sys.argv[1], int(sys.argv[2])
    name = sys.argv[sys.argv.index("--dataset") + 1] if "--dataset" in sys.argv else "/field/levels"
    with h5py.File(run + "/field.h5", "r") as f:
        out = f[name][...]
        src = f["/source/levels"][...]
    axes = seam_axes(out.shape, period)
    r = ratios(out, period, axes)
    s = ratios(src, period, axes)
    print(json.dumps({"run": run, "period": period, "axes": "".join("zyx"[a] for a in sorted(axes, reverse=True)),
                      "seam_ratio": round(r[period - 1], 4),
                      "source_ratio_max": round(max(s), 4), "source_ratio_min": round(min(s), 4),
                      "plane_ratio_max": round(plane_ratios(out, period, True), 4),
                      "source_plane_max": round(plane_ratios(src, period, False), 4)}))


if __name__ == "__main__":
    main()
