#!/usr/bin/python3
"""Example lattices nobody tuned for (issue #18): villages, fortresses, terrain with caves.

    scripts/gen-lattice.py KIND SEED OUT.txt [--size 24x24x8]

KIND: village (ground with roads, houses with walls, doors, windows and roofs, trees),
fortress (a walled yard with battlements, corner towers, a gate and a keep), terrain (a
height field of stone, dirt and grass with water in the hollows and caves in the stone).
Writes Paul Merrell's .txt lattice format (docs/FORMATS.md: three free lines, "X Y Z", then the
labels z outermost, then x, then y innermost; 0 = empty). z = 0 is a full ground layer and the
top layer is empty, as the model engine's fixed faces expect. Same KIND + SEED = same file.
Python standard library only.
"""
import argparse
import random

# labels (shared by the kinds so a reader can tell them apart)
GRASS, ROAD, WALL, DOOR, WINDOW, ROOF, TRUNK, LEAVES = 1, 2, 3, 4, 5, 6, 7, 8
FWALL, BATTLE, TOWER, TOWERTOP, GATE, KEEP, YARD = 9, 10, 11, 12, 13, 14, 15
STONE, DIRT, TGRASS, WATER = 16, 17, 18, 19


def village(r, X, Y, Z, L):
    for x in range(X):
        for y in range(Y):
            L[0][y][x] = GRASS
    # roads: one or two lines each way
    rx = sorted(r.sample(range(2, X - 2), r.randint(1, 2)))
    ry = sorted(r.sample(range(2, Y - 2), r.randint(1, 2)))
    for x in rx:
        for y in range(Y):
            L[0][y][x] = ROAD
    for y in ry:
        for x in range(X):
            L[0][y][x] = ROAD
    used = [[L[0][y][x] == ROAD for x in range(X)] for y in range(Y)]
    def free(x0, y0, w, h, pad=1):
        for y in range(y0 - pad, y0 + h + pad):
            for x in range(x0 - pad, x0 + w + pad):
                if x < 0 or y < 0 or x >= X or y >= Y or used[y][x]:
                    return False
        return True
    def take(x0, y0, w, h):
        for y in range(y0 - 1, y0 + h + 1):
            for x in range(x0 - 1, x0 + w + 1):
                if 0 <= x < X and 0 <= y < Y:
                    used[y][x] = True
    for _ in range(200):  # houses
        w, h = r.randint(4, 6), r.randint(4, 6)
        x0, y0 = r.randint(0, X - w), r.randint(0, Y - h)
        height = r.randint(2, min(3, Z - 3))
        if not free(x0, y0, w, h):
            continue
        take(x0, y0, w, h)
        for z in range(1, height + 1):
            for y in range(y0, y0 + h):
                for x in range(x0, x0 + w):
                    if x in (x0, x0 + w - 1) or y in (y0, y0 + h - 1):
                        L[z][y][x] = WALL
        side = r.randrange(4)  # door on one side, windows at z = 2
        dx, dy = [(x0 + w // 2, y0), (x0 + w // 2, y0 + h - 1), (x0, y0 + h // 2), (x0 + w - 1, y0 + h // 2)][side]
        L[1][dy][dx] = DOOR
        if height >= 2:
            for y in range(y0 + 1, y0 + h - 1, 2):
                L[2][y][x0] = L[2][y][x0 + w - 1] = WINDOW
            for x in range(x0 + 1, x0 + w - 1, 2):
                L[2][y0][x] = L[2][y0 + h - 1][x] = WINDOW
        for y in range(y0, y0 + h):
            for x in range(x0, x0 + w):
                L[height + 1][y][x] = ROOF
    for _ in range(200):  # trees
        x0, y0 = r.randint(1, X - 2), r.randint(1, Y - 2)
        if not free(x0 - 1, y0 - 1, 3, 3, 0) or Z < 6:
            continue
        take(x0 - 1, y0 - 1, 3, 3)
        L[1][y0][x0] = L[2][y0][x0] = TRUNK
        for ddx, ddy in [(0, 0), (1, 0), (-1, 0), (0, 1), (0, -1)]:
            L[3][y0 + ddy][x0 + ddx] = LEAVES
        L[4][y0][x0] = LEAVES


def fortress(r, X, Y, Z, L):
    for x in range(X):
        for y in range(Y):
            L[0][y][x] = GRASS
    m = r.randint(2, 4)
    x0, y0, x1, y1 = m, m, X - 1 - r.randint(2, 4), Y - 1 - r.randint(2, 4)
    wh = min(3, Z - 4)
    for y in range(y0 + 1, y1):  # the yard inside the walls (walls stand on grass)
        for x in range(x0 + 1, x1):
            L[0][y][x] = YARD
    for z in range(1, wh + 1):
        for y in range(y0, y1 + 1):
            for x in range(x0, x1 + 1):
                if x in (x0, x1) or y in (y0, y1):
                    L[z][y][x] = FWALL
    for y in range(y0, y1 + 1):
        for x in range(x0, x1 + 1):
            if (x in (x0, x1) or y in (y0, y1)) and (x + y) % 2 == 0:
                L[wh + 1][y][x] = BATTLE
    gx = r.randint(x0 + 2, x1 - 2)
    L[1][y0][gx] = L[2][y0][gx] = GATE
    th = min(wh + 2, Z - 2)
    for cx, cy in [(x0, y0), (x1, y0), (x0, y1), (x1, y1)]:
        for z in range(1, th + 1):
            for ddy in (0, 1):
                for ddx in (0, 1):
                    xx, yy = min(max(cx - ddx + (cx == x0), 0), X - 1), min(max(cy - ddy + (cy == y0), 0), Y - 1)
                    L[z][yy][xx] = TOWER if z < th else TOWERTOP
    kw, kh = r.randint(3, 5), r.randint(3, 5)  # keep
    kx, ky = r.randint(x0 + 3, max(x0 + 3, x1 - 2 - kw)), r.randint(y0 + 3, max(y0 + 3, y1 - 2 - kh))
    kz = min(r.randint(3, 5), Z - 2)
    for z in range(1, kz + 1):
        for y in range(ky, ky + kh):
            for x in range(kx, kx + kw):
                L[z][y][x] = KEEP if z < kz else TOWERTOP


def terrain(r, X, Y, Z, L):
    # smooth height field from a few random bumps
    bumps = [(r.uniform(0, X), r.uniform(0, Y), r.uniform(1, Z - 3), r.uniform(3, 8)) for _ in range(5)]
    for x in range(X):
        for y in range(Y):
            h = 1 + max(b[2] * max(0.0, 1 - ((x - b[0]) ** 2 + (y - b[1]) ** 2) / b[3] ** 2) for b in bumps)
            h = min(int(h), Z - 2)
            for z in range(0, h + 1):
                L[z][y][x] = STONE if z < h - 1 else DIRT if z < h else TGRASS
            if h <= 1:
                L[1][y][x] = WATER
    for _ in range(r.randint(2, 4)):  # caves: empty pockets inside the stone
        cx, cy, cz = r.randrange(X), r.randrange(Y), r.randint(1, max(1, Z // 2 - 1))
        for x in range(cx - 2, cx + 3):
            for y in range(cy - 1, cy + 2):
                if 0 <= x < X and 0 <= y < Y and 0 < cz < Z and L[cz][y][x] == STONE and L[cz + 1][y][x] in (STONE, DIRT):
                    L[cz][y][x] = 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("kind", choices=["village", "fortress", "terrain"])
    ap.add_argument("seed", type=int)
    ap.add_argument("out")
    ap.add_argument("--size", default="24x24x8")
    a = ap.parse_args()
    X, Y, Z = (int(v) for v in a.size.lower().split("x"))
    r = random.Random(f"{a.kind}:{a.seed}")
    L = [[[0] * X for _ in range(Y)] for _ in range(Z)]
    {"village": village, "fortress": fortress, "terrain": terrain}[a.kind](r, X, Y, Z, L)
    for z in range(Z - 1, Z):
        L[z] = [[0] * X for _ in range(Y)]
    with open(a.out, "w") as f:
        f.write(f"Example lattice: {a.kind}, seed {a.seed}, from geosynth scripts/gen-lattice.py\n\n")
        f.write("x, y, and z extents\n")
        f.write(f"{X} {Y} {Z}\n")
        for z in range(Z):
            for x in range(X):
                f.write(" ".join(str(L[z][y][x]) for y in range(Y)) + "\n")


if __name__ == "__main__":
    main()
