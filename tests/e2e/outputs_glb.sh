# End-to-end: glTF binary (.glb) of every mesh, opened the way Blender, three.js
# and game-engine users open it (#23 item 4). Every engine's meshes: field
# contour.glb and copied.glb (quick.ini at np 2), micro instance mesh.glb
# (region colours), model mesh.glb (label colours), points mesh.glb
# (output.mesh). Each file, read back by analysis/gsio.py read_glb (header,
# aligned chunks, accessors inside their views, POSITION min/max as stored),
# holds exactly the vertices and triangles of its PLY twin (back in z-up),
# the twin's colours (micro: COLOR_0 = the PLY's vertex colours; model: one
# material label_N per label = the PLY's face colour of that label), the
# counts summary.json lists, and up axis + units in asset.extras. Then the
# Khronos glTF validator (0 errors, 0 warnings) and three.js' GLTFLoader (the
# same triangles, colours, and z-up turned into glTF's y-up) under node, from
# tests/gltf (installed by scripts/install-deps.sh into build/gltf), and
# Blender's importer when Blender is installed.
source "$GS_ROOT/tests/e2e/lib.bash"

run_gs 2 field -c "$GS_ROOT/configs/field/quick.ini" -o field
expect_rc 0 "field quick.ini at np 2 (contour + copied geometry)"
run_gs 0 micro -c "$GS_ROOT/configs/micro/quick.ini" -o micro
expect_rc 0 "micro quick.ini"
run_gs 0 model -c "$GS_ROOT/configs/model/demo.ini" -o model
expect_rc 0 "model demo.ini"
run_gs 0 points -c "$GS_ROOT/configs/points/quick.ini" -o points --set output.mesh=true
expect_rc 0 "points quick.ini with output.mesh"
glbs=(field/contour.glb field/copied.glb micro/instance-0000/mesh.glb model/mesh.glb points/mesh.glb)

