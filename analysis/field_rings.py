#!/usr/bin/python3
"""Rings of a field run (chainmail.ini), from field.h5 alone: are the
output's rings whole, as the source's are?

usage: field_rings.py RUN_DIR_or_field.h5 [--json]

An object is an inside component (distance < 0, 6-connected) that touches
no face of the grid; its class is (Euler characteristic, sample count): the
Euler characteristic of the union of its samples' unit cubes is 0 for one
ring (a solid torus), 1 for a piece without a hole, 1 - k for k + 1 rings
joined (chainmail.ini's rings touch the rings that link them where they are
sampled: the source has rings alone, 152 samples, and chains of a ring with
its two linking rings, about 400 samples, Euler -2). Printed for output and
source: objects, the share of each class (most common first, of the
source), `known`: the share of the output's objects whose class the
source has (1: every output object is one of the source's whole shapes;
cut rings and fragments lower it; a source whose rings all differ, as
chainmail_jittered's, has few classes to share), and loops per 1000 inside
samples of the objects (objects - their Euler characteristics: the rings'
holes; a ring cut open has none, so cut rings lower it).
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


def euler(mask):
    """Euler characteristic of the union of closed unit cubes at the mask's
    samples (a solid ball 1, a solid torus 0): vertices - edges + faces - cubes,
    an element present when a cube holding it is."""
    a = np.pad(mask, 1).astype(bool)
    cubes = int(a.sum())
    v = int((a[:-1, :-1, :-1] | a[1:, :-1, :-1] | a[:-1, 1:, :-1] | a[1:, 1:, :-1] |
             a[:-1, :-1, 1:] | a[1:, :-1, 1:] | a[:-1, 1:, 1:] | a[1:, 1:, 1:]).sum())
    e = f = 0
    for ax in range(3):
        o = [k for k in range(3) if k != ax]

        def sl(i, j):
            return tuple(slice(i, i + a.shape[k] - 1) if k == o[0] else
                         slice(j, j + a.shape[k] - 1) if k == o[1] else slice(None)
                         for k in range(3))
        e += int((a[sl(0, 0)] | a[sl(1, 0)] | a[sl(0, 1)] | a[sl(1, 1)]).sum())
        t0 = tuple(slice(0, a.shape[k] - 1) if k == ax else slice(None) for k in range(3))
        t1 = tuple(slice(1, a.shape[k]) if k == ax else slice(None) for k in range(3))
        f += int((a[t0] | a[t1]).sum())
    return v - e + f - cubes


def classes(dist):
    lab, n = ndimage.label(dist < 0)
    border = set()
    for sl in (lab[0], lab[-1], lab[:, 0], lab[:, -1], lab[:, :, 0], lab[:, :, -1]):
        border.update(np.unique(sl).tolist())
    objs = ndimage.find_objects(lab)
    out = []
    for c in range(1, n + 1):
        if c not in border:
            me = lab[objs[c - 1]] == c
            out.append((euler(me), int(me.sum())))
    return out


def main(argv):
    run = argv[1]
    h5 = run if run.endswith(".h5") else run + "/field.h5"
    with h5py.File(h5, "r") as f:
        out, src = classes(levels(f, "field/levels")), classes(levels(f, "source/levels"))
    known = set(src)
    # loops: components - Euler characteristic = independent loops (tunnels)
    # less cavities (none here); per 1000 inside samples of the objects
    loops = lambda cl: round(1000.0 * sum(1 - c[0] for c in cl) / max(sum(c[1] for c in cl), 1), 3)
    share = lambda cl, k: round(sum(1 for c in cl if c == k) / max(len(cl), 1), 4)
    top = sorted(known, key=lambda k: -share(src, k))[:4]
    res = {"objects_out": len(out), "objects_src": len(src),
           "known_out": round(sum(1 for c in out if c in known) / max(len(out), 1), 4),
           "loops_per_1000_out": loops(out), "loops_per_1000_src": loops(src),
           "classes": [{"euler": k[0], "samples": k[1], "share_out": share(out, k),
                        "share_src": share(src, k)} for k in top]}
    print(json.dumps(res) if "--json" in argv else json.dumps(res, indent=1))


if __name__ == "__main__":
    main(sys.argv)
