"""Shared readers for geosynth run directories and campaigns (analysis/*.py).

Reads only machine-readable outputs: RUN_DIR/summary.json, RUN_DIR/metrics.jsonl,
the HDF5 outputs listed in summary.json "outputs", PLY meshes, the campaign
index CAMPAIGN/campaign.tsv written by jobs/campaign.sh, and benchmark JSON
(tests/bench, bench-results/*.json). Never scrapes logs. Debian's
/usr/bin/python3 with numpy and h5py; no PyPI packages.
"""
import json
import os
import sys
from collections import defaultdict

import numpy as np

CAMPAIGN_COLUMNS = ("name", "engine", "config", "size", "np", "seed", "overrides")


def warn(msg):
    print(f"warning: {msg}", file=sys.stderr)


def read_json(path):
    with open(path) as f:
        return json.load(f)


def read_jsonl(path):
    """One JSON object per line; blank lines skipped, a bad line is a warning."""
    rows = []
    try:
        with open(path) as f:
            for n, line in enumerate(f, 1):
                if line.strip():
                    try:
                        rows.append(json.loads(line))
                    except ValueError as e:
                        warn(f"{path}:{n}: {e}")
    except OSError:
        pass
    return rows


def read_campaign_index(root):
    """CAMPAIGN/campaign.tsv -> {run name: {column: value}} (empty without one)."""
    path = os.path.join(root, "campaign.tsv")
    index = {}
    if not os.path.exists(path):
        return index
    with open(path) as f:
        for line in f:
            cols = line.rstrip("\n").split("\t")
            if len(cols) >= 6:
                row = dict(zip(CAMPAIGN_COLUMNS, cols))
                row["np"], row["seed"] = int(row["np"]), int(row["seed"])
                index[row["name"]] = row
    return index


def config_name(run):
    """Config label of a run: the campaign index's config file (+ size), else the directory."""
    c = run.get("_campaign")
    if c:
        name = os.path.splitext(os.path.basename(c["config"]))[0]
        return f"{c['engine']}/{name}" + (f" [{c['size']}]" if c.get("size", "-") != "-" else "")
    return f"{run.get('engine', '?')}/{run['_dir']}"


def load_run(run_dir, rel=None):
    """summary.json + metrics.jsonl of one run directory, or None without a summary."""
    path = os.path.join(run_dir, "summary.json")
    try:
        s = read_json(path)
    except (OSError, ValueError) as e:
        if os.path.exists(path):
            warn(f"{path}: {e}")
        return None
    s["_path"] = os.path.abspath(run_dir)
    s["_dir"] = rel if rel is not None else os.path.basename(os.path.abspath(run_dir))
    s["_metrics"] = read_jsonl(os.path.join(run_dir, "metrics.jsonl"))
    return s


def load_runs(root):
    """Every run under root (any depth) with a summary.json, sorted by directory."""
    index = read_campaign_index(root)
    runs = []
    for dirpath, dirs, files in os.walk(root):
        dirs[:] = sorted(d for d in dirs if d != "report")
        if "summary.json" not in files:
            continue
        rel = os.path.relpath(dirpath, root)
        r = load_run(dirpath, rel)
        if r is not None:
            r["_campaign"] = index.get(rel)
            r["_config_name"] = config_name(r)
            runs.append(r)
    runs.sort(key=lambda r: (r["_config_name"], r.get("seed", 0), r.get("ranks", 0)))
    return runs


def config_key(run):
    """Everything that must be equal for two runs to be comparable: engine and
    the resolved config without run.output (and the comments)."""
    lines = [l for l in run.get("config", "").splitlines()
             if l.strip() and not l.lstrip().startswith(("#", ";")) and not l.startswith("output")]
    return (run.get("engine"), "\n".join(lines))


def comparable_groups(runs):
    """Runs grouped by config_key: members differ only in rank count (and output dir)."""
    groups = defaultdict(list)
    for r in runs:
        groups[config_key(r)].append(r)
    return list(groups.values())


def digest_agreement(runs):
    """{id(run): True/False/None}: does the run's digest equal every other run of
    its group (None: alone in its group)."""
    agree = {}
    for members in comparable_groups(runs):
        digests = {m.get("digest") for m in members}
        for m in members:
            agree[id(m)] = None if len(members) == 1 else len(digests) == 1
    return agree


