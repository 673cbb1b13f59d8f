#!/usr/bin/python3
"""Independent check of an assembled MarkovJunior tile-set output.

Re-derives, apart from geosynth's C code, which oriented tiles exist and
which may be neighbours, following MarkovJunior's TileModel.cs literally:
its voxel rotations (zRotate, yRotate, xRotate, xReflect, yReflect,
zReflect as index formulas), the orientations of a tile
(SymmetryHelper.CubeSymmetries / SquareSymmetries with content
de-duplication) and the expansion of every <neighbor> (the three loops of
fullSymmetry, or the four-plus-four pairs otherwise, top/bottom pairs).
Then cuts the output (tiles.vox) into tiles, identifies every tile by its
voxels and checks every pair of neighbours along x, y and z.

    mj_tiles_check.py TILESET.xml TILE_FOLDER RUN/tiles.vox [--json]

Prints the counts (orientations, allowed pairs, tiles, neighbour pairs
checked, unknown tiles, forbidden pairs). Exit 0 when there is no unknown
tile and no forbidden pair, 1 otherwise, 2 on bad input.
"""
import json
import os
import re
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from tile_seams import read_vox, read_vox_palette  # noqa: E402


def rotations(S, SZ):
    """MarkovJunior's six voxel maps on arrays p[x, y, z] (its p[x + y*S + z*S*S])."""
    def z_rotate(p):
        return np.array([[[p[y, S - 1 - x, z] for z in range(SZ)] for y in range(S)] for x in range(S)])

    def y_rotate(p):
        return np.array([[[p[z, y, S - 1 - x] for z in range(SZ)] for y in range(S)] for x in range(S)])

    def x_rotate(p):
        return np.array([[[p[x, z, S - 1 - y] for z in range(SZ)] for y in range(S)] for x in range(S)])

    def x_reflect(p):
        return p[::-1, :, :].copy()

    def y_reflect(p):
        return p[:, ::-1, :].copy()

    def z_reflect(p):
        return p[:, :, ::-1].copy()
    return z_rotate, y_rotate, x_rotate, x_reflect, y_reflect, z_reflect


def square_symmetries(t, rot, ref, dedup=True):
    th = [t]
    th.append(ref(th[0]))
    th.append(rot(th[0]))
    th.append(ref(th[2]))
    th.append(rot(th[2]))
    th.append(ref(th[4]))
    th.append(rot(th[4]))
    th.append(ref(th[6]))
    if not dedup:
        return th
    out = []
    for x in th:
        if not any(np.array_equal(x, o) for o in out):
            out.append(x)
    return out


def cube_symmetries(t, a, b, r):
    s = [None] * 48
    s[0] = t
    s[1] = r(s[0])
    s[2] = a(s[0])
    s[3] = r(s[2])
    s[4] = a(s[2])
    s[5] = r(s[4])
    s[6] = a(s[4])
    s[7] = r(s[6])
    s[8] = b(s[0])
    s[9] = r(s[8])
    s[10] = b(s[2])
    s[11] = r(s[10])
    s[12] = b(s[4])
    s[13] = r(s[12])
    s[14] = b(s[6])
    s[15] = r(s[14])
    for k in range(16, 32):  # s[16] = b(s[8]), s[17] = r(s[16]), ... s[31] = r(s[30])
        s[k] = b(s[k - 8]) if k % 2 == 0 else r(s[k - 1])
    s[32] = a(s[8])
    s[33] = r(s[32])
    s[34] = a(s[10])
    s[35] = r(s[34])
    s[36] = a(s[12])
    s[37] = r(s[36])
    s[38] = a(s[14])
    s[39] = r(s[38])
    s[40] = a(s[24])
    s[41] = r(s[40])
    s[42] = a(s[26])
    s[43] = r(s[42])
    s[44] = a(s[28])
    s[45] = r(s[44])
    s[46] = a(s[30])
    s[47] = r(s[46])
    out = []
    for x in s:
        if not any(np.array_equal(x, o) for o in out):
            out.append(x)
    return out


