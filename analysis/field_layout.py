#!/usr/bin/python3
"""Layout of separate objects in a field run (#19), from field.h5 alone.

usage: field_layout.py RUN_DIR [RUN_DIR ...] [--json] [--check]

The same figures as src/measure/layout.c (gs_measure_layout) and the run's
summary.json layout_*, for output and source alike:

- objects: for a height field (the source's inside reaches its bottom face
  everywhere) the objects are the 4-connected components of the columns
  whose height (inside extent along z: sum of clip(0.5 - d, 0, 1) over z, d
  in samples) is below the mid-range of that map's heights (texture.ini's
  discs); otherwise the 6-connected components of the core, the samples
  deeper than one sample (balls that touch are apart there, as in
  field.complete_objects).
- centre: the mean position of an object's samples. Objects that touch a
  face of the grid are cut by the box: they count as neighbours but are not
  measured themselves.
- nn: per measured object, the distance to the nearest other object's centre
  (samples); nn_p10/p50 of output and source, and their KS distance.
- close share: measured objects whose nn is below the source's smallest nn
  (objects crowded closer than any two in the example: clumps).
- fused share: measured objects larger than 1.5 x the source's largest
  measured object (two or more glued into one).
- fragment share: measured objects smaller than 3/4 of the source's
  smallest measured object (pieces of an object a later block left:
  crescents, slivers; the cut ratio of field_discs.py).
- merged share: measured objects reaching farther from their centre (largest
  distance of a sample from it) than the source's largest such radius plus
  half a sample (two objects glued, or one grown by a piece of another at a
  seam: elongated or bulging discs).
- guarded (layout_guard*): the output's measured objects whose centre lies
  at least the source's largest nn plus its largest object radius (largest
  distance of a sample from its object's centre) from every face: every
  object within the source's spacing of them is whole (the box moves a cut
  object's centre off its own); their close share and nn KS.

With --check it compares every figure with the run's summary.json and exits
1 on a difference (what e2e tests use to keep the C and Python equal).
"""
import json
import sys

import h5py
import numpy as np
from scipy import ndimage

import field_objects

FUSED = 1.5


def levels(h5, name):
    with h5py.File(h5, "r") as f:
        d = f[name]
        lo, hi = float(d.attrs["lo"]), float(d.attrs["hi"])
        sp = float(f["field/distance"].attrs["spacing"])
        q = d[()].astype(np.float64)
    return (lo + q * (hi - lo) / 255.0) / sp  # [z][y][x], in samples


def is_height_field(src):
    return bool((src[0] < 0).all())


def object_mask(d, height):
    if height:
        h = np.clip(0.5 - d, 0, 1).sum(axis=0)
        return (h < (h.min() + h.max()) / 2)[None]  # [1][y][x]
    return d < -1.0


def objects(mask, radii=False):
    """centres [n][3] (x, y, z), sizes, interior flags (and with radii the
    largest distance of a sample from its centre)."""
    struct = ndimage.generate_binary_structure(3, 1)
    lab, n = ndimage.label(mask, structure=struct)
    if n == 0:
        e = (np.zeros((0, 3)), np.zeros(0), np.zeros(0, dtype=bool))
        return e + (np.zeros(0),) if radii else e
    idx = np.arange(1, n + 1)
    sizes = ndimage.sum(mask, lab, idx)
    zz, yy, xx = np.indices(mask.shape)
    c = np.stack([ndimage.mean(xx, lab, idx), ndimage.mean(yy, lab, idx),
                  ndimage.mean(zz, lab, idx)], axis=1)
    border = set()
    for a in range(3):
        if mask.shape[a] == 1:
            continue
        border.update(np.unique(np.take(lab, 0, axis=a)).tolist())
        border.update(np.unique(np.take(lab, -1, axis=a)).tolist())
    border.discard(0)
    interior = np.array([i not in border for i in idx], dtype=bool)
    if radii:
        zs, ys, xs = np.nonzero(lab)
        l = lab[zs, ys, xs] - 1
        r = np.sqrt((xs - c[l, 0]) ** 2 + (ys - c[l, 1]) ** 2 + (zs - c[l, 2]) ** 2)
        rad = np.zeros(n)
        np.maximum.at(rad, l, r)
        return c, np.asarray(sizes, dtype=np.float64), interior, rad
    return c, np.asarray(sizes, dtype=np.float64), interior


def nearest(c, interior):
    out = []
    for i in np.flatnonzero(interior):
        d = np.sqrt(((c - c[i]) ** 2).sum(axis=1))
        d[i] = np.inf
        out.append(d.min() if len(c) > 1 else np.inf)
    return np.array(out)


def quantile(s, p):
    """As gs_measure_layout: the sorted value at round(p (n - 1))."""
    if len(s) == 0:
        return 0.0
    s = np.sort(s)
    return float(s[int(p * (len(s) - 1) + 0.5)])