def phase_seconds(run, stat="max"):
    """[(phase name, seconds)] from summary.json phases (max over ranks by default)."""
    return [(p["name"], float(p.get(stat, 0.0))) for p in run.get("phases", [])]


def outputs(run, kind=None, role=None):
    """Absolute paths of the outputs listed in summary.json, optionally of one
    kind (the format: h5, mesh, ...) and role (what it holds: field, lattice, ...)."""
    return [os.path.join(run["_path"], o["path"]) for o in run.get("outputs", [])
            if (kind is None or o.get("kind") == kind) and (role is None or o.get("role") == role)]


# --- HDF5 ----------------------------------------------------------------

def read_h5(path, dataset):
    import h5py
    with h5py.File(path, "r") as f:
        return f[dataset][()]


def read_h5_group(path, group):
    """{dataset name: array} and {attribute: value} of one HDF5 group."""
    import h5py
    with h5py.File(path, "r") as f:
        g = f[group]
        data = {k: g[k][()] for k in g if isinstance(g[k], h5py.Dataset)}
        attrs = {k: g.attrs[k] for k in g.attrs}
    return data, attrs


def field_volume(run):
    """The synthesized distance field {nz, ny, nx} of a field run, or None."""
    for p in outputs(run, "h5", "field"):
        return read_h5(p, "/field/distance")
    return None


def model_lattice(run):
    """The label lattice {nz, ny, nx} of a model run, or None."""
    for p in outputs(run, "h5", "lattice"):
        return read_h5(p, "/model/labels")
    return None


def micro_histograms(run):
    """[(instance dir, target_count, achieved_count, bins of the negative region,
    realized_count or None)] of a micro run. The histogram runs over signed
    distance: the negative region's bins (farthest first), then the positive
    region's. achieved counts the labels the reconstruction assigned; realized
    is measured from the regions and the surface (true geodesic distance of each
    triangle to the interface)."""
    res = []
    for p in outputs(run, "h5", "labels"):
        if p.endswith(".h5"):
            d, _ = read_h5_group(p, "/micro")
            if "target_count" in d and "achieved_count" in d:
                res.append((os.path.basename(os.path.dirname(p)), d["target_count"], d["achieved_count"],
                            len(d.get("dist_neg", ())), d.get("realized_count")))
    return res


# --- meshes --------------------------------------------------------------

_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
              "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
              "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}


def _ply_header(path):
    """(format, [(element, count, [property words])], comments, body bytes) of a PLY file."""
    with open(path, "rb") as f:
        if f.readline().strip() != b"ply":
            raise ValueError(f"{path}: not a PLY file")
        fmt, elements, comments = None, [], []
        while True:
            line = f.readline()
            if not line:
                raise ValueError(f"{path}: no end_header")
            w = line.decode("ascii", "replace").split()
            if not w or w[0] == "obj_info":
                continue
            if w[0] == "comment":
                comments.append(" ".join(w[1:]))
            elif w[0] == "format":
                fmt = w[1]
            elif w[0] == "element":
                elements.append((w[1], int(w[2]), []))
            elif w[0] == "property":
                elements[-1][2].append(w[1:])
            elif w[0] == "end_header":
                break
        return fmt, elements, comments, f.read()


def read_ply(path):
    """(vertices float32 (n, 3), faces int (m, k)) of a PLY file (ascii or binary);
    faces of different corner counts (model meshes' polygons) come fanned into
    triangles."""
    fmt, elements, _, body = _ply_header(path)
    if fmt == "ascii":
        return _ply_ascii(body, elements)
    end = "<" if fmt == "binary_little_endian" else ">"
    verts = faces = None
    off = 0
    for name, count, props in elements:
        if any(p[0] == "list" for p in props):
            # Fixed corner count: read the first row's count, verify all rows.
            fields, k = [], None
            for p in props:
                if p[0] == "list":
                    ct, it = np.dtype(end + _PLY_TYPES[p[1]]), _PLY_TYPES[p[2]]
                    k = int(np.frombuffer(body, ct, 1, off)[0])
                    fields += [("n", ct), (p[3], end + it, (k,))]
                else:
                    fields.append((p[1], end + _PLY_TYPES[p[0]]))
            dt = np.dtype(fields)
            if off + dt.itemsize * count > len(body):
                # rows shorter than the first one's (a model mesh: quads, then triangles)
                return _fan(read_ply_polygons(path))
            arr = np.frombuffer(body, dt, count, off)
            if count and not np.all(arr["n"] == k):
                return _fan(read_ply_polygons(path))
            off += dt.itemsize * count
            if name == "face":
                faces = np.asarray(arr[[p for p in dt.names if p != "n"][0]], dtype=np.int64)
        else:
            dt = np.dtype([(p[1], end + _PLY_TYPES[p[0]]) for p in props])
            arr = np.frombuffer(body, dt, count, off)
            off += dt.itemsize * count
            if name == "vertex":
                verts = np.stack([arr["x"], arr["y"], arr["z"]], axis=1).astype(np.float32)
    return verts, faces