def load(xml_path, folder):
    text = open(xml_path).read()
    text = re.sub(r"<!--.*?-->", "", text, flags=re.S)
    full = re.search(r'<tileset[^>]*fullSymmetry="True"', text) is not None
    names = re.findall(r'<tile\s+name="([^"]+)"', text)
    base = os.path.join(os.path.dirname(xml_path), folder)
    raw = {}
    for n in names:
        raw[n] = read_vox(os.path.join(base, n + ".vox"))
        pal = read_vox_palette(os.path.join(base, n + ".vox"))
        # colours as RGB so tiles with different palettes compare by colour
        rgb = np.zeros(raw[n].shape, np.int64)
        m = raw[n] > 0
        rgb[m] = [1 + (int(pal[c][0]) << 16 | int(pal[c][1]) << 8 | int(pal[c][2])) for c in raw[n][m]]
        raw[n] = rgb
    S, _, SZ = raw[names[0]].shape
    zR, yR, xR, xF, yF, zF = rotations(S, SZ)
    tiles, named = [], {}
    for n in names:
        local = cube_symmetries(raw[n], zR, yR, xF) if full else square_symmetries(raw[n], zR, xF)
        named[n] = local
        tiles.extend(local)

    def index(p):
        for i, t in enumerate(tiles):
            if np.array_equal(p, t):
                return i
        raise ValueError("orientation not found")

    def tile(attr):
        code = attr.split(" ")
        action = code[0] if len(code) == 2 else ""
        t = named[code[-1]][0]
        for ch in reversed(action):
            t = {"x": xR, "y": yR, "z": zR}[ch](t)
        return t
    prop = [set() for _ in range(6)]
    for m in re.finditer(r"<neighbor\s+([^>]*)/>", text):
        at = dict(re.findall(r'(\w+)="([^"]*)"', m.group(1)))
        if full:
            lt, rt = tile(at["left"]), tile(at["right"])
            ls = square_symmetries(lt, xR, yF, dedup=False)
            rs = square_symmetries(rt, xR, yF, dedup=False)
            for i in range(len(ls)):
                prop[0].add((index(ls[i]), index(rs[i])))
                prop[0].add((index(xF(rs[i])), index(xF(ls[i]))))
            dt, ut = zR(lt), zR(rt)
            ds = square_symmetries(dt, yR, zF, dedup=False)
            us = square_symmetries(ut, yR, zF, dedup=False)
            for i in range(len(ds)):
                prop[1].add((index(ds[i]), index(us[i])))
                prop[1].add((index(yF(us[i])), index(yF(ds[i]))))
            bt, tt = yR(lt), yR(rt)
            bs = square_symmetries(bt, zR, xF, dedup=False)
            ts = square_symmetries(tt, zR, xF, dedup=False)
            for i in range(len(bs)):
                prop[4].add((index(bs[i]), index(ts[i])))
                prop[4].add((index(zF(ts[i])), index(zF(bs[i]))))
        elif "left" in at:
            lt, rt = tile(at["left"]), tile(at["right"])
            prop[0].add((index(lt), index(rt)))
            prop[0].add((index(yF(lt)), index(yF(rt))))
            prop[0].add((index(xF(rt)), index(xF(lt))))
            prop[0].add((index(yF(xF(rt))), index(yF(xF(lt)))))
            dt, ut = zR(lt), zR(rt)
            prop[1].add((index(dt), index(ut)))
            prop[1].add((index(xF(dt)), index(xF(ut))))
            prop[1].add((index(yF(ut)), index(yF(dt))))
            prop[1].add((index(xF(yF(ut))), index(xF(yF(dt)))))
        else:
            tt, bt = tile(at["top"]), tile(at["bottom"])
            ts = square_symmetries(tt, zR, xF, dedup=False)
            bs = square_symmetries(bt, zR, xF, dedup=False)
            for i in range(len(ts)):
                prop[4].add((index(bs[i]), index(ts[i])))
    return tiles, {0: prop[0], 1: prop[1], 2: prop[4]}, (S, S, SZ)


def main(argv):
    if len(argv) < 4:
        print(__doc__)
        return 2
    try:
        tiles, prop, (sx, sy, sz) = load(argv[1], argv[2])
        vol = read_vox(argv[3])
        pal = read_vox_palette(argv[3])
    except (OSError, ValueError, KeyError) as e:
        print(f"mj_tiles_check: {e}", file=sys.stderr)
        return 2
    rgb = np.zeros(vol.shape, np.int64)
    m = vol > 0
    lut = np.array([1 + (int(p[0]) << 16 | int(p[1]) << 8 | int(p[2])) for p in pal], np.int64)
    rgb[m] = lut[vol[m]]
    nx, ny, nz = vol.shape[0] // sx, vol.shape[1] // sy, vol.shape[2] // sz
    keys = {t.tobytes(): i for i, t in reversed(list(enumerate(tiles)))}
    ids = np.full((nx, ny, nz), -1)
    for x in range(nx):
        for y in range(ny):
            for z in range(nz):
                blk = np.ascontiguousarray(rgb[x * sx:(x + 1) * sx, y * sy:(y + 1) * sy, z * sz:(z + 1) * sz])
                ids[x, y, z] = keys.get(blk.tobytes(), -1)
    unknown = int((ids < 0).sum())
    checked = bad = 0
    for axis in range(3):
        a = ids.take(range(0, ids.shape[axis] - 1), axis=axis)
        b = ids.take(range(1, ids.shape[axis]), axis=axis)
        for p, q in zip(a.flatten(), b.flatten()):
            if p < 0 or q < 0:
                continue
            checked += 1
            bad += (int(p), int(q)) not in prop[axis]
    res = {"orientations": len(tiles), "pairs": sum(len(v) for v in prop.values()),
           "tiles": int(ids.size), "neighbour_pairs": checked, "unknown_tiles": unknown,
           "forbidden_pairs": bad, "distinct_orientations_used": int(len(set(ids.flatten()) - {-1}))}
    if "--json" in argv:
        print(json.dumps(res))
    else:
        print(" ".join(f"{k} {v}" for k, v in res.items()))
    return 0 if unknown == 0 and bad == 0 else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
