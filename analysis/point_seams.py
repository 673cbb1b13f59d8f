#!/usr/bin/python3
"""Seams of a points run from points.ply alone (x y z nx ny nz and the int
patch id of every point): the twin of gs_measure_point_seams
(src/measure/pointset.c, include/geosynth/measure.h), to check it and to
measure any point set with patch ids.

  analysis/point_seams.py RUN_DIR [RADIUS BAND]   -> one JSON line
  analysis/point_seams.py RUN_DIR --patches CSV   -> one JSON line

--patches CSV (a run's patches.csv): the seam figures of the seam points by
a patch that run warped (warp > 0), their own or the one across, alone (no
inside figures): a run and the same patches without the warp
(points.choices = that patches.csv) compared where the warp acted, not over
the seams it never touched (chainmail 8 x 8: 5-18 of 48 patches warped).

RADIUS (default: summary.json's config mls_radius, else 3 input_spacing) and
BAND (default 1.5 input_spacing) as the engine passes them. A seam point has
a point of another patch within BAND in x y, at any height (that patch: the
nearest such point's);
its fit is the MLS frame (weights (1 - d^2/R^2)^4) of the other patch's
points within R: distance |(p - a).n| and the angle of normals. Inside: each
point with no other patch within R against its own patch's points beyond a
virtual seam: a line across +x, -x, +y, -y at u = band x frac((4 i + d) x
0.618...) from it, kept when a point beyond lies within BAND in x y (the
seam's one-sided geometry at its distances). Fits weighing less than 0.15
are open. Broken (patch_seam_broken, patch_inside_broken): open, or
farther than FAR from the surface across (default: summary.json's
patch_far_dist, the example's inside 90th percentile; else the run's own).
Agrees with summary.json's patch_seam_* / patch_inside_* to 1e-5 relative
(the points are read back as float32): counts and open shares exactly
(chainmail.ini 8 x 8 seed 1: 6836 seam points, open 0.0806), distances and
angles within 3e-6 relative.
"""
import csv
import json
import sys

import numpy as np
from scipy.spatial import cKDTree

MIN_WEIGHT = 0.15


def read_points(path):
    raw = open(path, "rb").read()
    end = raw.index(b"end_header\n") + len(b"end_header\n")
    hdr = raw[:end].decode().split("\n")
    assert hdr[1] == "format binary_little_endian 1.0", hdr[1]
    n = int([l for l in hdr if l.startswith("element vertex")][0].split()[2])
    props = [(l.split()[2], "<i4" if l.split()[1] == "int" else "<f4") for l in hdr
             if l.startswith("property")]
    a = np.frombuffer(raw, dtype=props, count=n, offset=end)
    v = np.stack([a[k].astype(np.float64) for k in ("x", "y", "z", "nx", "ny", "nz")], 1)
    return v, a["patch"].astype(np.int64)


def fit(v, p, idx, inv_r2):
    """(weight, |distance|, angle in degrees) of the MLS frame of v[idx] at p."""
    q = v[idx]
    t = np.maximum(1 - ((q[:, :3] - p[:3]) ** 2).sum(1) * inv_r2, 0) ** 4
    w = t.sum()
    nsum = (t[:, None] * q[:, 3:]).sum(0)
    nn = np.linalg.norm(nsum)
    if w < MIN_WEIGHT or not nn > 0:
        return w, None, None
    n = nsum / nn
    a = (t[:, None] * q[:, :3]).sum(0) / w
    c = min(1.0, max(-1.0, float(p[3:] @ n)))
    return w, abs(float((p[:3] - a) @ n)), np.degrees(np.arccos(c))


