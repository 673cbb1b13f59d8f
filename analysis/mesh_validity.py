#!/usr/bin/python3
"""Validity of a mesh file as written: the one shared mesh-validity measure.

    /usr/bin/python3 analysis/mesh_validity.py FILE.ply|FILE.obj [--json]

Reads the faces exactly as the file stores them (vertex indices, any corner
count; nothing welded, triangulated or reordered: analysis/gsio.py
read_ply_polygons), so an unwelded mesh shows up as open edges and a welding
reader cannot hide it. From the file alone:

  vertices, faces, corners, edges (distinct undirected index pairs)
  unreferenced_vertices   vertices no face uses
  degenerate_faces        a vertex index repeated within a face
  zero_area_faces         polygon area (Newell) below 1e-12 of the bounding box's squared size
  duplicate_faces         faces with the same vertex set as an earlier face
  coincident_faces        faces with the same corner positions as an earlier face (duplicates
                          however they are indexed, e.g. both sides of a wall between two labels)
  boundary_edges          edges used by one face (open surface, or unwelded corners)
  nonmanifold_edges       edges used by three or more faces
  misoriented_edges       edges used twice in the same direction
  nonmanifold_vertices    vertices whose faces form more than one fan (edge-connected around it)
  coincident_vertices     referenced vertices at exactly the position of another one
  components              face-connected pieces (linked through edges used by exactly two faces)
  euler                   V - E + F over referenced vertices
  volume                  signed enclosed volume (divergence theorem; meaningful when closed)
  closed                  no boundary, non-manifold or misoriented edges
  manifold                closed, and no non-manifold vertices, duplicate, coincident or
                          degenerate faces

A welded closed 2-manifold has closed = manifold = true. Exit status 0; the
figures are for the caller to judge (tests/e2e/model.sh, field's copied.ply).

With --rays [H] also doubled walls, which index checks cannot see: rays
parallel to each axis through a jittered grid of spacing H (default the
bounding box's longest side / 128) inside the bounding box; along a ray the
crossings of an oriented surface without doubled walls alternate in and out
(the sign of normal . direction, faces fanned into triangles):

  rays, ray_crossings
  ray_violations          consecutive crossings with the same sign (two walls on top of each
                          other, a wall the wrong way round, sheets passed through each other)
  ray_violation_share     share of rays with one
  ray_violations_at       up to 10 of them: axis, point, the two faces (fanned triangle indices)
(tests/e2e/field_copied.sh).
"""
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gsio  # noqa: E402


def read_faces(path):
    """(positions (n, 3) float64, counts, corners) as stored in the file."""
    if path.lower().endswith(".obj"):
        return gsio.read_obj_polygons(path)
    p = gsio.read_ply_polygons(path)
    vx = p["vertex"]
    pos = np.stack([vx["x"], vx["y"], vx["z"]], axis=1).astype(np.float64)
    return pos, p["counts"], p["corners"]


