#!/usr/bin/python3
"""Contacts between the objects of a field run (balls.ini's balls), from
field.h5 alone (/field/levels and /source/levels, the same figures for both).

usage: field_contacts.py RUN_DIR_or_field.h5 [--json] [--dataset NAME]

An object is a component of the core (the samples deeper than one sample
spacing: balls that touch are apart there, analysis/field_objects.py
--core). Each inside sample (distance < 0) belongs to the object whose core
it reaches first through the inside (breadth first, 6-neighbours). Two
objects touch when samples they own are 6-neighbours. Objects whose core
touches a face of the grid are counted as neighbours but not as objects
(they are cut by the box).

Printed for output and source:
- touching: share of the objects that touch at least one other;
- contacts: mean number of objects an object touches;
- density: objects (cores) per 10^3 samples, and their mean radius, from the
  core's volume (r = (3 V / 4 pi)^(1/3) + 1 sample);
- overlap: share of touching pairs whose centres (cores' centroids) are
  closer than 0.85 of the sum of their radii (balls of a physical drop do not
  overlap: the source's touching pairs sit at the sum, within the
  sampling), and the median of centre distance / sum of radii over touching
  pairs.
--dataset NAME reads the output from NAME instead of /field/levels (e.g.
/synthesis/levels, the field before field.complete_objects rebuilt it).
"""
import json
import sys

import h5py
import numpy as np
from scipy import ndimage


def levels(f, name):
    d = f[name]
    lo, hi = float(d.attrs["lo"]), float(d.attrs["hi"])
    return lo + d[()].astype(np.float64) * (hi - lo) / 255.0


def contacts(dist, spacing):
    inside = dist < 0
    core = dist < -spacing
    lab, n = ndimage.label(core)
    if n == 0:
        return {"objects": 0}
    border = set()
    for sl in (lab[0], lab[-1], lab[:, 0], lab[:, -1], lab[:, :, 0], lab[:, :, -1]):
        border.update(np.unique(sl).tolist())
    border.discard(0)
    # owner: breadth first from the cores through the inside (one sample a
    # round; among several cores reaching a sample in the same round the
    # highest label, as a grey dilation does)
    own = lab.copy()
    foot = ndimage.generate_binary_structure(3, 1)
    while True:
        grow = ndimage.grey_dilation(own, footprint=foot)
        new = inside & (own == 0) & (grow > 0)
        if not new.any():
            break
        own[new] = grow[new]
    pairs = set()
    for ax in range(3):
        a = np.moveaxis(own, ax, 0)
        u, v = a[:-1].ravel(), a[1:].ravel()
        m = (u > 0) & (v > 0) & (u != v)
        for p, q in zip(u[m].tolist(), v[m].tolist()):
            pairs.add((min(p, q), max(p, q)))
    idx = np.arange(1, n + 1)
    vol = ndimage.sum(core, lab, idx)
    rad = (3 * vol / (4 * np.pi)) ** (1 / 3) + 1.0
    cen = np.array(ndimage.center_of_mass(core, lab, idx))
    deg = np.zeros(n + 1, dtype=int)
    ratio = []
    for p, q in pairs:
        deg[p] += 1
        deg[q] += 1
        if p in border and q in border:
            continue
        ratio.append(np.linalg.norm(cen[p - 1] - cen[q - 1]) / (rad[p - 1] + rad[q - 1]))
    keep = np.array([i not in border for i in idx])
    kd = deg[1:][keep]
    ratio = np.array(ratio)
    return {
        "objects": int(keep.sum()),
        "touching": round(float(np.mean(kd > 0)), 4) if kd.size else 0.0,
        "contacts": round(float(np.mean(kd)), 3) if kd.size else 0.0,
        "density_per_1000": round(1000.0 * n / dist.size, 3),
        "radius_mean": round(float(rad[keep].mean()), 3) if kd.size else 0.0,
        "overlap_pairs": round(float(np.mean(ratio < 0.85)), 4) if ratio.size else 0.0,
        "centre_over_radii_median": round(float(np.median(ratio)), 4) if ratio.size else 0.0,
    }


def main(argv):
    run = argv[1]
    h5 = run if run.endswith(".h5") else run + "/field.h5"
    name = argv[argv.index("--dataset") + 1] if "--dataset" in argv else "field/levels"
    with h5py.File(h5, "r") as f:
        sp = float(f["field/distance"].attrs["spacing"])
        out, src = levels(f, name), levels(f, "source/levels")
    o, s = contacts(out, sp), contacts(src, sp)
    res = {k + "_out": v for k, v in o.items()}
    res.update({k + "_src": v for k, v in s.items()})
    if "--json" in argv:
        print(json.dumps(res))
        return
    for k in o:
        print(f"{k:26s} out {o[k]!s:>10}  source {s.get(k)!s:>10}")


if __name__ == "__main__":
    main(sys.argv)