/usr/bin/python3 - "$GS_ROOT" "${glbs[@]}" >glb.json <<'EOF' && ok "every .glb holds its PLY twin: vertices, triangles, colours, counts in summary.json, up axis + units" || bad "a .glb differs from its PLY twin"
import json, os, sys
import numpy as np
sys.path.insert(0, sys.argv[1] + "/analysis")
import gsio
fails, expect = [], {}
for path in sys.argv[2:]:
    run = path.split("/")[0]
    g = gsio.read_glb(path)
    ply = gsio.read_ply_polygons(path[:-4] + ".ply")
    v = ply["vertex"]
    pos = np.stack([v["x"], v["y"], v["z"]], axis=1).astype(np.float64)
    tris = np.concatenate([p["indices"] for p in g["primitives"]]).reshape(-1, 3)
    start = np.concatenate([[0], np.cumsum(ply["counts"])[:-1]])
    fan = [np.stack([ply["corners"][start[c > j + 1]], ply["corners"][start[c > j + 1] + j],
                     ply["corners"][start[c > j + 1] + j + 1]], 1) for c in [ply["counts"]] for j in range(1, c.max() - 1)]
    fan = np.concatenate(fan)
    ex = g["json"]["asset"]["extras"]
    need = []
    need.append((np.array_equal(g["pos"], pos), "positions = the PLY's (z-up)"))
    need.append((sorted(map(tuple, tris)) == sorted(map(tuple, fan)), f"{len(tris)} triangles = the PLY's {len(fan)} (fanned quads)"))
    need.append((ex["up_axis"] == "z" and ex["units"] and ex["vertices"] == len(pos) and ex["triangles"] == len(tris), f"asset.extras {ex}"))
    s = [o for o in json.load(open(f"{run}/summary.json"))["outputs"] if o["path"] == path[len(run) + 1:]]
    need.append((len(s) == 1 and s[0]["kind"] == "mesh" and s[0]["vertices"] == len(pos) and s[0]["faces"] == len(tris), f"summary.json lists it: {s}"))
    if g["normals"] is not None:
        need.append((np.allclose(np.linalg.norm(g["normals"], axis=1), 1, atol=1e-5), "unit normals"))
    colours = []
    if run == "micro":
        rgb = np.stack([v["red"], v["green"], v["blue"]], axis=1)
        need.append((g["rgb"] is not None and np.array_equal(g["rgb"], rgb), "COLOR_0 = the PLY's vertex colours"))
    if run == "model":
        f = ply["face"]
        for p in g["primitives"]:
            lab = int(p["material"].split("_")[1])
            sel = f["label"] == lab
            face_rgb = np.unique(np.stack([f["red"], f["green"], f["blue"]], 1)[sel], axis=0)
            need.append((len(face_rgb) == 1 and np.array_equal(face_rgb[0], p["rgb"]), f"label {lab}: material {p['rgb']} = face colour {face_rgb}"))
            need.append((len(p["indices"]) // 3 == int((ply["counts"][sel] - 2).sum()), f"label {lab}: its faces"))
            colours.append("%02x%02x%02x" % tuple(int(c) for c in face_rgb[0]))  # what users must see
    # Blender keeps the vertices each primitive uses, its own for each
    expect_bl_verts = sum(len(np.unique(p["indices"])) for p in g["primitives"])
    for cond, what in need:
        print(("  ok   " if cond else "  FAIL ") + path + ": " + what)
        cond or fails.append(path)
    expect[path] = {"triangles": len(tris), "vertices": len(pos), "primitives": len(g["primitives"]),
                    "colours": colours, "coloured": run == "micro", "blender_vertices": expect_bl_verts,
                    "zmax": float(pos[:, 2].max()), "ymin": float(pos[:, 1].min())}
json.dump(expect, open("expect.json", "w"))
sys.exit(1 if fails else 0)
EOF
cat glb.json

# break the file on purpose: the reader must refuse it
head -c 2000 model/mesh.glb >cut.glb
/usr/bin/python3 -c "import sys; sys.path.insert(0, sys.argv[1] + '/analysis'); import gsio; gsio.read_glb('cut.glb')" "$GS_ROOT" 2>/dev/null \
  && bad "a cut .glb was accepted by gsio.read_glb" || ok "a cut .glb is refused by gsio.read_glb"

gltf_dir=$GS_ROOT/build/gltf
if command -v node >/dev/null && [[ -d $gltf_dir/node_modules/three && -d $gltf_dir/node_modules/gltf-validator ]]; then
  paths=(); for f in "${glbs[@]}"; do paths+=("$PWD/$f"); done
  (cd "$gltf_dir" && timeout 300 node check.mjs "${paths[@]}") >three.jsonl 2>three.err
  /usr/bin/python3 - <<'EOF' && ok "glTF validator: 0 errors, 0 warnings; three.js GLTFLoader: the same triangles, colours and y-up extent" || { bad "glTF validator or three.js"; cat three.err; }
import json, sys
expect = json.load(open("expect.json"))
fails = 0
for line in open("three.jsonl"):
    r = json.loads(line)
    path = [p for p in expect if r["file"].endswith("/" + p)][0]
    e, t = expect[path], r.get("three", {})
    need = [(r["errors"] == 0 and r["warnings"] == 0, f"validator: {r['errors']} errors, {r['warnings']} warnings {r['messages'][:5]}"),
            ("three_error" not in r, r.get("three_error", "")),
            (t.get("triangles") == e["triangles"] and t.get("primitives") == e["primitives"], f"three.js: {t.get('triangles')} triangles in {t.get('primitives')} meshes"),
            (set(t.get("positions", [])) == {e["vertices"]}, f"three.js vertex buffers {set(t.get('positions', []))}"),
            ((t.get("vertexColoured") == 1) == e["coloured"], f"three.js vertex colours used: {t.get('vertexColoured')}"),
            (not e["colours"] or sorted(t.get("colours", [])) == sorted(e["colours"]), "three.js material colours = the label colours"),
            (abs(t["box"][1][1] - e["zmax"]) < 1e-4 and abs(t["box"][1][2] + e["ymin"]) < 1e-4, f"y-up: three.js box {t.get('box')}")]
    for cond, what in need:
        print(("  ok   " if cond else "  FAIL ") + path + ": " + what)
        fails += not cond
sys.exit(1 if fails else 0)
EOF
else
  skipped "glTF validator and three.js check: node or build/gltf/node_modules missing (make deps installs tests/gltf with npm)"
fi

if command -v blender >/dev/null; then
  cat >bl.py <<'EOF'
import bpy, json, sys
paths = sys.argv[sys.argv.index("--") + 1:]
for path in paths:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    # Debian 12's Blender 3.4 importer stops on numpy 1.24 (np.bool) with the
    # default shading "Use Normal Data": users pick Flat or Smooth (FORMATS.md)
    bpy.ops.import_scene.gltf(filepath=path, import_shading="SMOOTH")
    for o in bpy.context.scene.objects:
        if o.type != "MESH":
            continue
        me = o.data
        cols = []
        for m in me.materials:
            bsdf = m.node_tree.nodes.get("Principled BSDF")
            cols.append(list(bsdf.inputs["Base Color"].default_value[:3]))
        print("BLENDER", json.dumps({"file": path, "vertices": len(me.vertices), "faces": len(me.polygons),
                                     "materials": len(me.materials), "colours": cols,
                                     "colour_attributes": [a.name for a in me.color_attributes],
                                     "zmax": max((o.matrix_world @ v.co).z for v in me.vertices)}))
EOF
  timeout 600 blender -b --factory-startup --python bl.py -- "${glbs[@]}" 2>&1 | grep '^BLENDER ' | cut -c9- >blender.jsonl
  /usr/bin/python3 - <<'EOF' && ok "Blender imports every .glb: its vertices, triangles, label materials, vertex colours, z up" || bad "Blender import of the .glb files"
import json, sys
expect = json.load(open("expect.json"))
seen, fails = set(), 0
def srgb(x):
    s = 12.92 * x if x <= 0.0031308 else 1.055 * x ** (1 / 2.4) - 0.055
    return round(s * 255)
for line in open("blender.jsonl"):
    r = json.loads(line)
    path = r["file"]
    e = expect[path]
    seen.add(path)
    cols = sorted("%02x%02x%02x" % tuple(srgb(c) for c in rgb) for rgb in r["colours"])
    need = [(r["faces"] == e["triangles"] and r["vertices"] == e["blender_vertices"], f"Blender: {r['vertices']} vertices, {r['faces']} faces"),
            (not e["colours"] or cols == sorted(e["colours"]), f"Blender materials {len(cols)} = label colours"),
            (bool(r["colour_attributes"]) == e["coloured"], f"Blender colour attributes {r['colour_attributes']}"),
            (abs(r["zmax"] - e["zmax"]) < 1e-4, f"z up: top at {r['zmax']}")]
    for cond, what in need:
        print(("  ok   " if cond else "  FAIL ") + path + ": " + what)
        fails += not cond
missing = set(expect) - seen
print("not imported:", sorted(missing)) if missing else None
sys.exit(1 if fails or missing else 0)
EOF
else
  skipped "Blender import of the .glb files: blender is not installed (apt-get install blender)"
fi
finish
