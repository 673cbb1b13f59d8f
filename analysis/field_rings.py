#!/usr/bin/python3
"""Rings of a field run (chainmail*.ini), from field.h5 alone: are the
output's rings whole, as the source's are? (#19 item 3)

usage: field_rings.py RUN_DIR_or_field.h5 [--json] [--check]

An object is an inside component (distance < 0, 6-connected) that touches
no face of the grid. Its handles are 1 - its Euler characteristic, that of
the cubical complex 6-connectivity describes (cells - face-adjacent pairs +
2x2 squares - 2x2x2 cubes): a whole ring has one, an arc, a stub or a ball
none, g rings that touch (chainmail's rings touch the rings that link them
where they are sampled) g or more. Printed for output and source, as
summary.json has them (src/field/report.c, gs_field_geometry_report):
genus{k}: objects with k handles (4: 4 or more), ring_share: the share of
objects with a handle, open_per_msample: objects without one per 10^6
samples of the grid, handles_per_kinside: handles per 1000 inside samples of
the objects (a ring cut open loses its handle, an arc grown onto a ring adds
samples and no handle), handles_all_per_kinside: the same over every inside
component (those at the faces too); and the class table (Euler
characteristic, sample count) with `known`: the share of the output's
objects whose class the source has. --check compares the figures with the
run's summary.json and exits 1 when one differs (the C measure and this one
are the same).
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


def euler6(lab, n):
    """Euler characteristic of each 6-connected component of lab (1..n):
    cells - face-adjacent pairs + 2x2 squares - 2x2x2 cubes."""
    a = np.pad(lab, ((0, 1), (0, 1), (0, 1)))
    s = a != 0
    core = (slice(0, -1),) * 3
    sh = lambda dz, dy, dx: s[dz:dz + lab.shape[0], dy:dy + lab.shape[1], dx:dx + lab.shape[2]]
    x, y, z = sh(0, 0, 1), sh(0, 1, 0), sh(1, 0, 0)
    sxy, sxz, syz = x & y & sh(0, 1, 1), x & z & sh(1, 0, 1), y & z & sh(1, 1, 0)
    cube = sxy & sxz & syz & sh(1, 1, 1)
    w = (1 - x.astype(np.int64) - y - z + sxy + sxz + syz - cube)
    e = np.bincount(a[core].ravel(), weights=w.ravel(), minlength=n + 1)
    return np.rint(e).astype(np.int64)


def components(dist):
    """(interior: [(euler, samples)], handles and inside samples of every component)"""
    lab, n = ndimage.label(dist < 0)
    border = set()
    for sl in (lab[0], lab[-1], lab[:, 0], lab[:, -1], lab[:, :, 0], lab[:, :, -1]):
        border.update(np.unique(sl).tolist())
    eu = euler6(lab, n)
    size = np.bincount(lab.ravel(), minlength=n + 1)
    out = [(int(eu[c]), int(size[c])) for c in range(1, n + 1) if c not in border]
    return out, int(n - eu[1:].sum()), int(size[1:].sum())


def classes(dist):
    return components(dist)[0]


def figures(dist, tag, res):
    cl, h_all, s_all = components(dist)
    g = [0] * 5
    for e, _ in cl:
        g[min(max(1 - e, 0), 4)] += 1
    for k in range(5):
        res["genus%d_%s" % (k, tag)] = g[k]
    res["ring_share_" + tag] = (len(cl) - g[0]) / len(cl) if cl else 0.0
    res["open_per_msample_" + tag] = 1e6 * g[0] / dist.size
    s = sum(c[1] for c in cl)
    res["handles_per_kinside_" + tag] = 1e3 * sum(1 - c[0] for c in cl) / s if s else 0.0
    res["handles_all_per_kinside_" + tag] = 1e3 * h_all / s_all if s_all else 0.0
    return cl


def main(argv):
    run = argv[1]
    h5 = run if run.endswith(".h5") else run + "/field.h5"
    res = {}
    with h5py.File(h5, "r") as f:
        out = figures(levels(f, "field/levels"), "out", res)
        src = figures(levels(f, "source/levels"), "src", res)
    known = set(src)
    share = lambda cl, k: round(sum(1 for c in cl if c == k) / max(len(cl), 1), 4)
    top = sorted(known, key=lambda k: -share(src, k))[:4]
    res.update({"objects_out": len(out), "objects_src": len(src),
                "known_out": round(sum(1 for c in out if c in known) / max(len(out), 1), 4),
                "classes": [{"euler": k[0], "samples": k[1], "share_out": share(out, k),
                             "share_src": share(src, k)} for k in top]})
    bad = []
    if "--check" in argv:
        with open(h5[:-len("field.h5")] + "summary.json") as f:
            m = json.load(f)["metrics"]
        for k, v in res.items():
            if k.startswith(("genus", "ring_share", "open_per", "handles")):
                if k not in m or abs(m[k] - v) > 1e-6 * max(1.0, abs(v)):
                    bad.append((k, m.get(k), v))
        res["check"] = "differs: %s" % bad if bad else "summary.json agrees"
    print(json.dumps(res) if "--json" in argv else json.dumps(res, indent=1))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