def read_ply_vertex_property(path, name):
    """The vertex property `name` of a binary PLY file whose vertex element
    comes first (geosynth's meshes: micro's uchar label) as a numpy array."""
    fmt, elements, _, body = _ply_header(path)
    if fmt == "ascii" or not elements or elements[0][0] != "vertex":
        raise ValueError(f"{path}: expected a binary PLY whose first element is vertex")
    end = "<" if fmt == "binary_little_endian" else ">"
    _, count, props = elements[0]
    if any(p[0] == "list" for p in props):
        raise ValueError(f"{path}: list property in the vertex element")
    dt = np.dtype([(p[1], end + _PLY_TYPES[p[0]]) for p in props])
    if name not in dt.names:
        raise ValueError(f"{path}: no vertex property {name}")
    return np.frombuffer(body, dt, count, 0)[name].copy()


def _ply_ascii(body, elements):
    lines = body.decode("ascii").splitlines()
    pos, verts, faces = 0, None, None
    for name, count, props in elements:
        rows = [l.split() for l in lines[pos:pos + count]]
        pos += count
        if name == "vertex":
            names = [p[1] for p in props]
            ix = [names.index(c) for c in "xyz"]
            verts = np.array([[float(r[i]) for i in ix] for r in rows], dtype=np.float32)
        elif name == "face":
            faces = np.array([[int(v) for v in r[1:1 + int(r[0])]] for r in rows], dtype=np.int64)
    return verts, faces


def _fan(p):
    v = p["vertex"]
    verts = np.stack([v["x"], v["y"], v["z"]], axis=1).astype(np.float32)
    counts, corners = p["counts"], p["corners"]
    start = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
    f = np.repeat(np.arange(len(counts)), np.maximum(counts - 2, 0))
    j = np.arange(len(f)) - np.repeat(np.cumsum(np.maximum(counts - 2, 0)) - np.maximum(counts - 2, 0),
                                      np.maximum(counts - 2, 0))
    s = start[f]
    return verts, np.stack([corners[s], corners[s + j + 1], corners[s + j + 2]], axis=1)


