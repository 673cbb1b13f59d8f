#!/usr/bin/python3
"""Does a model-synthesis output follow its soft target shape (Merrell Sec. 4.2)
without losing its resemblance to the example? Measured from the output file,
the example and the target picture alone, not from the synthesis' bookkeeping.

Structure labels come from the example alone: empty is the commonest label of
its top layer, ground the labels of the layers below the first one holding
empty (the terrain), and a structure label is neither and is stacked on or
under another such label somewhere in the example (something built more than
one cell high: walls, towers; not grass or bushes).

    model_structure.py EXAMPLE.txt TARGET.png RUN_DIR... [--json]

For each run (RUN_DIR/lattice.txt, Merrell's format): the share of structure
cells in the columns inside the target (grey >= 0.5, the picture stretched over
x and y, its row 0 at the largest y, as geosynth reads model.shape) and outside,
over all layers; res3, the share of the non-empty 3x3x3 windows (a cell other
than empty) that occur in the example; res3_structure, the same over the
windows that hold a structure cell (the structure's own likeness, which flat
empty ground cannot inflate). Also the example's structure share.
"""
import json
import sys

import numpy as np


def read_txt(path):
    """Merrell .txt -> int array [x, y, z] (z outermost, then x, y innermost)."""
    t = open(path).read().split("\n")
    X, Y, Z = map(int, t[3].split())
    v = [int(w) for w in " ".join(t[4:]).split() if w.lstrip("-").isdigit()][:X * Y * Z]
    return np.array(v).reshape(Z, X, Y).transpose(1, 2, 0)


def structure_labels(E):
    empty = int(np.bincount(E[:, :, -1].ravel()).argmax())
    zg = next((z for z in range(E.shape[2]) if (E[:, :, z] == empty).any()), E.shape[2])
    other = {empty} | set(E[:, :, :zg].ravel().tolist())
    lo, hi = E[:, :, :-1].ravel().tolist(), E[:, :, 1:].ravel().tolist()
    return empty, {l for p in zip(lo, hi) if p[0] not in other and p[1] not in other for l in p}


def windows(A, w=3):
    X, Y, Z = A.shape
    return {(x, y, z): A[x:x + w, y:y + w, z:z + w].tobytes()
            for x in range(X - w + 1) for y in range(Y - w + 1) for z in range(Z - w + 1)}


def target(png, X, Y):
    import matplotlib.image as mpimg
    g = mpimg.imread(png)
    if g.ndim == 3:
        g = g[:, :, :3].mean(axis=2)
    if g.dtype == np.uint8:
        g = g / 255.0
    ih, iw = g.shape
    xs = (np.arange(X) * iw) // X
    ys = ih - 1 - (np.arange(Y) * ih) // Y
    return g[ys[None, :], xs[:, None]] >= 0.5   # [x, y]


def figures(E, O, inside):
    empty, S = structure_labels(E)
    ex = set(windows(E).values())
    st = np.isin(O, sorted(S))
    found = tot = sfound = stot = 0
    for (x, y, z), k in windows(O).items():
        if (O[x:x + 3, y:y + 3, z:z + 3] == empty).all():
            continue
        f = k in ex
        found += f
        tot += 1
        if st[x:x + 3, y:y + 3, z:z + 3].any():
            sfound += f
            stot += 1
    ins = np.repeat(inside[:, :, None], O.shape[2], axis=2)
    return {"structure_labels": len(S),
            "structure_share_example": float(np.isin(E, sorted(S)).mean()),
            "structure_share_inside": float(st[ins].mean()) if ins.any() else 0.0,
            "structure_share_outside": float(st[~ins].mean()) if (~ins).any() else 0.0,
            "res3": found / tot if tot else 0.0,
            "res3_structure": sfound / stot if stot else 0.0,
            "windows_structure": stot}


def main(argv):
    js = "--json" in argv
    argv = [a for a in argv if a != "--json"]
    if len(argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    E = read_txt(argv[0])
    out = {}
    for d in argv[2:]:
        O = read_txt(d + "/lattice.txt")
        out[d] = figures(E, O, target(argv[1], O.shape[0], O.shape[1]))
    if js:
        print(json.dumps(out, indent=1))
    else:
        for d, f in out.items():
            print(d, " ".join("%s=%.3f" % (k, v) if isinstance(v, float) else "%s=%d" % (k, v)
                              for k, v in f.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
