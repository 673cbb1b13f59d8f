#!/usr/bin/python3
"""Discs of a height-field run (texture.ini, #19 item 2), from field.h5 alone.

usage: field_discs.py RUN_DIR [RUN_DIR ...]   -> one line per run

The height at (x, y) is the inside extent along z (sum of clip(0.5 - d, 0, 1)
over z, d in samples); the discs are the components (4-connected) of heights
below the mid-range that touch no border of the map, of output and source
alike. Prints their count, median area, the share of discs smaller than 3/4
of the source's median (cut discs, "crescents") and the median of area /
(pi r^2), r the largest inscribed radius (1 for a disc, more for a ragged
or cut one).
"""
import sys

import h5py
import numpy as np
from scipy import ndimage


def levels(path, name):
    with h5py.File(path, "r") as f:
        d = f[name]
        lo, hi = float(d.attrs["lo"]), float(d.attrs["hi"])
        return lo + d[()].astype(np.float64) * (hi - lo) / 255.0  # [z][y][x]


def discs(d):
    h = np.clip(0.5 - d, 0, 1).sum(axis=0)
    m = h < (h.min() + h.max()) / 2
    lab, n = ndimage.label(m)
    border = set(np.unique(np.concatenate([lab[0], lab[-1], lab[:, 0], lab[:, -1]]))) - {0}
    keep = [i for i in range(1, n + 1) if i not in border]
    e = ndimage.distance_transform_edt(m)
    sizes = np.array([(lab == i).sum() for i in keep], dtype=np.float64)
    radii = np.array([e[lab == i].max() for i in keep], dtype=np.float64)
    return sizes, radii


def main(argv):
    for run in argv[1:]:
        so, ro = discs(levels(run + "/field.h5", "field/levels"))
        ss, rs = discs(levels(run + "/field.h5", "source/levels"))
        full = np.median(ss)
        print(f"{run}: discs {len(so)} (source {len(ss)}), median area {np.median(so):.0f} "
              f"(source {full:.0f}), cut (< 3/4 of the source's median) {(so < 0.75 * full).mean():.2f} "
              f"(source {(ss < 0.75 * full).mean():.2f}), area/(pi r^2) median "
              f"{np.median(so / (np.pi * ro ** 2)):.2f} (source {np.median(ss / (np.pi * rs ** 2)):.2f})")


if __name__ == "__main__":
    main(sys.argv)