def read_ply_polygons(path):
    """Every element of a PLY file as written, nothing welded or triangulated:
    {"vertex": {prop: array}, "face": {prop: array}, "counts": corners per face,
    "corners": the faces' vertex indices one after the other, "comments": [...]}.
    Faces may have any corner count (ascii or binary, either endian)."""
    import struct
    fmt, elements, comments, body = _ply_header(path)
    out = {"comments": comments, "counts": np.zeros(0, np.int64), "corners": np.zeros(0, np.int64)}
    if fmt == "ascii":
        toks = body.split()
        pos = 0
        for name, count, props in elements:
            cols = {p[-1]: [] for p in props}
            counts, corners = [], []
            for _ in range(count):
                for p in props:
                    if p[0] == "list":
                        k = int(toks[pos]); pos += 1
                        vals = [int(t) for t in toks[pos:pos + k]]; pos += k
                        if name == "face" and p[-1] in ("vertex_indices", "vertex_index"):
                            counts.append(k); corners += vals
                    else:
                        cols[p[-1]].append(float(toks[pos])); pos += 1
            out[name] = {k: np.array(v, _PLY_TYPES[[p for p in props if p[-1] == k][0][0]])
                         for k, v in cols.items() if v or not any(p[0] == "list" and p[-1] == k for p in props)}
            if name == "face":
                out["counts"], out["corners"] = np.array(counts, np.int64), np.array(corners, np.int64)
        return out
    end = "<" if fmt == "binary_little_endian" else ">"
    off = 0
    for name, count, props in elements:
        if not any(p[0] == "list" for p in props):
            dt = np.dtype([(p[1], end + _PLY_TYPES[p[0]]) for p in props])
            arr = np.frombuffer(body, dt, count, off)
            off += dt.itemsize * count
            out[name] = {p[1]: np.array(arr[p[1]]) for p in props}
            continue
        cols = {p[-1]: [] for p in props if p[0] != "list"}
        counts, corners = [], []
        codes = {"i1": "b", "u1": "B", "i2": "h", "u2": "H", "i4": "i", "u4": "I", "f4": "f", "f8": "d"}
        for _ in range(count):
            for p in props:
                if p[0] == "list":
                    ct, it = codes[_PLY_TYPES[p[1]]], codes[_PLY_TYPES[p[2]]]
                    (k,) = struct.unpack_from(end + ct, body, off)
                    off += struct.calcsize(ct)
                    vals = struct.unpack_from(end + it * k, body, off)
                    off += struct.calcsize(it) * k
                    if name == "face":
                        counts.append(k)
                        corners += vals
                else:
                    c = codes[_PLY_TYPES[p[0]]]
                    cols[p[1]].append(struct.unpack_from(end + c, body, off)[0])
                    off += struct.calcsize(c)
        out[name] = {k: np.array(v, _PLY_TYPES[[p for p in props if p[-1] == k][0][0]])
                     for k, v in cols.items()}
        if name == "face":
            out["counts"], out["corners"] = np.array(counts, np.int64), np.array(corners, np.int64)
    return out


def read_obj_polygons(path):
    """(vertices float64 (n, 3), corners per face, the faces' vertex indices one
    after the other) of a Wavefront OBJ, faces as stored (0-based indices)."""
    v, counts, corners = [], [], []
    with open(path) as f:
        for line in f:
            w = line.split()
            if not w:
                continue
            if w[0] == "v":
                v.append([float(x) for x in w[1:4]])
            elif w[0] == "f":
                idx = [int(x.split("/")[0]) for x in w[1:]]
                idx = [i - 1 if i > 0 else len(v) + i for i in idx]
                counts.append(len(idx))
                corners += idx
    return np.array(v, np.float64).reshape(-1, 3), np.array(counts, np.int64), np.array(corners, np.int64)


def read_obj(path):
    """(vertices, triangles) of a Wavefront OBJ (polygons fanned into triangles)."""
    v, counts, corners = read_obj_polygons(path)
    tri, at = [], 0
    for k in counts:
        idx = corners[at:at + k]
        at += k
        tri += [[idx[0], idx[j], idx[j + 1]] for j in range(1, k - 1)]
    return v.astype(np.float32), np.array(tri, dtype=np.int64).reshape(-1, 3)


def read_mesh(path):
    return read_obj(path) if path.lower().endswith(".obj") else read_ply(path)


def _linear_to_srgb8(x):
    x = np.clip(np.asarray(x, np.float64), 0, 1)
    s = np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)
    return np.rint(s * 255).astype(np.uint8)


