#!/usr/bin/python3
"""Is a 4D model-synthesis output (Merrell Sec. 4.3) consistent along time, and does it move
like its example? Measured from the output file and the example alone.

    model_time.py EXAMPLE.txt RUN_DIR [--png OUT.png] [--json]

EXAMPLE.txt is a Merrell .txt with geosynth's fourth extent ("X Y Z T"); RUN_DIR holds
lattice.h5 (/model/labels [t][z][y][x]). Figures:
  time_pairs_found: share of the output's (cell at frame t, same cell at t+1) label pairs
    that occur between consecutive frames of the example (1.0 when synthesis kept to the
    example's time transitions);
  space_pairs_found: the same for x, y, z neighbours inside one frame;
  moving_share / moving_share_example: share of cells whose label differs from the next
    frame (0 for a model that stands still);
  moving_labels: labels that ever change in the output (the example's: moving_labels_example).
--png: the layer above the ground of every frame seen from above, side by side (cars).
"""
import json
import sys

import numpy as np


def read_txt4(path):
    """-> int array [t, z, y, x]"""
    t = open(path).read().split("\n")
    ext = list(map(int, t[3].split()))
    X, Y, Z = ext[:3]
    T = ext[3] if len(ext) > 3 else 1
    v = [int(w) for w in " ".join(t[4:]).split() if w.isdigit()][:X * Y * Z * T]
    # file: frame, z outermost, then x, then y innermost
    return np.array(v).reshape(T, Z, X, Y).transpose(0, 1, 3, 2)


def pairs(a, axis):
    lo = np.moveaxis(a, axis, 0)[:-1].ravel()
    hi = np.moveaxis(a, axis, 0)[1:].ravel()
    return lo.astype(np.int64) * 65536 + hi


def found(out, ex, axis):
    p = pairs(out, axis)
    return float(np.isin(p, np.unique(pairs(ex, axis))).mean()) if p.size else 1.0


def measures(E, O):
    m = {"frames": int(O.shape[0]), "frames_example": int(E.shape[0])}
    m["time_pairs_found"] = found(O, E, 0)
    sp = [found(O, E, a) for a in (1, 2, 3)]
    m["space_pairs_found"] = float(min(sp))
    for name, A in (("", O), ("_example", E)):
        ch = A[1:] != A[:-1]
        m["moving_share" + name] = float(ch.mean())
        m["moving_labels" + name] = sorted(set(A[:-1][ch].tolist()) | set(A[1:][ch].tolist()))
    return m


def strip_png(O, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    T = O.shape[0]
    fig, axs = plt.subplots(1, T, figsize=(2.2 * T, 2.4))
    cmap = plt.get_cmap("tab20", 21)
    for t in range(T):
        top = O[t, 1] if O.shape[1] > 1 else O[t, 0]
        img = np.where(top > 0, top, O[t, 0])  # the car/building layer over the ground
        axs[t].imshow(img, origin="lower", cmap=cmap, vmin=0, vmax=20, interpolation="nearest")
        axs[t].set_title("t=%d" % t, fontsize=8)
        axs[t].axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv):
    if len(argv) < 3:
        sys.exit(__doc__)
    import h5py
    E = read_txt4(argv[1])
    with h5py.File(argv[2] + "/lattice.h5", "r") as f:
        O = f["/model/labels"][...]
    if O.ndim == 3:
        O = O[None]
    m = measures(E, O)
    if "--png" in argv:
        strip_png(O, argv[argv.index("--png") + 1])
    if "--json" in argv:
        print(json.dumps(m))
    else:
        for k, v in m.items():
            print(k, v)


if __name__ == "__main__":
    main(sys.argv)
