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
discs: the regions as mesh.ply shows them, from its vertex labels alone
  (>= 128 positive; the colour boundary runs through the midpoints of the
  edges whose ends differ, outline()). Per region of at least min_area
  units^2: area, equivalent radius r = sqrt(area / pi), perimeter / (2 pi r),
  the same ratio of an ideal disc of that area drawn at the region's
  centroid on this mesh (ideal_ratio: vertices labelled by their true
  distance to the centre; > 1 from the staircase of the edges, 1.09-1.10 on
  the regular sphere), and the radial profile's coefficient of variation
  about the centroid (0 for a disc, 0.03 for a regular hexagon). On a
  displaced sphere (radial spread < 10%) all of it is measured on the
  sphere under the relief (the displacement is radial); elsewhere on the
  mesh as it is (the ideal disc then a ball of radius r around the centroid).

summary (per side): the regions of at least min_area except a side's
  largest when it holds over half that side's area (the surrounding sea or
  land, not a disc), their count, the area-weighted mean of perimeter /
  2 pi r, of the ideal disc's ratio and of radial cv, and the largest area
  over the median (merged discs show as a few regions many times the
  others'); specks: regions under min_area.

roughness: the colour boundary's length over that of the same labelling
  opened at rho units (default 1.5, the gallery's smallest disc
  radius), see roughness(); ~1.0 for unions of round discs, larger for
  staircased or jagged coasts.

usage: micro_outline.py INSTANCE_DIR [--json] [--min-area A] (default 100 units^2)
       micro_outline.py --gallery RUN_DIR [--rho R] [--json]: per card of a
         gallery run (RUN_DIR/gallery/candidate-NNN), the roughness and
         candidates.json's realized L1/n; mean and max over the cards
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
    ply = os.path.join(inst, "mesh.ply")
    v, f = gsio.read_ply(ply)
    vl = gsio.read_ply_vertex_property(ply, "label")
    with h5py.File(os.path.join(inst, "micro.h5"), "r") as h:
        x = h["/micro/triangle_value"][...]
        upm = float(h["/micro"].attrs["units_per_model"])
    return v.astype(np.float64) * upm, np.asarray(f, dtype=np.int64), x, vl


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


def _areas(P, f):
    return 0.5 * np.linalg.norm(np.cross(P[f[:, 1]] - P[f[:, 0]], P[f[:, 2]] - P[f[:, 0]]), axis=1)


def _edges(f):
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    return np.unique(np.sort(e, axis=1), axis=0)


def outline(P, f, vside, edges=None, areas=None):
    """Regions of the vertex sides vside (bool per vertex) as a viewer shows
    them: the colour boundary runs through the midpoints of the edges whose
    ends differ (marching triangles on the side indicator). A mixed triangle
    gives its lone corner a quarter of its area and the other two the rest,
    and a coast segment of half its edge opposite the lone corner to both.
    Returns (vertex region ids, region areas, perimeters, area-weighted
    centroids, per region the coast segments' midpoints)."""
    nv = len(P)
    e = _edges(f) if edges is None else edges
    a = _areas(P, f) if areas is None else areas
    same = vside[e[:, 0]] == vside[e[:, 1]]
    g = coo_matrix((np.ones(int(same.sum())), (e[same, 0], e[same, 1])), shape=(nv, nv))
    nc, lab = connected_components(g, directed=False)
    s = vside[f]
    cnt = s.sum(axis=1)
    area = np.zeros(nc)
    perim = np.zeros(nc)
    cen = np.zeros((nc, 3))
    tc = P[f].mean(axis=1)
    full = (cnt == 0) | (cnt == 3)
    r0 = lab[f[full, 0]]
    np.add.at(area, r0, a[full])
    np.add.at(cen, r0, tc[full] * a[full, None])
    mixed = ~full
    fm, sm, am = f[mixed], s[mixed], a[mixed]
    lone_is_pos = (cnt[mixed] == 1)
    li = np.argmax(sm == lone_is_pos[:, None], axis=1)
    rows = np.arange(len(fm))
    lone, o1, o2 = fm[rows, li], fm[rows, (li + 1) % 3], fm[rows, (li + 2) % 3]
    seg = 0.5 * np.linalg.norm(P[o1] - P[o2], axis=1)
    segmid = 0.25 * (2 * P[lone] + P[o1] + P[o2])
    rl, ro = lab[lone], lab[o1]
    np.add.at(area, rl, 0.25 * am)
    np.add.at(area, ro, 0.75 * am)
    np.add.at(cen, rl, (0.5 * P[lone] + 0.25 * (P[o1] + P[o2])) * (0.25 * am)[:, None])
    np.add.at(cen, ro, tc[mixed] * (0.75 * am)[:, None])
    np.add.at(perim, rl, seg)
    np.add.at(perim, ro, seg)
    cen /= np.maximum(area, 1e-300)[:, None]
    return lab, area, perim, cen, (rl, ro, segmid)


def _sphere(P):
    """(centre, radius) when the surface is a sphere displaced along its
    normals (radial spread < 10%), else None."""
    c = P.mean(axis=0)
    r = np.linalg.norm(P - c, axis=1)
    if r.mean() > 0 and r.std() / r.mean() < 0.1:
        return c, float(np.median(r))
    return None


def ideal_ratio(P, f, centre, area, sph, edges, areas, shifts=6, seed=1):
    """Perimeter / 2 pi r of an ideal disc of `area` drawn on this mesh:
    vertices within the disc's true radius of `centre` (on a sphere: the
    geodesic disc, by angle; elsewhere a ball of the planar radius), the same
    outline() as the output's, averaged over a few centres within a unit
    (the staircase of the edges depends on where the circle cuts them)."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(shifts):
        c = centre + (rng.normal(size=3) * 0.5 if k else 0)
        if sph is not None:
            o, R = sph
            d = c - o
            d /= np.linalg.norm(d)
            u = (P - o) / np.linalg.norm(P - o, axis=1)[:, None]
            th = np.arccos(np.clip(1 - area / (2 * np.pi * R * R), -1, 1))
            vs = u @ d >= np.cos(th)
        else:
            vs = np.linalg.norm(P - c, axis=1) <= np.sqrt(area / np.pi)
        if not vs.any():
            continue
        lab, ar, pe, _, _ = outline(P, f, vs, edges, areas)
        ins = np.unique(lab[vs])
        r = ins[np.argmax(ar[ins])]
        out.append(pe[r] / (2 * np.pi * np.sqrt(ar[r] / np.pi)))
    return float(np.mean(out)) if out else float("nan")


def discs(v, f, vlabel, min_area=100.0):
    """Per region of at least min_area units^2 of mesh.ply's vertex labels
    (>= 128 positive): area, r = sqrt(area / pi), perimeter / 2 pi r, the
    same ratio of an ideal disc of that area drawn at the region's centroid
    on this mesh (ideal_ratio), and the radial profile's coefficient of
    variation (coast segments' distance to the centroid in 72 sectors). On a
    displaced sphere everything is measured on the sphere under it (the
    displacement is radial)."""
    sph = _sphere(v)
    P = v
    if sph is not None:
        o, R = sph
        P = o + (v - o) / np.linalg.norm(v - o, axis=1)[:, None] * R
    vside = vlabel >= 128
    edges, areas = _edges(f), _areas(P, f)
    lab, area, perim, cen, (rl, ro, segmid) = outline(P, f, vside, edges, areas)
    reg_side = np.zeros(len(area), dtype=bool)
    reg_side[lab] = vside
    out = []
    for r in range(len(area)):
        A = float(area[r])
        if A < min_area or perim[r] == 0:
            continue
        ctr = cen[r]
        if sph is not None:
            o, R = sph
            ctr = o + (ctr - o) / np.linalg.norm(ctr - o) * R
        bm = (rl == r) | (ro == r)
        nrm = ctr - (sph[0] if sph is not None else P.mean(axis=0))
        nrm = nrm / np.linalg.norm(nrm) if np.linalg.norm(nrm) > 0 else np.array([0.0, 0.0, 1.0])
        b = segmid[bm] - ctr
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
        out.append({"positive": bool(reg_side[r]), "area": A, "radius": float(req),
                    "perimeter_ratio": float(perim[r] / (2 * np.pi * req)),
                    "ideal_ratio": ideal_ratio(P, f, ctr, A, sph, edges, areas),
                    "radial_cv": float(np.nanstd(prof) / np.nanmean(prof))})
    return out, int(np.sum(area < min_area))


def roughness(v, f, vlabel, rho=1.5):
    """Outline roughness of unions of discs (issue 20 item 3, gallery cards:
    a Boolean model's overlapping discs, so no region need be one disc):
    the colour boundary's length (outline()) over the length of the same
    labelling opened at radius rho units (positive vertices farther than rho
    from every negative one, grown back by rho), distances straight-line
    between vertices (on a displaced sphere on the sphere under it; the chord
    is within 0.2% of the geodesic at rho <= 2 on a sphere of radius >= 10
    units). A union of discs of radii >= rho is unchanged by the opening, so
    the ratio is near 1 for it (both drawn on the same mesh, the edges'
    staircase cancels: 1.01-1.06 for Boolean unions of discs of radii in
    [a, 2a], a = 1.5-3 units); spikes and jagged steps of the positive side
    narrower than 2 rho are cut, so it grows with them. No closing: it would
    bridge every gap under 2 rho between neighbouring discs (1.1-2.5 on the
    same ideal unions). src/measure/outline.c is the same measure, computed
    by the engine for every instance. Returns (ratio, boundary length,
    smoothed length)."""
    sph = _sphere(v)
    P = v
    if sph is not None:
        o, R = sph
        P = o + (v - o) / np.linalg.norm(v - o, axis=1)[:, None] * R
    edges, areas = _edges(f), _areas(P, f)

    def grow(s, r):  # vertices within r of a vertex of s
        if not s.any():
            return s.copy()
        d, _ = cKDTree(P[s]).query(P, distance_upper_bound=r)
        return np.isfinite(d)

    pos = vlabel >= 128
    smooth = grow(~grow(~pos, rho), rho)           # erode pos, then grow it back
    length = float(outline(P, f, pos, edges, areas)[2].sum()) / 2
    slen = float(outline(P, f, smooth, edges, areas)[2].sum()) / 2
    return (length / slen if slen > 0 else float("nan")), length, slen


def summary(regions, specks=0):
    out = {"specks": specks}
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
                     "ideal_ratio": float(np.average([r["ideal_ratio"] for r in rs], weights=a)),
                     "radial_cv": float(np.average([r["radial_cv"] for r in rs], weights=a)),
                     "largest_over_median": float(a.max() / np.median(a))}
    return out


def gallery(run, rho):
    cand = json.load(open(os.path.join(run, "gallery", "candidates.json")))
    out = []
    for c in cand:
        d = os.path.join(run, "gallery", c["dir"])
        v, f = gsio.read_ply(os.path.join(d, "mesh.ply"))
        vl = gsio.read_ply_vertex_property(os.path.join(d, "mesh.ply"), "label")
        with h5py.File(os.path.join(d, "micro.h5"), "r") as h:
            upm = float(h["/micro"].attrs["units_per_model"])
        ratio, length, slen = roughness(v.astype(np.float64) * upm, np.asarray(f, dtype=np.int64), vl, rho)
        out.append({"dir": c["dir"], "roughness": ratio, "length": length, "smoothed_length": slen,
                    "realized_l1": c["realized_l1"]})
    return out


def main():
    rho = float(sys.argv[sys.argv.index("--rho") + 1]) if "--rho" in sys.argv else 1.5
    if sys.argv[1] == "--gallery":
        out = gallery(sys.argv[2], rho)
        rs = [c["roughness"] for c in out]
        if "--json" in sys.argv:
            print(json.dumps({"cards": out, "roughness_mean": float(np.mean(rs)),
                              "roughness_max": float(np.max(rs))}))
            return
        for c in out:
            print("%s: coast %.0f units, smoothed at %.1f: %.0f, roughness %.3f, realized L1/n %.4f"
                  % (c["dir"], c["length"], rho, c["smoothed_length"], c["roughness"], c["realized_l1"]))
        print("roughness mean %.3f, max %.3f; L1/n max %.4f"
              % (np.mean(rs), np.max(rs), max(c["realized_l1"] for c in out)))
        return
    inst = sys.argv[1]
    v, f, x, vl = load(inst)
    ma = float(sys.argv[sys.argv.index("--min-area") + 1]) if "--min-area" in sys.argv else 100.0
    regions, specks = discs(v, f, vl, min_area=ma)
    res = {"metric_excess": metric_excess(v, f, x), "discs": regions}
    res["summary"] = summary(regions, specks)
    res["roughness"] = roughness(v, f, vl, rho)[0]
    if "--json" in sys.argv:
        print(json.dumps(res))
        return
    print("metric excess (max |dx| / straight line, 3-6 units): %.3f" % res["metric_excess"])
    print("regions under the minimum area (specks): %d" % res["summary"]["specks"])
    print("roughness (coast / coast opened at %.1f units): %.3f" % (rho, res["roughness"]))
    for name in ("positive", "negative"):
        sm = res["summary"][name]
        if sm["count"]:
            print("%s regions (not the surrounding one): %d, area-weighted perimeter / 2 pi r %.3f (an ideal disc "
                  "on this mesh %.3f: excess %.3f), radial cv %.3f, largest / median area %.1f"
                  % (name, sm["count"], sm["perimeter_ratio"], sm["ideal_ratio"],
                     sm["perimeter_ratio"] / sm["ideal_ratio"], sm["radial_cv"], sm["largest_over_median"]))
    for r in sorted(res["discs"], key=lambda r: -r["area"]):
        print("  %s region: area %.0f, r %.1f, perimeter / 2 pi r %.3f (ideal disc %.3f), radial cv %.3f"
              % ("positive" if r["positive"] else "negative", r["area"], r["radius"],
                 r["perimeter_ratio"], r["ideal_ratio"], r["radial_cv"]))


if __name__ == "__main__":
    main()
