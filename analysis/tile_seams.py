#!/usr/bin/python3
"""Do the tiles of an assembled voxel tile-set output join? Measured from the
output file alone (tiles.vox of a `geosynth model` run on a 3D tile set) and
the tile size, not from the labels the synthesis chose.

For every face between two neighbouring tile cells, the voxel layers on its
two sides are compared: the face is "joined" when every voxel on one side is
filled exactly where the voxel across is filled (a tube, wall or stair that
reaches the face goes on in the next tile), and "equal" when the two layers
also have the same colours (DeBroglie's auto-adjacency rule). Faces where
both layers are empty count as joined and are reported apart ("empty").

    tile_seams.py RUN/tiles.vox TILE [--json]

TILE: voxels per tile edge (e.g. 5), or NXxNYxNZ. Prints per axis the faces,
the joined share, the equal share, and per z layer of faces (z faces between
tile layers k-1 and k) the joined share, so a ground layer whose top is not
continuous by design can be read apart. Exit 2 on a bad file.
"""
import json
import struct
import sys

import numpy as np


def read_vox(path):
    """MagicaVoxel .vox -> uint8 array [x, y, z] (0 empty) of the whole scene:
    each model placed by its nTRN translation (centre - size // 2), as
    MagicaVoxel and geosynth (gs_vox_flatten) place them."""
    b = open(path, "rb").read()
    if b[:4] != b"VOX ":
        raise ValueError(f"{path}: not a .vox file")
    sizes, voxels, trn, grp, shp = [], [], {}, {}, {}

    def rd_str(o):
        n = struct.unpack_from("<i", b, o)[0]
        return b[o + 4:o + 4 + n].decode("latin1"), o + 4 + n

    def rd_dict(o):
        n = struct.unpack_from("<i", b, o)[0]
        o += 4
        d = {}
        for _ in range(n):
            k, o = rd_str(o)
            v, o = rd_str(o)
            d[k] = v
        return d, o

    off = 8 + 12  # header + MAIN chunk header
    while off + 12 <= len(b):
        cid = b[off:off + 4].decode("latin1")
        n, m = struct.unpack_from("<ii", b, off + 4)
        o = off + 12
        if cid == "SIZE":
            sizes.append(struct.unpack_from("<iii", b, o))
        elif cid == "XYZI":
            k = struct.unpack_from("<i", b, o)[0]
            voxels.append(np.frombuffer(b, np.uint8, 4 * k, o + 4).reshape(k, 4))
        elif cid == "nTRN":
            nid = struct.unpack_from("<i", b, o)[0]
            _, o2 = rd_dict(o + 4)
            child, _, _, nframes = struct.unpack_from("<iiii", b, o2)
            fr, _ = rd_dict(o2 + 16) if nframes > 0 else ({}, 0)
            t = tuple(int(v) for v in fr.get("_t", "0 0 0").split())
            trn[nid] = (child, t)
        elif cid == "nGRP":
            nid = struct.unpack_from("<i", b, o)[0]
            _, o2 = rd_dict(o + 4)
            k = struct.unpack_from("<i", b, o2)[0]
            grp[nid] = list(struct.unpack_from(f"<{k}i", b, o2 + 4))
        elif cid == "nSHP":
            nid = struct.unpack_from("<i", b, o)[0]
            _, o2 = rd_dict(o + 4)
            shp[nid] = struct.unpack_from("<i", b, o2 + 4)[0]
        off = o + n + m
    place = []  # (model, x0, y0, z0)

    def walk(nid, t):
        if nid in trn:
            child, tt = trn[nid]
            walk(child, tuple(a + c for a, c in zip(t, tt)))
        elif nid in grp:
            for c in grp[nid]:
                walk(c, t)
        elif nid in shp:
            mdl = shp[nid]
            s = sizes[mdl]
            place.append((mdl, t[0] - s[0] // 2, t[1] - s[1] // 2, t[2] - s[2] // 2))

    if trn:
        walk(0, (0, 0, 0))
    else:
        place = [(i, 0, 0, 0) for i in range(len(sizes))]
    lo = np.min([[p[1], p[2], p[3]] for p in place], axis=0)
    hi = np.max([[p[1] + sizes[p[0]][0], p[2] + sizes[p[0]][1], p[3] + sizes[p[0]][2]] for p in place], axis=0)
    out = np.zeros(tuple(int(v) for v in hi - lo), np.uint8)
    for mdl, x0, y0, z0 in place:
        v = voxels[mdl]
        out[v[:, 0] + x0 - lo[0], v[:, 1] + y0 - lo[1], v[:, 2] + z0 - lo[2]] = v[:, 3]
    return out


def read_vox_palette(path):
    """The RGBA palette of a .vox: entry i = colour of voxel value i (entry
    0 unused), from its RGBA chunk (ValueError when it has none)."""
    b = open(path, "rb").read()
    off = 8 + 12
    while off + 12 <= len(b):
        cid = b[off:off + 4]
        n, m = struct.unpack_from("<ii", b, off + 4)
        if cid == b"RGBA":
            rgba = np.frombuffer(b, np.uint8, 1024, off + 12).reshape(256, 4)
            return np.vstack([np.zeros((1, 4), np.uint8), rgba[:255]])
        off += 12 + n + m
    raise ValueError(f"{path}: no RGBA palette chunk")


def seams(vol, tile):
    """Per axis: faces, joined, equal, empty (both layers empty); and per
    z-face layer k (between tile layers k-1 and k): faces, joined."""
    res = {}
    for axis in range(3):
        s = tile[axis]
        n = vol.shape[axis] // s
        faces = joined = equal = empty = 0
        by_layer = {}
        for k in range(1, n):
            a = np.take(vol, k * s - 1, axis=axis)
            b = np.take(vol, k * s, axis=axis)
            # cut the two layers into the tiles' faces
            other = [ax for ax in range(3) if ax != axis]
            ta, tb = tile[other[0]], tile[other[1]]
            na, nb = a.shape[0] // ta, a.shape[1] // tb
            fa = a[:na * ta, :nb * tb].reshape(na, ta, nb, tb)
            fb = b[:na * ta, :nb * tb].reshape(na, ta, nb, tb)
            occ = ((fa > 0) == (fb > 0)).all(axis=(1, 3))
            same = (fa == fb).all(axis=(1, 3))
            none = ((fa == 0) & (fb == 0)).all(axis=(1, 3))
            faces += occ.size
            joined += int(occ.sum())
            equal += int(same.sum())
            empty += int(none.sum())
            if axis == 2:
                by_layer[k] = {"faces": int(occ.size), "joined": int(occ.sum())}
        res["xyz"[axis]] = {"faces": faces, "joined": joined, "equal": equal, "empty": empty,
                            "joined_share": joined / faces if faces else 1.0,
                            "equal_share": equal / faces if faces else 1.0}
        if axis == 2:
            res["z_layers"] = by_layer
    return res


def main(argv):
    if len(argv) < 3:
        print(__doc__)
        return 1
    t = argv[2].lower().split("x")
    tile = [int(v) for v in t] if len(t) == 3 else [int(t[0])] * 3
    try:
        vol = read_vox(argv[1])
    except (OSError, ValueError, struct.error) as e:
        print(f"tile_seams: {e}", file=sys.stderr)
        return 2
    r = seams(vol, tile)
    if "--json" in argv:
        print(json.dumps(r))
        return 0
    print(f"{argv[1]}: {vol.shape[0]}x{vol.shape[1]}x{vol.shape[2]} voxels, "
          f"{int((vol > 0).sum())} filled, tiles {tile[0]}x{tile[1]}x{tile[2]}")
    for a in "xyz":
        q = r[a]
        print(f"  {a} faces {q['faces']}: joined {q['joined_share']:.4f}, equal {q['equal_share']:.4f}, "
              f"both empty {q['empty']}")
    for k, q in sorted(r["z_layers"].items()):
        print(f"  z faces above tile layer {k - 1}: {q['joined']}/{q['faces']} joined")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