def validity(pos, counts, corners):
    """The figures above for a polygon mesh: pos (n, 3), counts (faces), corners (sum counts)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    pos = np.asarray(pos, np.float64)
    counts = np.asarray(counts, np.int64)
    corners = np.asarray(corners, np.int64)
    nv, nf, nc = len(pos), len(counts), len(corners)
    r = {"vertices": int(nv), "faces": int(nf), "corners": int(nc)}
    if nc and (corners.min() < 0 or corners.max() >= nv):
        raise ValueError("a face's vertex index is out of range")
    start = np.concatenate([[0], np.cumsum(counts)[:-1]]) if nf else np.zeros(0, np.int64)
    face_of = np.repeat(np.arange(nf), counts)
    # next corner within its face
    nxt = np.arange(nc) + 1
    last = start + counts - 1
    nxt[last] = start
    a, b = corners, corners[nxt]
    used = np.zeros(nv, bool)
    used[corners] = True
    r["unreferenced_vertices"] = int(nv - used.sum())

    # degenerate faces: a repeated index within the face
    order = np.lexsort((corners, face_of))
    sf, sc = face_of[order], corners[order]
    rep = (sf[1:] == sf[:-1]) & (sc[1:] == sc[:-1])
    degenerate = np.zeros(nf, bool)
    degenerate[sf[1:][rep]] = True
    r["degenerate_faces"] = int(degenerate.sum())

    # zero-area faces (Newell normal)
    cr = np.cross(pos[a], pos[b])
    if nf:
        n = np.add.reduceat(cr, start, axis=0) / 2.0
        area = np.linalg.norm(n, axis=1)
        ext = float(np.ptp(pos[used], axis=0).max()) if used.any() else 0.0
        r["zero_area_faces"] = int((area <= 1e-12 * max(ext, 1e-30) ** 2).sum())
        # signed volume: fan each face from its first corner
        p0 = pos[corners[np.repeat(start, counts)]]
        r["volume"] = float(np.einsum("ij,ij->i", p0, np.cross(pos[a], pos[b])).sum() / 6.0)
    else:
        r["zero_area_faces"], r["volume"] = 0, 0.0

    # duplicate faces: same vertex set (sorted, padded)
    kmax = int(counts.max()) if nf else 0
    if nf:
        pad = np.full((nf, kmax), -1, np.int64)
        col = np.arange(nc) - np.repeat(start, counts)
        pad[face_of, col] = corners
        pad.sort(axis=1)
        _, first = np.unique(pad, axis=0, return_index=True)
        r["duplicate_faces"] = int(nf - len(first))
        # the same by position: faces on top of each other, whatever their indices
        _, pid = np.unique(pos, axis=0, return_inverse=True)
        pad[face_of, col] = pid.reshape(-1)[corners]
        pad.sort(axis=1)
        _, first = np.unique(pad, axis=0, return_index=True)
        r["coincident_faces"] = int(nf - len(first))
    else:
        r["duplicate_faces"] = r["coincident_faces"] = 0

    # edges by index
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    ok = lo != hi
    key = lo * nv + hi
    fwd = (a < b).astype(np.int64)
    he = np.nonzero(ok)[0]
    uk, inv, cnt = np.unique(key[he], return_inverse=True, return_counts=True)
    nfwd = np.bincount(inv, weights=fwd[he], minlength=len(uk))
    r["edges"] = int(len(uk))
    r["boundary_edges"] = int((cnt == 1).sum())
    r["nonmanifold_edges"] = int((cnt > 2).sum())
    r["misoriented_edges"] = int(((cnt == 2) & (nfwd != 1)).sum())

    # fans around vertices and face components, through edges used exactly twice
    two = np.nonzero(cnt[inv] == 2)[0]
    hh = he[two]
    o = np.argsort(inv[two], kind="stable")
    pairs = hh[o].reshape(-1, 2)            # the two half-edges of each such edge
    c1, c2 = pairs[:, 0], pairs[:, 1]
    # corners at the same vertex: c1 (at a) with nxt[c2]; nxt[c1] (at b) with c2
    # (for a misoriented pair the two corners at each vertex are c1, c2 and nxt[c1], nxt[c2])
    same = a[c1] == a[c2]
    u = np.concatenate([c1, nxt[c1]])
    w = np.concatenate([np.where(same, c2, nxt[c2]), np.where(same, nxt[c2], c2)])
    g = coo_matrix((np.ones(len(u)), (u, w)), shape=(nc, nc))
    _, comp = connected_components(g, directed=False)
    fans = np.unique(np.stack([corners, comp], axis=1), axis=0) if nc else np.zeros((0, 2), np.int64)
    per_vertex = np.bincount(fans[:, 0], minlength=nv) if nc else np.zeros(nv, np.int64)
    r["nonmanifold_vertices"] = int((per_vertex > 1).sum())
    fg = coo_matrix((np.ones(len(c1)), (face_of[c1], face_of[c2])), shape=(nf, nf))
    r["components"] = int(connected_components(fg, directed=False)[0]) if nf else 0

    # coincident vertices among the referenced ones
    up = pos[used]
    r["coincident_vertices"] = int(len(up) - len(np.unique(up, axis=0))) if len(up) else 0
    r["euler"] = int(used.sum() - len(uk) + nf)
    r["closed"] = bool(nf > 0 and r["boundary_edges"] == 0 and r["nonmanifold_edges"] == 0
                       and r["misoriented_edges"] == 0)
    r["manifold"] = bool(r["closed"] and r["nonmanifold_vertices"] == 0 and r["duplicate_faces"] == 0
                         and r["coincident_faces"] == 0 and r["degenerate_faces"] == 0)
    return r


def ray_parity(V, F, box, h, jitter=(0.31830988, 0.41421356)):
    """Rays along each axis through (lo + (j + jitter) h); see the module doc."""
    V = V.astype(np.float64)
    rays = viol = bad_rays = crossings = 0
    where = []
    lo, hi = np.asarray(box[0], float), np.asarray(box[1], float)
    for ax in range(3):
        u, v = [(ax + 1) % 3, (ax + 2) % 3]
        nu = int(np.floor((hi[u] - lo[u]) / h - jitter[0])) + 1
        nv = int(np.floor((hi[v] - lo[v]) / h - jitter[1])) + 1
        if nu <= 0 or nv <= 0:
            continue
        rays += nu * nv
        P = V[F]  # (m, 3, 3)
        pu, pv, pa = P[:, :, u], P[:, :, v], P[:, :, ax]
        j0 = np.ceil((pu.min(1) - lo[u]) / h - jitter[0]).astype(np.int64)
        j1 = np.floor((pu.max(1) - lo[u]) / h - jitter[0]).astype(np.int64)
        k0 = np.ceil((pv.min(1) - lo[v]) / h - jitter[1]).astype(np.int64)
        k1 = np.floor((pv.max(1) - lo[v]) / h - jitter[1]).astype(np.int64)
        j0, k0 = np.maximum(j0, 0), np.maximum(k0, 0)
        j1, k1 = np.minimum(j1, nu - 1), np.minimum(k1, nv - 1)
        cj, ck = np.maximum(j1 - j0 + 1, 0), np.maximum(k1 - k0 + 1, 0)
        cnt = cj * ck
        t = np.repeat(np.arange(len(F)), cnt)
        if len(t) == 0:
            continue
        # position of each candidate inside its triangle's bounding box of rays
        first = np.repeat(np.cumsum(cnt) - cnt, cnt)
        r = np.arange(len(t)) - first
        j = j0[t] + r % cj[t]
        k = k0[t] + r // cj[t]
        qu = lo[u] + (j + jitter[0]) * h
        qv = lo[v] + (k + jitter[1]) * h
        x0, y0 = pu[t, 0], pv[t, 0]
        x1, y1 = pu[t, 1], pv[t, 1]
        x2, y2 = pu[t, 2], pv[t, 2]
        area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
        w0 = (x1 - qu) * (y2 - qv) - (x2 - qu) * (y1 - qv)
        w1 = (x2 - qu) * (y0 - qv) - (x0 - qu) * (y2 - qv)
        w2 = (x0 - qu) * (y1 - qv) - (x1 - qu) * (y0 - qv)
        s = np.sign(area)
        inside = (area != 0) & (w0 * s > 0) & (w1 * s > 0) & (w2 * s > 0)
        t, j, k, w0, w1, w2, area = t[inside], j[inside], k[inside], w0[inside], w1[inside], w2[inside], area[inside]
        depth = (w0 * pa[t, 0] + w1 * pa[t, 1] + w2 * pa[t, 2]) / area
        # the normal's component along the ray: (e1 x e2)[ax] is area in (u, v)
        sign = np.sign(area).astype(np.int8)
        ray = j * nv + k
        o = np.lexsort((depth, ray))
        ray, sign, depth, t = ray[o], sign[o], depth[o], t[o]
        crossings += len(ray)
        same = (ray[1:] == ray[:-1]) & (sign[1:] == sign[:-1])
        for i in np.flatnonzero(same)[:10]:
            pt = np.zeros(3)
            pt[ax], pt[u], pt[v] = depth[i + 1], lo[u] + (ray[i] // nv + jitter[0]) * h, lo[v] + (ray[i] % nv + jitter[1]) * h
            where.append({"axis": ax, "point": [round(float(x), 4) for x in pt],
                          "faces": [int(t[i]), int(t[i + 1])]})
        viol += int(same.sum())
        bad_rays += int(len(np.unique(ray[1:][same])))
    return {"rays": int(rays), "ray_crossings": int(crossings), "ray_violations": int(viol),
            "ray_violation_share": bad_rays / rays if rays else 0.0, "ray_violations_at": where[:10]}


def triangles(counts, corners):
    """Faces fanned into triangles (m, 3)."""
    counts = np.asarray(counts, np.int64)
    corners = np.asarray(corners, np.int64)
    start = np.concatenate([[0], np.cumsum(counts)[:-1]]) if len(counts) else np.zeros(0, np.int64)
    tris = []
    for j in range(1, int(counts.max()) - 1 if len(counts) else 0):
        f = counts > j + 1
        s0 = start[f]
        tris.append(np.stack([corners[s0], corners[s0 + j], corners[s0 + j + 1]], axis=1))
    return np.concatenate(tris) if tris else np.zeros((0, 3), np.int64)


def file_rays(path, h=None):
    pos, counts, corners = read_faces(path)
    F = triangles(counts, corners)
    used = np.zeros(len(pos), bool)
    used[F.reshape(-1)] = True
    lo, hi = pos[used].min(0), pos[used].max(0)
    if h is None:
        h = float(np.max(hi - lo)) / 128
    return ray_parity(pos, F, (lo, hi), h)


def file_validity(path):
    return validity(*read_faces(path))


def main(argv):
    argv = list(argv)
    rays, h = "--rays" in argv, None
    if rays:
        i = argv.index("--rays")
        if i + 1 < len(argv) and not argv[i + 1].startswith("--") and not os.path.exists(argv[i + 1]):
            h = float(argv.pop(i + 1))
    args = [x for x in argv if not x.startswith("--")]
    if len(args) != 1:
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        return 1
    r = file_validity(args[0])
    if rays:
        r.update(file_rays(args[0], h))
    if "--json" in argv:
        print(json.dumps(r))
    else:
        for k, v in r.items():
            print(f"{k}: {v}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