def measure(v, pid, radius, band, far=None, only=None):
    """The figures; far: the broken distance (None: the inside p90); only: a
    set of patch ids, the seam points by one of them alone (no inside)."""
    tree = cKDTree(v[:, :3])
    flat = cKDTree(v[:, :2])
    inv_r2 = 1.0 / radius ** 2
    acc = {"seam": [[], 0], "inside": [[], 0]}
    dirs = [(1, 0), (-1, 0), (0, 1), (0, -1)]
    pts = range(len(v))
    if only is not None:
        # a seam point by a patch of only: its own, or (within band) across
        m = np.isin(pid, list(only))
        near = flat.query_ball_point(v[m, :2], band)
        sel = np.zeros(len(v), bool)
        sel[m] = True
        for nb in near:
            sel[nb] = True
        pts = np.flatnonzero(sel)
    nbs = tree.query_ball_point(v[pts, :3], radius)
    nbs2 = flat.query_ball_point(v[pts, :2], band)
    for c, i in enumerate(pts):
        nb = np.array([j for j in nbs[c] if j != i], dtype=np.int64)
        p = v[i]
        nb2 = np.array([j for j in nbs2[c] if j != i], dtype=np.int64)
        other2 = nb2[pid[nb2] != pid[i]] if len(nb2) else nb2
        if len(other2):
            d2 = ((v[other2, :2] - p[:2]) ** 2).sum(1)
            k = pid[other2[d2 == d2.min()]].min()
            if only is not None and pid[i] not in only and k not in only:
                continue
            r = fit(v, p, nb[pid[nb] == k] if len(nb) else nb, inv_r2)
            if r[1] is None:
                acc["seam"][1] += 1
            else:
                acc["seam"][0].append(r[1:])
            continue
        if only is not None or (len(nb) and (pid[nb] != pid[i]).any()):
            continue
        for d, (dx, dy) in enumerate(dirs):
            x = float(4 * i + d) * 0.6180339887498949
            u = band * (x - np.floor(x))
            if not len(nb2) or not ((v[nb2, 0] - p[0]) * dx + (v[nb2, 1] - p[1]) * dy > u).any():
                continue
            side = nb[(v[nb, 0] - p[0]) * dx + (v[nb, 1] - p[1]) * dy > u]
            r = fit(v, p, side, inv_r2)
            if r[1] is None:
                acc["inside"][1] += 1
            else:
                acc["inside"][0].append(r[1:])
    out = {}
    for w in ("seam", "inside") if only is None else ("seam",):
        m = np.array(acc[w][0]).reshape(-1, 2)
        tot = len(m) + acc[w][1]
        d = np.sort(m[:, 0])
        out[f"patch_{w}_dist"] = float(m[:, 0].mean()) if len(m) else 0.0
        out[f"patch_{w}_angle"] = float(m[:, 1].mean()) if len(m) else 0.0
        out[f"patch_{w}_dist_p90"] = float(d[int(np.floor(0.9 * (len(d) - 1)))]) if len(d) else 0.0
        out[f"patch_{w}_open"] = acc[w][1] / tot if tot else 0.0
    if far is None:
        if only is not None:
            sys.exit("point_seams: --patches needs patch_far_dist in summary.json")
        far = out["patch_inside_dist_p90"]
    out["patch_far_dist"] = far
    for w in ("seam", "inside") if only is None else ("seam",):
        m = np.array(acc[w][0]).reshape(-1, 2)
        tot = len(m) + acc[w][1]
        out[f"patch_{w}_broken"] = (acc[w][1] + int((m[:, 0] > far).sum())) / tot if tot else 0.0
    out["patch_seam_points"] = len(acc["seam"][0]) + acc["seam"][1]
    return out


def warped_patches(path):
    """The patch ids a run warped, from its patches.csv."""
    return {int(r["patch"]) for r in csv.DictReader(open(path)) if int(r["warp"]) > 0}


def main():
    args = sys.argv[1:]
    only = None
    if "--patches" in args:
        k = args.index("--patches")
        only = warped_patches(args[k + 1])
        del args[k:k + 2]
    d = args[0]
    s = json.load(open(d + "/summary.json"))
    m = s["metrics"]
    radius = float(args[1]) if len(args) > 1 else None
    band = float(args[2]) if len(args) > 2 else 1.5 * m["input_spacing"]
    if radius is None:
        cfg = {l.split("=")[0].strip(): l.split("=", 1)[1].strip()
               for l in s["config"].splitlines() if "=" in l and not l.startswith("#")}
        r = float(cfg.get("mls_radius", "0") or 0)
        radius = r if r > 0 else 3 * m["input_spacing"]
    band = min(band, radius)
    v, pid = read_points(d + "/points.ply")
    print(json.dumps(measure(v, pid, radius, band, m.get("patch_far_dist"), only)))


if __name__ == "__main__":
    main()
