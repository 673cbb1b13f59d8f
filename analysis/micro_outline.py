#!/usr/bin/env python3
"""Shape measures of a micro instance's regions, from its mesh.ply and
micro.h5 alone (issue 20 item 3: round outlines where the distribution asks
for discs, no hexagonal plateaus of the dual graph's hop metric).

metric_excess: the largest |x_i - x_j| / |c_i - c_j| over pairs of triangles
  of one region whose centroids lie 3..6 units apart (x: /micro/triangle_value,
  c: centroids in distribution units; on a sphere of radius >= 10 units the
  chord is within 0.4% of the geodesic there). The reconstruction keeps
  |x_i - x_j| <= d(i, j) in its own metric and its cones x = a - d(seed, .)
  fill the regions, so this is that metric's largest excess over the straight
  line: >= 2/sqrt(3) = 1.155 for hop paths over the dual graph (a honeycomb:
  its paths run 1.155-1.36x the straight line on a regular mesh, the
  hexagons), about 1.035 for the ring graph. Meaningful on the
  reconstruction's own values (micro.correct = no); the correction pass
  replaces them by measured distances.
discs: per region of at least min_area units^2 (regions: edge-connected
  triangles of one sign of /micro/triangle_distance): area, equivalent radius
  r = sqrt(area / pi), perimeter / (2 pi r) (interface edge length; a disc
  traced on a regular triangle mesh gives 1.10, the staircase of its edges),
  and the radial profile's coefficient of variation about the region's
  centroid (0 for a disc, 0.03 for a regular hexagon).

summary (per side): the regions of at least min_area except a side's
  largest when it holds over half that side's area (the surrounding sea or
  land, not a disc), their count, the
  area-weighted mean of perimeter / 2 pi r and of radial cv, and the largest
  area over the median (merged discs show as a few regions many times the
  others').

usage: micro_outline.py INSTANCE_DIR [--json] [--min-area A] (default 100 units^2)
"""
import json
import os
import sys

import h5py
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gsio  # noqa: E402


def load(inst):
    v, f = gsio.read_ply(os.path.join(inst, "mesh.ply"))
    with h5py.File(os.path.join(inst, "micro.h5"), "r") as h:
        x = h["/micro/triangle_value"][...]
        d = h["/micro/triangle_distance"][...]
        upm = float(h["/micro"].attrs["units_per_model"])
    return v.astype(np.float64) * upm, np.asarray(f, dtype=np.int64), x, d


def metric_excess(v, f, x, lo=3.0, hi=6.0, samples=3000, seed=1):
    c = v[f].mean(axis=1)
    tree = cKDTree(c)
    rng = np.random.default_rng(seed)
    pick = rng.choice(len(f), size=min(samples, len(f)), replace=False)
    worst = 0.0
    for i in pick:
        js = np.array(tree.query_ball_point(c[i], hi), dtype=np.int64)
        if len(js) == 0:
            continue
        e = np.linalg.norm(c[js] - c[i], axis=1)
        m = (e >= lo) & (np.sign(x[js]) == np.sign(x[i])) & (x[i] != 0)
        if m.any():
            worst = max(worst, float(np.max(np.abs(x[js[m]] - x[i]) / e[m])))
    return worst


def discs(v, f, d, min_area=100.0):
    side = d > 0
    a = 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
    cen = v[f].mean(axis=1)
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    t = np.tile(np.arange(len(f)), 3)
    key = np.minimum(e[:, 0], e[:, 1]) * (len(v) + 1) + np.maximum(e[:, 0], e[:, 1])
    o = np.argsort(key, kind="stable")
    ks, ts, es = key[o], t[o], e[o]
    same = ks[1:] == ks[:-1]
    p, q = ts[:-1][same], ts[1:][same]
    ea, eb = es[:-1][same, 0], es[:-1][same, 1]
    el = np.linalg.norm(v[ea] - v[eb], axis=1)
    mid = 0.5 * (v[ea] + v[eb])
    inner = side[p] == side[q]
    n = len(f)
    g = coo_matrix((np.ones(int(inner.sum())), (p[inner], q[inner])), shape=(n, n))
    nc, lab = connected_components(g, directed=False)
    out = []
    for r in range(nc):
        m = lab == r
        A = float(a[m].sum())
        if A < min_area:
            continue
        bm = (~inner) & ((lab[p] == r) | (lab[q] == r))
        if not bm.any():
            continue
        ctr = (cen[m] * a[m, None]).sum(0) / A
        nrm = ctr / np.linalg.norm(ctr) if np.linalg.norm(ctr) > 0 else np.array([0.0, 0.0, 1.0])
        b = mid[bm] - ctr
        b = b - np.outer(b @ nrm, nrm)
        ax = np.cross(nrm, [1.0, 0.0, 0.0])
        if np.linalg.norm(ax) < 0.1:
            ax = np.cross(nrm, [0.0, 1.0, 0.0])
        ax /= np.linalg.norm(ax)
        ay = np.cross(nrm, ax)
        rad = np.hypot(b @ ax, b @ ay)
        phi = np.arctan2(b @ ay, b @ ax)
        sec = ((phi + np.pi) / (2 * np.pi) * 72).astype(int) % 72
        prof = np.array([rad[sec == s].mean() if np.any(sec == s) else np.nan for s in range(72)])
        req = np.sqrt(A / np.pi)
        out.append({"positive": bool(side[m][0]), "area": A, "radius": float(req),
                    "perimeter_ratio": float(el[bm].sum() / (2 * np.pi * req)),
                    "radial_cv": float(np.nanstd(prof) / np.nanmean(prof))})
    return out


def summary(regions):
    out = {}
    for side, name in ((True, "positive"), (False, "negative")):
        rs = sorted((r for r in regions if r["positive"] == side), key=lambda r: -r["area"])
        if rs and rs[0]["area"] > 0.5 * sum(r["area"] for r in rs):
            rs = rs[1:]  # the region around the others
        if not rs:
            out[name] = {"count": 0}
            continue
        a = np.array([r["area"] for r in rs])
        out[name] = {"count": len(rs),
                     "perimeter_ratio": float(np.average([r["perimeter_ratio"] for r in rs], weights=a)),
                     "radial_cv": float(np.average([r["radial_cv"] for r in rs], weights=a)),
                     "largest_over_median": float(a.max() / np.median(a))}
    return out


def main():
    inst = sys.argv[1]
    v, f, x, d = load(inst)
    ma = float(sys.argv[sys.argv.index("--min-area") + 1]) if "--min-area" in sys.argv else 100.0
    res = {"metric_excess": metric_excess(v, f, x), "discs": discs(v, f, d, min_area=ma)}
    res["summary"] = summary(res["discs"])
    if "--json" in sys.argv:
        print(json.dumps(res))
        return
    print("metric excess (max |dx| / straight line, 3-6 units): %.3f" % res["metric_excess"])
    for name, sm in res["summary"].items():
        if sm["count"]:
            print("%s regions (not the surrounding one): %d, area-weighted perimeter / 2 pi r %.2f, radial cv %.3f, "
                  "largest / median area %.1f" % (name, sm["count"], sm["perimeter_ratio"], sm["radial_cv"],
                                                  sm["largest_over_median"]))
    for r in sorted(res["discs"], key=lambda r: -r["area"]):
        print("  %s region: area %.0f, r %.1f, perimeter / 2 pi r %.2f, radial cv %.3f"
              % ("positive" if r["positive"] else "negative", r["area"], r["radius"],
                 r["perimeter_ratio"], r["radial_cv"]))


if __name__ == "__main__":
    main()
