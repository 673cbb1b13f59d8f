"""Quality of a label lattice against its example, from the files alone.

The same figures as the engine's summary.json (src/measure/lattice.c,
docs/FORMATS.md), recomputed here from the output lattice and the example, so
tests and analyses do not take the engine's word for them, plus the
reference each figure is judged against: what one half of the example
reaches against the other half (an unseen piece of the example), along x and
along y.

    /usr/bin/python3 analysis/lattice_measures.py EXAMPLE OUTPUT [--k 2,3]

prints one JSON object: {"output": {...}, "halves": {...}, "shuffled": {...}}
(shuffled: the example's cells in a random order, the structureless reference). EXAMPLE: Merrell
.txt, DeBroglie .csv or a lattice.h5; OUTPUT: lattice.h5 (or .txt/.csv).
Arrays are numpy uint16 [z][y][x]; label 0 is empty.
"""
import json
import os
import sys

import numpy as np


def read_csv(path):
    """DeBroglie .csv: rows of x, one row per y, layers (z = 0 first) split by blank lines."""
    layers, cur = [], []
    with open(path) as f:
        for line in f:
            line = line.strip()
            if not line:
                if cur:
                    layers.append(cur)
                    cur = []
                continue
            cur.append([int(t) for t in line.split(",") if t.strip()])
    if cur:
        layers.append(cur)
    return np.array(layers, dtype=np.uint16)


def read_txt(path):
    """Merrell .txt: 3 free lines, 'X Y Z', then X*Y*Z labels, z outermost, then x, y innermost."""
    with open(path) as f:
        lines = f.read().split("\n")
    nx, ny, nz = (int(t) for t in lines[3].split()[:3])
    vals = []
    for line in lines[4:]:
        if line.strip().startswith("<"):
            break
        vals.extend(int(t) for t in line.split())
        if len(vals) >= nx * ny * nz:
            break
    a = np.array(vals[:nx * ny * nz], dtype=np.uint16).reshape(nz, nx, ny)
    return np.ascontiguousarray(a.transpose(0, 2, 1))


def read_h5(path):
    import h5py
    with h5py.File(path, "r") as f:
        return f["/model/labels"][()].astype(np.uint16)


def read_lattice(path):
    if path.endswith(".csv"):
        return read_csv(path)
    if path.endswith(".txt"):
        return read_txt(path)
    return read_h5(path)


def read_run(example_path, run_dir):
    """The example, a model run's lattice.h5 and its summary.json metrics."""
    with open(os.path.join(run_dir, "summary.json")) as f:
        metrics = json.load(f)["metrics"]
    return read_lattice(example_path), read_lattice(os.path.join(run_dir, "lattice.h5")), metrics


def windows(a, k, nonempty=True):
    """Every k^3 window of a as one bytes key each (the non-empty ones only by default)."""
    if min(a.shape) < k:
        return []
    v = np.lib.stride_tricks.sliding_window_view(a, (k, k, k)).reshape(-1, k * k * k)
    if nonempty:
        v = v[v.any(axis=1)]
    v = np.ascontiguousarray(v)
    return [bytes(r) for r in v.view(np.uint8).reshape(len(v), -1)]


def share(ex, out, k=3, nonempty=True):
    """Share of out's (non-empty) k^3 windows found in ex."""
    es = set(windows(ex, k, nonempty))
    ow = windows(out, k, nonempty)
    return sum(w in es for w in ow) / max(1, len(ow))


def completeness(ex, out, k=3):
    """Share of ex's distinct non-empty k^3 windows that occur in out."""
    es, os_ = set(windows(ex, k)), set(windows(out, k))
    return len(es & os_) / max(1, len(es))


def label_l1(a, b):
    """L1 distance of the label frequencies, empty included: 0 same mix, 2 disjoint."""
    n = max(int(a.max()), int(b.max())) + 1
    ha = np.bincount(a.ravel(), minlength=n) / a.size
    hb = np.bincount(b.ravel(), minlength=n) / b.size
    return float(np.abs(ha - hb).sum())