def read_glb(path):
    """A glTF 2.0 binary as geosynth writes it (include/geosynth/glb.h), checked
    against the format as it is read: header, 4-byte aligned JSON and BIN
    chunks, every accessor inside its buffer view and the buffer, POSITION
    min/max as stored, indices in range. Returns {"json", "pos" (n, 3) back in
    z-up, "normals" or None, "rgb" (n, 3) sRGB bytes of COLOR_0 or None,
    "primitives": [{"mode", "indices" or None, "material", "rgb" sRGB bytes of
    baseColorFactor}]}. Raises ValueError naming what is wrong."""
    b = open(path, "rb").read()
    if len(b) < 20 or b[:4] != b"glTF":
        raise ValueError(f"{path}: not a glTF binary")
    version, length = np.frombuffer(b[4:12], "<u4")
    if version != 2 or length != len(b):
        raise ValueError(f"{path}: version {version}, length {length} of {len(b)} bytes")
    jl, jt = np.frombuffer(b[12:20], "<u4")
    if jt != 0x4E4F534A or jl % 4 or 20 + jl + 8 > len(b):
        raise ValueError(f"{path}: bad JSON chunk")
    js = json.loads(b[20:20 + jl].decode("utf-8"))
    bl, bt = np.frombuffer(b[20 + jl:28 + jl], "<u4")
    binary = b[28 + jl:28 + jl + bl]
    if bt != 0x004E4942 or bl % 4 or 28 + jl + bl != len(b):
        raise ValueError(f"{path}: bad BIN chunk")
    if js["asset"]["version"] != "2.0" or js["buffers"][0]["byteLength"] > bl:
        raise ValueError(f"{path}: asset version or buffer length")
    comps = {5126: ("<f4", 4), 5125: ("<u4", 4), 5123: ("<u2", 2), 5121: ("u1", 1)}
    width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}

    def accessor(i):
        a = js["accessors"][i]
        v = js["bufferViews"][a["bufferView"]]
        dt, size = comps[a["componentType"]]
        k = width[a["type"]]
        start = v.get("byteOffset", 0) + a.get("byteOffset", 0)
        end = start + a["count"] * k * size
        if start % size or end > v.get("byteOffset", 0) + v["byteLength"] or \
                v.get("byteOffset", 0) + v["byteLength"] > js["buffers"][0]["byteLength"] or "byteStride" in v:
            raise ValueError(f"{path}: accessor {i} outside its view or buffer")
        x = np.frombuffer(binary[start:end], dt).reshape(-1, k) if k > 1 else np.frombuffer(binary[start:end], dt)
        if "min" in a and not (np.array_equal(x.min(0), np.float32(a["min"])) and np.array_equal(x.max(0), np.float32(a["max"]))):
            raise ValueError(f"{path}: accessor {i} min/max differ from the data")
        return x

    def z_up(v):  # stored (x, z, -y)
        return np.stack([v[:, 0], -v[:, 2], v[:, 1]], axis=1).astype(np.float64) + 0.0

    mesh = js["meshes"][js["nodes"][js["scenes"][js["scene"]]["nodes"][0]]["mesh"]]
    attrs = mesh["primitives"][0]["attributes"]
    pos = accessor(attrs["POSITION"])
    if "min" not in js["accessors"][attrs["POSITION"]]:
        raise ValueError(f"{path}: POSITION without min/max")
    out = {"json": js, "pos": z_up(pos), "normals": z_up(accessor(attrs["NORMAL"])) if "NORMAL" in attrs else None,
           "rgb": _linear_to_srgb8(accessor(attrs["COLOR_0"])) if "COLOR_0" in attrs else None, "primitives": []}
    for p in mesh["primitives"]:
        if p["attributes"] != attrs:
            raise ValueError(f"{path}: primitives with different vertex lists")
        idx = accessor(p["indices"]).astype(np.int64) if "indices" in p else None
        if idx is not None and (len(idx) % 3 or (len(idx) and idx.max() >= len(pos))):
            raise ValueError(f"{path}: indices out of range or not triangles")
        m = js["materials"][p["material"]]
        f = m["pbrMetallicRoughness"]["baseColorFactor"]
        out["primitives"].append({"mode": p.get("mode", 4), "indices": idx, "material": m["name"],
                                  "rgb": _linear_to_srgb8(f[:3])})
    return out


def mesh_face_count(path):
    """Faces as the file stores them (polygons count once, however many corners)."""
    if path.lower().endswith(".ply"):
        return next((n for name, n, _ in _ply_header(path)[1] if name == "face"), 0)
    return len(read_obj_polygons(path)[1])


def mesh_outputs(run):
    """Mesh files of a run (PLY/OBJ outputs in summary.json)."""
    return [p for p in outputs(run, "mesh") if p.lower().endswith((".ply", ".obj"))]


# --- benchmarks ----------------------------------------------------------

def read_bench_field(path):
    """tests/bench field JSON -> [(case label, {query kind: {tree_s, brute_s, fft_s}})]:
    the made-up query kinds, then the queries recorded from real syntheses
    (synthesis_paper, _weighted, _masked; tree_s is their mean)."""
    b = read_json(path)
    res = []
    for c in b.get("cases", []):
        shape = os.path.splitext(os.path.basename(str(c.get("shape", "?"))))[0]
        label = f"{shape} {c.get('source')}^3 / {c.get('block')}"
        kinds = dict(c.get("queries", {}))
        for k, v in c.get("synthesis_queries", {}).items():
            if isinstance(v, dict):
                kinds[k] = v
        res.append((label, kinds))
    return res