def figures(h5):
    out, src = levels(h5, "field/levels"), levels(h5, "source/levels")
    height = is_height_field(src)
    co, so, io, ro = objects(object_mask(out, height), radii=True)
    cs, ss, is_, rs = objects(object_mask(src, height), radii=True)
    no, ns = nearest(co, io), nearest(cs, is_)
    no, ns = no[np.isfinite(no)], ns[np.isfinite(ns)]
    nn_min = float(ns.min()) if len(ns) else 0.0
    big = float(ss[is_].max()) if is_.any() else 0.0
    small = 0.75 * float(ss[is_].min()) if is_.any() else 0.0
    reach = (float(rs[is_].max()) if is_.any() else 0.0) + 0.5
    f = {"layout_height_field": int(height)}
    for tag, nn, s, i, r in (("out", no, so, io, ro), ("src", ns, ss, is_, rs)):
        f[f"layout_objects_{tag}"] = int(i.sum())
        f[f"layout_nn_p10_{tag}"] = quantile(nn, 0.1)
        f[f"layout_nn_p50_{tag}"] = quantile(nn, 0.5)
        f[f"layout_close_share_{tag}"] = float((nn < nn_min).mean()) if len(nn) else 0.0
        f[f"layout_fused_share_{tag}"] = float((s[i] > FUSED * big).mean()) if i.any() else 0.0
        f[f"layout_fragment_share_{tag}"] = float((s[i] < small).mean()) if i.any() else 0.0
        f[f"layout_merged_share_{tag}"] = float((r[i] > reach).mean()) if i.any() else 0.0
    # gs_measure_ks: both empty 0, one empty 1
    f["layout_nn_ks"] = 0.0 if len(no) == len(ns) == 0 else field_objects.ks(no, ns)
    # guarded: output objects whose centre lies at least the source's largest
    # nn plus its largest object radius from every face (neighbours within the
    # source's spacing are then whole, not cut by the box)
    shape = object_mask(out, height).shape  # [z][y][x]
    guard = (float(ns.max()) if len(ns) else 0.0) + (float(rs[is_].max()) if is_.any() else 0.0)
    ig = io.copy()
    for a, n in enumerate((shape[2], shape[1], shape[0])):
        if n > 1:
            ig &= (co[:, a] >= guard) & ((n - 1) - co[:, a] >= guard)
    ng = nearest(co, ig)
    ng = ng[np.isfinite(ng)]
    f["layout_guard"] = guard
    f["layout_guarded_objects_out"] = int(ig.sum())
    f["layout_guarded_close_share_out"] = float((ng < nn_min).mean()) if len(ng) else 0.0
    f["layout_guarded_fragment_share_out"] = float((so[ig] < small).mean()) if ig.any() else 0.0
    f["layout_guarded_merged_share_out"] = float((ro[ig] > reach).mean()) if ig.any() else 0.0
    f["layout_guarded_nn_ks"] = 0.0 if len(ng) == len(ns) == 0 else field_objects.ks(ng, ns)
    return f


def main(argv):
    runs = [a for a in argv[1:] if not a.startswith("--")]
    bad = 0
    for run in runs:
        h5 = run if run.endswith(".h5") else run + "/field.h5"
        f = figures(h5)
        if "--json" in argv:
            print(json.dumps(f))
        else:
            print(f"{run}: objects {f['layout_objects_out']} (source {f['layout_objects_src']}), "
                  f"nn p10/p50 {f['layout_nn_p10_out']:.2f}/{f['layout_nn_p50_out']:.2f} "
                  f"(source {f['layout_nn_p10_src']:.2f}/{f['layout_nn_p50_src']:.2f}), nn KS "
                  f"{f['layout_nn_ks']:.3f}, close {f['layout_close_share_out']:.3f}, fused "
                  f"{f['layout_fused_share_out']:.3f}, fragments {f['layout_fragment_share_out']:.3f}, merged "
                  f"{f['layout_merged_share_out']:.3f}; guarded (>= {f['layout_guard']:.2f} "
                  f"from the faces): objects {f['layout_guarded_objects_out']}, close "
                  f"{f['layout_guarded_close_share_out']:.3f}, fragments "
                  f"{f['layout_guarded_fragment_share_out']:.3f}, merged "
                  f"{f['layout_guarded_merged_share_out']:.3f}, nn KS {f['layout_guarded_nn_ks']:.3f}")
        if "--check" in argv:
            with open(run + "/summary.json") as fh:
                m = json.load(fh)["metrics"]
            for k, v in f.items():
                if k not in m or abs(float(m[k]) - v) > 1e-6 * max(1.0, abs(v)):
                    print(f"{run}: {k} = {m.get(k)} in summary.json, {v} here")
                    bad += 1
    if "--check" in argv:
        print("layout check: " + ("ok" if not bad else f"{bad} differences"))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