def stacked(a, nz):
    """a cut or grown to nz layers, its top layer repeated (the layer each output height
    draws from with model.resemblance_layers)."""
    return a[[min(z, a.shape[0] - 1) for z in range(nz)]]


def label_l1_layers(ex, out):
    """Mean over the output's layers of the label L1 of layer z to the example's layer
    min(z, top): the label mix at each height, which the whole-lattice L1 mixes up."""
    return float(np.mean([label_l1(ex[min(z, ex.shape[0] - 1)], out[z]) for z in range(out.shape[0])]))


def unsupported(a):
    """Share of the non-empty cells with no 6-connected path of non-empty cells to z = 0
    (floating structure; as summary.json's unsupported_share, non-periodic)."""
    from scipy import ndimage
    lab, _ = ndimage.label(a != 0)
    grounded = np.unique(lab[0])
    solid = int((a != 0).sum())
    return float(((a != 0) & ~np.isin(lab, grounded[grounded > 0])).sum()) / solid if solid else 0.0


def fill(a, nz):
    """Share of non-empty cells in each of nz layers (layers past a's top count as empty)."""
    return np.array([(a[z] != 0).mean() if z < a.shape[0] else 0.0 for z in range(nz)])


def fill_classes(ex, nz):
    """The example's fill per layer over nz layers (fill) and its partly filled layers split at
    half the fullest partly filled one: (fill, full layers, thin layers). castle.txt: the wall
    layers z = 2-4 (0.25-0.33) and the keep layers z = 5, 6 (0.062, 0.031)."""
    fe = fill(ex, nz)
    part = [v for v in fe if 0 < v < 1]
    top = max(part) if part else 0.0
    return (fe, [z for z in range(nz) if part and 0.5 * top <= fe[z] < 1],
            [z for z in range(nz) if 0 < fe[z] < 0.5 * top])


def near_face_labels(ex, margin=2):
    """Labels every one of whose example cells lies within margin cells of the example's x/y
    faces (castle.txt: its bushes, and two wall pieces)."""
    Z, Y, X = ex.shape
    yy, xx = np.meshgrid(np.arange(Y), np.arange(X), indexing="ij")
    d = np.minimum(np.minimum(xx, X - 1 - xx), np.minimum(yy, Y - 1 - yy))
    near = np.broadcast_to(d <= margin, ex.shape)
    return [l for l in np.unique(ex[ex != 0]).tolist() if (ex[~near] != l).all()]


def run_lengths(a):
    """Mean length of the runs of one non-empty label along x, y, z (as gs_model_run_lengths)."""
    out = {}
    for name, axis in (("x", 2), ("y", 1), ("z", 0)):
        b = np.moveaxis(a, axis, -1).reshape(-1, a.shape[axis]).astype(np.int32)
        cells = int((b != 0).sum())
        prev = np.concatenate([np.full((b.shape[0], 1), -1), b[:, :-1]], axis=1)
        runs = int(((b != 0) & (b != prev)).sum())
        out[name] = cells / runs if runs else 0.0
    return out


def enclosed(a, z=2):
    """Share of layer z's cells that are empty and enclosed: not 4-connected through empty
    cells of the layer to its border (a courtyard inside closed walls). castle.txt: 0.156 at
    z = 2 (its courtyard ring); walls that run out through the output's faces enclose nothing."""
    return enclosure(a, z)["share"]


def ground_layer(a):
    """The lowest layer holding an empty cell (the first layer above the ground), -1 if none."""
    for z in range(a.shape[0]):
        if (a[z] == 0).any():
            return z
    return -1


def yard_components(a, z):
    """Layer z's empty cells labelled by 4-connected component, and the ids of the yards: the
    components not reaching the layer's border."""
    from scipy import ndimage
    lab, n = ndimage.label(a[z] == 0)
    border = set(np.unique(np.concatenate([lab[0], lab[-1], lab[:, 0], lab[:, -1]])).tolist())
    return lab, [i for i in range(1, n + 1) if i not in border]


