#!/usr/bin/python3
"""Whole objects of a field run (#19 item 3), from field.h5 alone.

usage: field_objects.py RUN_DIR [--png FILE] [--slices K] [--json] [--bulk M] [--core]

Reads the output's and the source's quantized levels (field/levels,
source/levels), takes the inside region (distance < 0) of each, labels its
6-connected components (as src/measure/stats.c) and drops the components
that touch the grid's border (they are cut by the box, in the source as in
the output). For the rest it prints count, sizes, the largest inscribed
sphere radius (max -distance inside the component), the share of "fragments"
(components smaller than half the source's smallest interior component) and
the KS distance of the size distributions. With --png it writes K z-slices
of output and source with interior components coloured, fragments in red;
with --json it prints the figures as one JSON object instead. With --bulk M
it also gives volume fraction and surface per volume (sign changes between
6-neighbours per sample) of both with M samples at every face left out: an
example made in a box (balls.ini: balls dropped into a box, centres at least
a radius from its walls) is sparser near its walls than in its bulk (balls
64^3: volume fraction 0.200 overall, 0.260 at depth >= 5), while the output
has no walls. With --core the components are those of the core, the
samples deeper than one sample spacing, instead of the inside: objects that
touch (balls.ini's balls, dropped into a box, touch: 10 inside components
for 205 balls' cores at 64^3) are apart there, so each is counted alone.
"""
import sys

import h5py
import numpy as np
from scipy import ndimage


def levels(path, name):
    with h5py.File(path, "r") as f:
        d = f[name]
        lo, hi = float(d.attrs["lo"]), float(d.attrs["hi"])
        q = d[()].astype(np.float64)
    return lo + q * (hi - lo) / 255.0  # [z][y][x]


def spacing(path):
    with h5py.File(path, "r") as f:
        return float(f["field/distance"].attrs["spacing"])


def objects(dist, below=0.0):
    inside = dist < below
    lab, n = ndimage.label(inside)  # 6-connected by default
    border = set()
    for sl in (lab[0], lab[-1], lab[:, 0], lab[:, -1], lab[:, :, 0], lab[:, :, -1]):
        border.update(np.unique(sl).tolist())
    border.discard(0)
    idx = np.arange(1, n + 1)
    sizes = ndimage.sum(inside, lab, idx) if n else np.zeros(0)
    rad = ndimage.maximum(-dist, lab, idx) if n else np.zeros(0)
    keep = np.array([i not in border for i in idx], dtype=bool)
    return lab, idx[keep], np.asarray(sizes)[keep], np.asarray(rad)[keep], n


def sign_changes(ins):
    return sum(np.count_nonzero(np.diff(ins.astype(np.int8), axis=a)) for a in range(3)) / ins.size


def ks(a, b):
    if len(a) == 0 or len(b) == 0:
        return 1.0
    a, b = np.sort(a), np.sort(b)
    t = np.concatenate([a, b])
    return float(np.max(np.abs(np.searchsorted(a, t, "right") / len(a)
                               - np.searchsorted(b, t, "right") / len(b))))


def main(argv):
    run = argv[1]
    png = argv[argv.index("--png") + 1] if "--png" in argv else None
    k = int(argv[argv.index("--slices") + 1]) if "--slices" in argv else 3
    h5 = run if run.endswith(".h5") else run + "/field.h5"
    out, src = levels(h5, "field/levels"), levels(h5, "source/levels")
    below = -spacing(h5) if "--core" in argv else 0.0
    lo, io, so, ro, no = objects(out, below)
    ls, is_, ss, rs, ns = objects(src, below)
    smin = ss.min() if len(ss) else 0
    frag = 0.5 * smin
    bulk = int(argv[argv.index("--bulk") + 1]) if "--bulk" in argv else 0
    if "--json" in argv:
        import json
        fig = {"fragment_size": float(frag), "size_ks": ks(so, ss), "radius_ks": ks(ro, rs),
               "median_src": float(np.median(ss)) if len(ss) else 0.0,
               "median_out": float(np.median(so)) if len(so) else 0.0}
        for name, s, r, d in (("src", ss, rs, src), ("out", so, ro, out)):
            fig["interior_" + name] = int(len(s))
            fig["fragments_" + name] = float(np.mean(s < frag)) if len(s) else 0.0
            fig["vf_" + name] = float(np.mean(d < 0))
            if bulk:
                b = d[bulk:-bulk, bulk:-bulk, bulk:-bulk] < 0
                fig["bulk_vf_" + name] = float(b.mean())
                fig["bulk_spv_" + name] = float(sign_changes(b))
        print(json.dumps(fig))
        return
    for name, s, r, n, d in (("source", ss, rs, ns, src), ("output", so, ro, no, out)):
        vol = d.size
        print(f"{name}: {n} components, {len(s)} interior ({1e6 * len(s) / vol:.1f} per 1e6 "
              f"samples), size median {np.median(s) if len(s) else 0:.0f} min "
              f"{s.min() if len(s) else 0:.0f}, inscribed radius median "
              f"{np.median(r) if len(r) else 0:.2f} min {r.min() if len(r) else 0:.2f}, "
              f"fragments (< {frag:.0f} samples) {np.mean(s < frag) if len(s) else 0:.3f}, "
              f"volume fraction {np.mean(d < 0):.4f}")
    print(f"size KS {ks(so, ss):.3f}, inscribed radius KS {ks(ro, rs):.3f}")
    if bulk:
        for name, d in (("source", src), ("output", out)):
            b = d[bulk:-bulk, bulk:-bulk, bulk:-bulk] < 0
            print(f"{name} bulk (depth >= {bulk}): volume fraction {b.mean():.4f}, surface per "
                  f"volume {sign_changes(b):.4f}")
    if png:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(2, k, figsize=(4 * k, 8))
        for row, (name, lab, keep, s, d) in enumerate((("output", lo, io, so, out),
                                                       ("source", ls, is_, ss, src))):
            colour = np.zeros(lab.max() + 1)
            colour[keep] = np.where(s < frag, 2, 1)
            nz = d.shape[0]
            for j in range(k):
                z = int((j + 0.5) * nz / k)
                img = colour[lab[z]]
                a = ax[row, j]
                a.imshow(np.where(d[z] < 0, 0.5, 0) + img, origin="lower", cmap="magma",
                         vmin=0, vmax=2.5, interpolation="nearest")
                a.set_title(f"{name} z={z} (grey: border-cut, orange: whole, white: fragment)",
                            fontsize=7)
        fig.tight_layout()
        fig.savefig(png, dpi=90)
        print("wrote", png)


if __name__ == "__main__":
    main(sys.argv)
