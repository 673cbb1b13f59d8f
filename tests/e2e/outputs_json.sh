# End-to-end: one JSON vocabulary across engines (#23 item 6). Every engine's
# quick run writes a summary.json that docs/summary.schema.json accepts
# (tests/util/json_schema.py: output kinds from one list, a role, the
# dimensions of every grid, mesh, point cloud and image, metric keys with
# their unit last: search_seconds, never seconds_search); the dimensions
# agree with the files as h5py and the PNG/PLY/.vox headers read them; seeds
# above 2^53 read back exactly through jq and JavaScript (seed_string). The
# validator itself must refuse broken summaries.
source "$GS_ROOT/tests/e2e/lib.bash"
SCHEMA=$GS_ROOT/docs/summary.schema.json
VALIDATE="/usr/bin/python3 $GS_ROOT/tests/util/json_schema.py $SCHEMA"
BIG=9007199254740993   # 2^53 + 1: a double reads it as ...992 (run.seed is an int64)

# run directory = engine, except tiles (a model run with a 3D tile set: tiles.vox)
declare -A cfg=([field]=field/quick.ini [points]=points/quick.ini [micro]=micro/quick.ini
                [model]=model/demo.ini [tiles]=model/tiles-knots3d.ini)
for e in field points micro model tiles; do
  run_gs 1 "$([[ $e == tiles ]] && echo model || echo "$e")" -c "$GS_ROOT/configs/${cfg[$e]}" -o "$e" \
    --set run.seed=$BIG
  expect_rc 0 "$e ${cfg[$e]} with run.seed = $BIG"
  if $VALIDATE "$e/summary.json" >schema.log 2>&1; then
    ok "$e: summary.json matches docs/summary.schema.json"
  else
    bad "$e: summary.json breaks the schema: $(head -c 600 schema.log)"
  fi
  # the seed as jq and JavaScript read it
  [[ $(jq -r .seed_string "$e/summary.json") == "$BIG" ]] && ok "$e: jq reads seed_string exactly" \
    || bad "$e: jq reads seed_string as $(jq -r .seed_string "$e/summary.json")"
  if node -e '
      const fs = require("fs"), want = process.argv[2];
      for (const f of [process.argv[1], process.argv[3]]) {
        if (f !== process.argv[1] && !fs.existsSync(f)) continue;
        const text = fs.readFileSync(f, "utf8"), doc = JSON.parse(text);
        const objs = Array.isArray(doc) ? doc : [doc];
        const raw = [...text.matchAll(/"seed":(\d+)/g)].map(m => m[1]);
        const strs = objs.filter(o => "seed" in o).map(o => o.seed_string);
        if (raw.length === 0 || raw.length !== strs.length) throw f + ": " + raw.length + " seeds, " + strs.length + " seed_string";
        raw.forEach((r, i) => { if (BigInt(strs[i]) !== BigInt(r)) throw f + ": seed " + r + " but seed_string " + strs[i]; });
        if (!Array.isArray(doc) && doc.seed_string !== want) throw f + ": seed_string " + doc.seed_string;
      }' "$e/summary.json" "$BIG" "$e/instances.json" 2>node.log; then
    ok "$e: JavaScript reads every seed exactly (seed_string = the written seed)"
  else
    bad "$e: JavaScript seeds: $(head -c 400 node.log)"
  fi
done

# the dimensions in summary.json are those of the files (h5py, PNG, PLY, .vox)
if /usr/bin/python3 - field points micro model tiles >dims.log 2>&1 <<'PY'
import json, struct, sys, h5py
bad = []
def png(p):
    b = open(p, "rb").read(24); return list(struct.unpack(">II", b[16:24]))
def ply(p):
    n = {}
    with open(p, "rb") as f:
        for line in f:
            w = line.split()
            if w[:1] == [b"element"]: n[w[1].decode()] = int(w[2])
            if w[:1] == [b"end_header"]: break
    return n
def vox(p):
    b = open(p, "rb").read(); i = b.index(b"SIZE"); return list(struct.unpack("<3i", b[i + 12:i + 24]))
seen = set()
for d in sys.argv[1:]:
    s = json.load(open(d + "/summary.json"))
    for o in s["outputs"]:
        p, k = d + "/" + o["path"], o["kind"]
        seen.add(k)
        if k == "h5" and "dimensions" in o:
            with h5py.File(p, "r") as f:
                ds = f["/field/distance" if o["role"] == "field" else "/model/labels"]
                got = list(ds.shape[::-1])
        elif k == "vox": got = vox(p)
        elif k in ("image", "preview"): got = png(p); o["dimensions"] = o["pixels"]
        elif k == "mesh" and p.endswith(".ply"):
            n = ply(p); got = [n.get("vertex"), n.get("face")]; o["dimensions"] = [o["vertices"], o["faces"]]
        elif k == "points": got = [ply(p)["vertex"]]; o["dimensions"] = [o["points"]]
        else: continue
        if got != o["dimensions"]: bad.append("%s: summary says %s, the file %s" % (p, o["dimensions"], got))
for k in ("h5", "xdmf", "vdb", "vox", "mesh", "points", "preview", "json", "csv"):
    if k not in seen: bad.append("no engine listed an output of kind " + k)
for d in sys.argv[1:]:  # every preview.png a run wrote is listed (micro: one per instance)
    import glob, os
    listed = {o["path"] for o in json.load(open(d + "/summary.json"))["outputs"]}
    for p in glob.glob(d + "/**/preview.png", recursive=True):
        if os.path.relpath(p, d) not in listed: bad.append(p + " is not listed in summary.json")
print("\n".join(bad) or "dims ok")
sys.exit(1 if bad else 0)
PY
then ok "output dimensions in summary.json equal the files' (h5py shapes, PNG, PLY, .vox headers)"
else bad "output dimensions: $(head -c 800 dims.log)"; fi

# the validator refuses what the vocabulary forbids
mutate() { # NAME JQ-FILTER: a broken copy of field's (or points') summary must fail
  local src=$1 what=$2 filter=$3
  jq "$filter" "$src/summary.json" >broken.json
  if $VALIDATE broken.json >/dev/null 2>&1; then bad "the schema accepts $what"
  else ok "the schema refuses $what"; fi
}
mutate points "a metric named seconds_search" '.metrics.seconds_search = 1'
mutate field "an engine-specific kind (field_vdb)" '.outputs[0].kind = "field_vdb"'
mutate field "a grid output without dimensions" 'del(.outputs[0].dimensions)'
mutate field "a mesh without its face count" '(.outputs[] | select(.kind == "mesh")) |= del(.faces)'
mutate points "a point cloud without its point count" '(.outputs[] | select(.kind == "points")) |= del(.points)'
mutate field "a seed without seed_string" 'del(.seed_string)'
mutate field "seed_string as a number" '.seed_string = 5'
finish