def enclosure(a, z, min_large=1):
    """Yards of layer z (as gs_measure_enclosure): the empty cells not 4-connected through
    empty cells of the layer to its border. share = enclosed cells / layer cells, yards =
    their components, yard_max = the largest one's cells, large_share = cells in yards of
    >= min_large cells / layer cells."""
    lab, ids = yard_components(a, z)
    sizes = np.bincount(lab.ravel(), minlength=max(ids, default=0) + 1)
    yards = [int(sizes[i]) for i in ids]
    return {"share": sum(yards) / lab.size, "yards": len(yards),
            "yard_max": max(yards, default=0),
            "large_share": sum(y for y in yards if y >= min_large) / lab.size}


def enclosure_figures(ex, out):
    """summary.json's enclosed_* figures: both lattices at the example's ground layer (its
    lowest layer holding an empty cell); "large" yards hold >= half the example's largest
    yard (at least 1 cell); yards_per_kcell = yards per 1000 cells of the layer."""
    z = ground_layer(ex)
    if z < 0 or z >= out.shape[0]:
        return {"enclosed_layer": -1}
    fe = enclosure(ex, z)
    big = max(1, (fe["yard_max"] + 1) // 2)
    fe = enclosure(ex, z, big)
    fo = enclosure(out, z, big)
    f = {"enclosed_layer": z}
    for name, g, a in (("", fo, out), ("_example", fe, ex)):
        f["enclosed_share" + name] = g["share"]
        f["enclosed_yards" + name] = g["yards"]
        f["enclosed_yards_per_kcell" + name] = 1000.0 * g["yards"] / (a.shape[1] * a.shape[2])
        f["enclosed_yard_max" + name] = g["yard_max"]
        f["enclosed_large_share" + name] = g["large_share"]
    return f


def yard_touches(a, z):
    """Per yard of layer z (as enclosure): its cells and the set of non-empty labels of layer
    z 4-adjacent to it (what stands at its edge: walls, towers, a gate, a keep)."""
    from scipy import ndimage
    lab, ids = yard_components(a, z)
    out = []
    for i in ids:
        m = lab == i
        ring = ndimage.binary_dilation(m) & ~m
        out.append((int(m.sum()), set(np.unique(a[z][ring]).tolist()) - {0}))
    return out


def yard_fittings(ex, out):
    """The example's yard fittings: the labels at the edge of every yard of the example's
    ground layer (fortress: wall, tower, gate, keep). For the output's yards of the example's
    scale (>= half its largest): how many there are, how many touch every fitting, and per
    fitting label how many touch it (the gate and the keep are what yards lack)."""
    z = ground_layer(ex)
    if z < 0 or z >= out.shape[0]:
        return {"yard_fittings": []}
    ey = yard_touches(ex, z)
    if not ey:
        return {"yard_fittings": []}
    fit = set.intersection(*[t for _, t in ey])
    big = max(1, (max(c for c, _ in ey) + 1) // 2)
    oy = [t for c, t in yard_touches(out, z) if c >= big]
    return {"yard_fittings": sorted(fit), "yard_fittings_yards": len(oy),
            "yard_fittings_complete": sum(1 for t in oy if fit <= t),
            "yard_fittings_per_label": {str(l): sum(1 for t in oy if l in t) for l in sorted(fit)}}


def layout(a, ground, large_min=0):
    """Large-scale layout of the layers z >= ground (as gs_measure_layout_lattice): open
    columns (nothing non-empty at z >= ground), clear columns (open with their 8 column
    neighbours inside the lattice open), structures = 6-connected components of the
    non-empty cells at z >= ground holding a cell above the ground layer (their cell
    counts, largest first), size_median = cell-weighted median (half the structure cells
    are in structures of at least this size), large_cells = cells in structures of more
    than large_min cells (0: none counted)."""
    from scipy import ndimage
    above = a[ground:] != 0
    openc = ~above.any(axis=0)
    clear = ndimage.binary_erosion(openc, structure=np.ones((3, 3), bool), border_value=1)
    lab, n = ndimage.label(above)
    sizes = np.bincount(lab.ravel(), minlength=n + 1)
    tall = np.unique(lab[1:])
    st = sorted((int(sizes[c]) for c in tall if c > 0), reverse=True)
    cells = sum(st)
    median, cum = 0, 0
    for v in st:
        cum += v
        if 2 * cum >= cells:
            median = v
            break
    # nested: no column of the structure on the border or next to an outside column (no
    # structure cell, 4-connected through such columns to the border)
    talls = np.isin(lab, [c for c in tall if c > 0])
    scol = talls.any(axis=0)
    fl, _ = ndimage.label(~scol)
    border = np.unique(np.concatenate([fl[0], fl[-1], fl[:, 0], fl[:, -1]]))
    outside = np.isin(fl, border[border > 0])
    pad = np.pad(outside, 1, constant_values=True)
    meets = pad[:-2, 1:-1] | pad[2:, 1:-1] | pad[1:-1, :-2] | pad[1:-1, 2:]
    out_comps = set(np.unique(lab[:, meets]).tolist())
    nested = sum(int(sizes[c]) for c in tall if c > 0 and c not in out_comps)
    return {"columns": int(openc.size), "open": int(openc.sum()), "clear": int(clear.sum()),
            "sizes": st, "structure_cells": cells, "largest": st[0] if st else 0,
            "size_median": median,
            "large_cells": sum(v for v in st if large_min and v > large_min),
            "nested_cells": nested}


def layout_figures(ex, out):
    """summary.json's layout figures (docs/FORMATS.md): both lattices above the example's
    ground layer; "large" structures hold more than twice the example's largest."""
    z = ground_layer(ex)
    if z < 0 or z >= out.shape[0] or out.shape[0] < 2:
        return {}
    le = layout(ex, z)
    big = 2 * le["largest"]
    f = {"layout_ground_layer": z}
    for name, g in (("", layout(out, z, big)), ("_example", layout(ex, z, big))):
        cols = g["columns"] or 1
        f["open_ground_share" + name] = g["open"] / cols
        f["open_ground_clear_share" + name] = g["clear"] / cols
        f["structures_per_kcell" + name] = 1000.0 * len(g["sizes"]) / cols
        f["structure_max" + name] = g["largest"]
        f["structure_size_median" + name] = g["size_median"]
        f["structure_large_share" + name] = g["large_cells"] / (g["structure_cells"] or 1)
        f["structures" + name] = len(g["sizes"])
        f["structure_nested_share" + name] = g["nested_cells"] / (g["structure_cells"] or 1)
    f["structure_max_ratio"] = f["structure_max"] / le["largest"] if le["largest"] else 0.0
    return f


def column_heights(a):
    """Per column (y, x): its top non-empty layer, -1 for an empty column (the height map)."""
    nz = a.shape[0]
    solid = a != 0
    top = nz - 1 - np.argmax(solid[::-1], axis=0)
    return np.where(solid.any(axis=0), top, -1)


def land(a, ground):
    """Land bodies of the height map (terrain's hills and domes, issue #18 item 4): land
    columns reach z >= ground (their top non-empty layer); bodies are their 4-connected components.
    share = land columns / columns; sizes = body columns, largest first; size_median =
    column-weighted median (half the land is in bodies of at least this size); interior =
    over every level z >= ground, the columns at least that high whose 4 neighbours are too
    (past the lattice's sides counts as high), over the columns at least that high: a ridge
    or band a cell or two wide has little, a round dome much."""
    from scipy import ndimage
    h = column_heights(a)
    lc = h >= ground
    lab, n = ndimage.label(lc)
    sizes = sorted(np.bincount(lab.ravel(), minlength=n + 1)[1:].tolist(), reverse=True)
    cells, median, cum = sum(sizes), 0, 0
    for v in sizes:
        cum += v
        if 2 * cum >= cells:
            median = v
            break
    four = ndimage.generate_binary_structure(2, 1)
    inner = high = 0
    for z in range(ground, a.shape[0]):
        m = h >= z
        high += int(m.sum())
        inner += int(ndimage.binary_erosion(m, structure=four, border_value=1).sum())
    return {"share": float(lc.mean()), "sizes": [int(v) for v in sizes], "size_median": median,
            "interior": inner / high if high else 0.0}


def land_figures(ex, out):
    """The height map against the example's (issue #18 item 4: the example's few large round
    domes, not long ridges): height_hist_l1 = L1 distance of the column-height histograms
    (shares of columns whose top non-empty layer is z, empty columns apart; 0 same, 2
    disjoint); land_* of land() one layer above the example's lowest column (terrain: land
    rises above the water; a village's houses above the street), for the output and the
    example; land_body_max_share = the largest body's
    columns / columns; land_body_median_share the same of the column-weighted median body."""
    nz = max(ex.shape[0], out.shape[0])
    hist = lambda a: np.bincount(column_heights(a).ravel() + 1, minlength=nz + 1) / (a.shape[1] * a.shape[2])
    f = {"height_hist_l1": float(np.abs(hist(ex) - hist(out)).sum())}
    z = int(column_heights(ex).min()) + 1
    if z >= out.shape[0]:
        return f
    for name, a in (("", out), ("_example", ex)):
        g = land(a, z)
        cols = a.shape[1] * a.shape[2]
        f["land_share" + name] = g["share"]
        f["land_bodies_per_kcell" + name] = 1000.0 * len(g["sizes"]) / cols
        f["land_body_max_share" + name] = (g["sizes"][0] if g["sizes"] else 0) / cols
        f["land_body_median_share" + name] = g["size_median"] / cols
        f["land_interior" + name] = g["interior"]
    return f


def houses(a, parts=(3, 4, 5, 6), roof=6, ring=(3, 4), door=4):
    """Whole houses (issue #18 item 4, "houses, not speckle"; scripts/gen-lattice.py village
    labels by default: wall 3, door 4, window 5, roof 6). Houses are the 6-connected components
    of the part labels. A house is a roofed box when its footprint is a filled rectangle at least
    3x3 with roof over every column; whole when it is also closed: at z = 1 its footprint's
    border is wall or door, its inside empty, and it has a door (every house of the generator's
    villages is whole). Returns the shares of part cells in roofed boxes and in whole houses, and
    whole houses per 1000 columns."""
    from scipy import ndimage
    hm = np.isin(a, parts)
    lab, n = ndimage.label(hm)
    box = whole = count = 0
    for i, sl in enumerate(ndimage.find_objects(lab), 1):
        m = lab[sl] == i
        sub = a[sl]
        fp = m.any(axis=0)
        if not (fp.all() and min(fp.shape) >= 3 and ((sub == roof) & m).any(axis=0).all()):
            continue
        box += int(m.sum())
        z1 = 1 - sl[0].start
        if z1 < 0 or z1 >= sub.shape[0]:
            continue
        edge = np.ones(fp.shape, bool)
        edge[1:-1, 1:-1] = False
        if np.isin(sub[z1][edge], ring).all() and (sub[z1][~edge] == 0).all() and (sub == door).any():
            whole += int(m.sum())
            count += 1
    cells = int(hm.sum()) or 1
    return {"box_share": box / cells, "whole_share": whole / cells,
            "whole_per_kcell": 1000.0 * count / (a.shape[1] * a.shape[2])}


def grid_crossing(a, ground, period):
    """Structure columns across a regular grid's lines (as gs_measure_grid_crossing_lattice,
    issue #18: one castle per region, open streets along the region lines). A structure
    column holds a non-empty cell at z >= ground; of the x- (y-) neighbouring column pairs,
    those across a line x = k * period[0] (0 < x < nx; y likewise) and the rest; rates = the
    shares of pairs that are both structure columns; ratio = rate on the lines / rate off
    them (1: structures ignore the grid; near 0: they never cross its lines; 0 when
    undefined). period <= 0 or >= the extent: no line along that axis."""
    col = (a[ground:] != 0).any(axis=0)  # (y, x)
    ny, nx = col.shape
    px = period[0] if 0 < period[0] < nx else 0
    py = period[1] if 0 < period[1] < ny else 0
    bx = col[:, 1:] & col[:, :-1]  # pair (x - 1, x), x = 1 .. nx - 1
    by = col[1:, :] & col[:-1, :]
    lx = (np.arange(1, nx) % px == 0) if px else np.zeros(nx - 1, bool)
    ly = (np.arange(1, ny) % py == 0) if py else np.zeros(ny - 1, bool)
    on_pairs = int(lx.sum()) * ny + int(ly.sum()) * nx
    off_pairs = int((~lx).sum()) * ny + int((~ly).sum()) * nx
    on_both = int(bx[:, lx].sum() + by[ly, :].sum())
    off_both = int(bx[:, ~lx].sum() + by[~ly, :].sum())
    ratio = (on_both / on_pairs) / (off_both / off_pairs) if on_pairs and off_pairs and off_both else 0.0
    return {"region_grid_crossing": on_both / on_pairs if on_pairs else 0.0,
            "region_grid_crossing_other": off_both / off_pairs if off_pairs else 0.0,
            "region_grid_crossing_ratio": ratio}


def plan_boxes(schedule, pass_=0):
    """The x / y boxes (x0, y0, x1, y1) of one pass's regions from a run's schedule.jsonl
    (model.schedule_log = true)."""
    import json
    boxes = []
    for line in open(schedule):
        d = json.loads(line)
        if d.get("pass") == pass_ and "box" in d:
            x0, y0, _, x1, y1, _ = d["box"]
            boxes.append((x0, y0, x1, y1))
    return boxes


def region_lines_crossing(a, ground, boxes):
    """Structure columns across the x / y sides of a plan's regions (boxes as plan_boxes; #18:
    with overlap 0 every region closes its castles inside it, so none crosses a region line,
    whatever the region sizes). As grid_crossing: of the neighbouring column pairs across a
    region side inside the lattice and of the other pairs, the shares that are both structure
    columns (a non-empty cell at z >= ground); ratio = across the sides / elsewhere (1:
    structures ignore the regions; near 0: confined to them; 0 when undefined)."""
    col = (a[ground:] != 0).any(axis=0)  # (y, x)
    ny, nx = col.shape
    onx = np.zeros((ny, nx - 1), bool)  # pair (x - 1, x) on a side x = x0 or x1
    ony = np.zeros((ny - 1, nx), bool)
    for x0, y0, x1, y1 in boxes:
        for x in (x0, x1):
            if 0 < x < nx:
                onx[y0:y1, x - 1] = True
        for y in (y0, y1):
            if 0 < y < ny:
                ony[y - 1, x0:x1] = True
    bx = col[:, 1:] & col[:, :-1]
    by = col[1:, :] & col[:-1, :]
    on_pairs, off_pairs = int(onx.sum() + ony.sum()), int((~onx).sum() + (~ony).sum())
    on_both = int(bx[onx].sum() + by[ony].sum())
    off_both = int(bx[~onx].sum() + by[~ony].sum())
    ratio = (on_both / on_pairs) / (off_both / off_pairs) if on_pairs and off_pairs and off_both else 0.0
    return {"region_lines_crossing": on_both / on_pairs if on_pairs else 0.0,
            "region_lines_crossing_other": off_both / off_pairs if off_pairs else 0.0,
            "region_lines_crossing_ratio": ratio}


def straight_streets(a, ground):
    """Straight open streets: the lines x = const (y = const) between neighbouring columns
    across which no pair of structure columns (a non-empty cell at z >= ground) meets over
    the whole extent; returns (along x, along y). A layout tiled on a region grid has one per
    region line; structures placed at random almost none."""
    col = (a[ground:] != 0).any(axis=0)  # (y, x)
    bx = (col[:, 1:] & col[:, :-1]).any(axis=0)
    by = (col[1:, :] & col[:-1, :]).any(axis=1)
    return int((~bx).sum()), int((~by).sum())


def structure_periodicity(a, ground, min_lag, max_lag=40):
    """A periodic layout, independent of any region size: the highest autocorrelation of the
    structure-column mask (a non-empty cell at z >= ground; mean removed, each lag normalised
    by its overlap and the variance) over the lags (dx, dy) with min_lag <= max(|dx|, |dy|)
    <= max_lag; returns (value, (dx, dy)). A layout tiled on a grid of period P peaks near 0.5
    or more at multiples of P; structures placed at random stay near 0."""
    col = (a[ground:] != 0).any(axis=0).astype(float)
    c = col - col.mean()
    ny, nx = c.shape
    s = (2 * ny, 2 * nx)
    r = np.fft.irfft2(np.abs(np.fft.rfft2(c, s=s)) ** 2, s=s)
    cnt = np.fft.irfft2(np.abs(np.fft.rfft2(np.ones_like(c), s=s)) ** 2, s=s)
    r = r / np.maximum(np.rint(cnt), 1) / (c.var() or 1)
    best, arg = -np.inf, (0, 0)
    for dy in range(-max_lag, max_lag + 1):
        for dx in range(-max_lag, max_lag + 1):
            if max(abs(dx), abs(dy)) >= min_lag and r[dy % s[0], dx % s[1]] > best:
                best, arg = float(r[dy % s[0], dx % s[1]]), (dx, dy)
    return best, arg


def shuffled(ex, seed=0):
    """The example's cells in a random order: the same label mix, no structure."""
    flat = ex.ravel().copy()
    np.random.default_rng(seed).shuffle(flat)
    return flat.reshape(ex.shape)


def figures(ex, out, ks=(2, 3)):
    """The output's figures against the example."""
    f = {}
    for k in ks:
        f["share_%d" % k] = share(ex, out, k)
        f["share_%d_with_empty" % k] = share(ex, out, k, nonempty=False)
        f["completeness_%d" % k] = completeness(ex, out, k)
    f["label_l1"] = label_l1(ex, out)
    # what a copy of every example layer at its height scores when the output is taller
    # (castle.txt 8 layers, empty on top, in a 10-layer output: 0.146 with every layer exact)
    f["label_l1_stacked_example"] = label_l1(ex, stacked(ex, out.shape[0]))
    f["label_l1_layers"] = label_l1_layers(ex, out)
    if min(ex.shape[0], out.shape[0]) > 2:
        f["enclosed_2"], f["enclosed_2_example"] = enclosed(out), enclosed(ex)
    f.update(enclosure_figures(ex, out))
    f.update(yard_fittings(ex, out))
    f.update(layout_figures(ex, out))
    f["unsupported_share"], f["unsupported_share_example"] = unsupported(out), unsupported(ex)
    f["labels_used"] = int(len(np.unique(out[out != 0])))
    f["labels_example"] = int(len(np.unique(ex[ex != 0])))
    f["empty_share"] = float((out == 0).mean())
    f["empty_share_example"] = float((ex == 0).mean())
    fo, fe = fill(out, out.shape[0]), fill(ex, out.shape[0])
    f["height_fill_mean_abs"] = float(np.abs(fo - fe).mean())
    f["height_fill_example_mean"] = float(fe.mean())
    f.update(land_figures(ex, out))
    ro, re_ = run_lengths(out), run_lengths(ex)
    for a in "xyz":
        f["run_length_%s_ratio" % a] = ro[a] / re_[a] if re_[a] else 0.0
    return f


def halves(ex):
    """The example cut in two along x and along y: [(a, b), (a, b)]."""
    Z, Y, X = ex.shape
    return [(ex[:, :, :X // 2], ex[:, :, X // 2:]), (ex[:, :Y // 2, :], ex[:, Y // 2:, :])]


def half_figures(ex, ks=(2, 3)):
    """What an unseen piece of the example reaches against the rest, both ways, both cuts:
    share_K = the better window share, completeness_K = the lower completeness, label_l1 =
    the larger L1, run_length_A_ratio = [lowest, highest] ratio of a half's runs to the whole's."""
    f = {}
    hs = halves(ex)
    for k in ks:
        f["share_%d" % k] = max(max(share(a, b, k), share(b, a, k)) for a, b in hs)
        f["completeness_%d" % k] = min(min(completeness(a, b, k), completeness(b, a, k))
                                       for a, b in hs)
    f["label_l1"] = max(label_l1(a, b) for a, b in hs)
    whole = run_lengths(ex)
    for a in "xyz":
        r = [run_lengths(h)[a] / whole[a] for pair in hs for h in pair if whole[a]]
        f["run_length_%s_ratio" % a] = [min(r), max(r)] if r else [0.0, 0.0]
    return f


def shuffled_figures(ex):
    """The structureless reference: run_length_A_ratio of the shuffled example's runs to the
    example's (about 0.3 along x and y on Merrell's lattices, about 1 along z)."""
    whole, sh = run_lengths(ex), run_lengths(shuffled(ex))
    return {"run_length_%s_ratio" % a: sh[a] / whole[a] if whole[a] else 0.0 for a in "xyz"}


class Checks:
    """need(cond, what) prints "ok   what" or "FAIL what"; result() prints the closing line
    "RESULT pass" or "RESULT fail: ..." (the tests' convention)."""

    def __init__(self):
        self.fails = []

    def need(self, cond, what):
        print(("ok   " if cond else "FAIL ") + what)
        if not cond:
            self.fails.append(what)

    def result(self):
        print("RESULT", "pass" if not self.fails else "fail: " + "; ".join(self.fails))


def untuned_checks(example_path, run_dir):
    """The untuned examples' target (issue #18 item 4, tests/bench/model_untuned.sh) from the
    example and the run's lattice.h5 alone: non-empty 3x3x3 share >= 0.5, top layer within 1 of
    the example's, no floating cells where the example has none; 0 violations and 0 failed
    regions from summary.json. Prints the checks and "L1 x" (label L1); returns the figures."""
    ex = read_lattice(example_path)
    out = read_lattice(os.path.join(run_dir, "lattice.h5"))
    m = json.load(open(os.path.join(run_dir, "summary.json")))["metrics"]
    f = figures(ex, out, ks=(3,))
    top = lambda a: max([z for z in range(a.shape[0]) if a[z].any()] or [-1])
    chk = Checks()
    need = chk.need
    need(f["share_3"] >= 0.5, "non-empty 3x3x3 share %.3f >= 0.5 (issue #18 item 4, untuned examples)" % f["share_3"])
    need(abs(top(out) - top(ex)) <= 1, "top layer %d within 1 of example's %d" % (top(out), top(ex)))
    need(f["unsupported_share_example"] > 0 or f["unsupported_share"] == 0,
         "floating share %.4f where the example's is %.4f" % (f["unsupported_share"], f["unsupported_share_example"]))
    need(m["violations"] == 0 and m["failed_regions"] == 0,
         "0 violations, 0 failed regions (%d, %d)" % (m["violations"], m["failed_regions"]))
    print("L1 %.4f" % f["label_l1"])
    chk.result()
    return f


def main(argv):
    ks = (2, 3)
    args = list(argv)
    if "--k" in args:
        i = args.index("--k")
        ks = tuple(int(t) for t in args[i + 1].split(","))
        del args[i:i + 2]
    if len(args) != 2:
        sys.exit("usage: lattice_measures.py EXAMPLE OUTPUT [--k 2,3]")
    ex, out = read_lattice(args[0]), read_lattice(args[1])
    json.dump({"output": figures(ex, out, ks), "halves": half_figures(ex, ks),
               "shuffled": shuffled_figures(ex)}, sys.stdout, indent=1)
    print()


if __name__ == "__main__":
    main(sys.argv[1:])
