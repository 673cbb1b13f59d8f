# End-to-end: the points engine (geosynth points -c configs/points/quick.ini).
# Same digest at np 1, 2, 3; outputs valid; output density within 10% of the
# example's; stop after N patches + resume at another np; kill -9 at a
# random moment + resume. Inputs and errors: tests/e2e/points_inputs.sh.
source "$GS_ROOT/tests/e2e/lib.bash"
CFG=$GS_ROOT/configs/points/quick.ini
RANDOM=$$

# check_ply DIR: points.ply is a binary PLY of float32 (#23) and an int patch
# id (#21) whose vertex count equals summary's output_points, inside the
# output box, unit normals, ids of the run's patches.
check_ply() {
  /usr/bin/python3 - "$1" <<'EOF'
import json, struct, sys, math
d = sys.argv[1]
m = json.load(open(d + "/summary.json"))["metrics"]
raw = open(d + "/points.ply", "rb").read()
end = raw.index(b"end_header\n") + len(b"end_header\n")
hdr = raw[:end].decode().split("\n")
assert hdr[1] == "format binary_little_endian 1.0", hdr[1]
n = int([l for l in hdr if l.startswith("element vertex")][0].split()[2])
props = [l.split()[2] for l in hdr if l.startswith("property")]
assert props == ["x", "y", "z", "nx", "ny", "nz", "patch"], props
assert n == m["output_points"], (n, m["output_points"])
assert len(raw) == end + 28 * n, (len(raw), end + 28 * n)
types = [l.split()[1] for l in hdr if l.startswith("property")]
assert types == ["float"] * 6 + ["int"], hdr
sx, sy = m["out_size_x"], m["out_size_y"]
ids = set()
for i in range(n):
    x, y, z, a, b, c, k = struct.unpack_from("<6fi", raw, end + 28 * i)
    ids.add(k)
    if i % max(1, n // 2000) == 0:
        assert 0 <= x < sx and 0 <= y < sy, (i, x, y)
        assert abs(a * a + b * b + c * c - 1) < 1e-6, (i, a, b, c)
# every point has its patch (0 .. patches - 1) and most patches have points
assert min(ids) >= 0 and max(ids) < m["patches"], (min(ids), max(ids), m["patches"])
assert len(ids) > m["patches"] // 2, (len(ids), m["patches"])
print("ply ok", n, "points of", len(ids), "patches")
EOF
}

metric() { /usr/bin/python3 -c 'import json,sys;print(json.load(open(sys.argv[1]+"/summary.json"))["metrics"][sys.argv[2]])' "$1" "$2"; }

# --- determinism over rank counts -------------------------------------------
declare -A dig
for np in 1 2 3; do
  run_gs "$np" points -c "$CFG" -o "run$np"
  expect_rc 0 "quick.ini at np=$np"
  dig[$np]=$(digest_of "run$np" 2>/dev/null)
  echo "np=$np digest ${dig[$np]}"
done
[[ -n "${dig[1]}" && "${dig[1]}" == "${dig[2]}" && "${dig[1]}" == "${dig[3]}" ]] &&
  ok "quick.ini digests identical at np 1, 2, 3 (${dig[1]})" ||
  bad "quick.ini digests differ: np1 ${dig[1]} np2 ${dig[2]} np3 ${dig[3]}"
ref=${dig[1]}

# points.choices (a run's patches.csv): each patch takes that run's source
# patch; with the same settings the output is the same, and another seed
# without the warp places the same patches (what the benchmark's ablations
# on the same patches rely on)
run_gs 2 points -c "$CFG" -o chosen --set points.choices="$PWD/run2/patches.csv"
expect_rc 0 "quick.ini with points.choices = its own patches.csv"
[[ $(digest_of chosen 2>/dev/null) == "$ref" ]] && ok "points.choices: the same output ($ref)" ||
  bad "points.choices: digest $(digest_of chosen 2>/dev/null), expected $ref"
run_gs 1 points -c "$CFG" -o chosen2 --set points.choices="$PWD/run2/patches.csv" \
  --set run.seed=2 --set points.max_pair_dist=0.000001
expect_rc 0 "quick.ini seed 2, no warp, points.choices = seed 1's patches.csv"
run_gs 1 points -c "$CFG" -o seed2 --set run.seed=2
expect_rc 0 "quick.ini seed 2"
c1=$(cut -d, -f1,2 run2/patches.csv | md5sum) c2=$(cut -d, -f1,2 chosen2/patches.csv | md5sum)
c3=$(cut -d, -f1,2 seed2/patches.csv | md5sum)
[[ $c1 == "$c2" && $c1 != "$c3" ]] &&
  ok "points.choices: seed 2 places seed 1's source patches (its own picks differ)" ||
  bad "points.choices: seed 2 with seed 1's choices places other patches (or seed 2 picks the same)"
printf 'patch,chosen,x\n0,1,0\n2,1,0\n' >bad_choices.csv
run_gs 0 points -c "$CFG" -o badc --set points.choices="$PWD/bad_choices.csv"
expect_rc 4 "points.choices: a row out of order"
expect_err "bad_choices.csv line 3" "points.choices: the error names the file and line"

out=$(check_ply run2 2>&1) && ok "points.ply valid ($out)" || bad "points.ply: $out"
# ParaView as FORMATS.md says to read it (#23 item 4): the PLY has no cells,
# Convert To Point Cloud gives one vertex cell per point
if command -v pvpython >/dev/null; then
  cat >pvpts.py <<'EOF'
import sys
from paraview.simple import PLYReader, ConvertToPointCloud
c = ConvertToPointCloud(Input=PLYReader(FileNames=[sys.argv[1]]))
c.CellGenerationMode = "Vertex cells"
c.UpdatePipeline()
d = c.GetDataInformation()
print("PV", d.GetNumberOfPoints(), d.GetNumberOfCells())
EOF
  n=$(/usr/bin/python3 -c 'import json,sys;print(json.load(open(sys.argv[1]))["metrics"]["output_points"])' run2/summary.json)
  pv=$(timeout 300 xvfb-run -a pvpython pvpts.py run2/points.ply 2>&1 | grep '^PV')
  [[ $pv == "PV $n $n" ]] && ok "ParaView: points.ply + Convert To Point Cloud = $n vertex cells" || bad "ParaView points: '$pv' (want PV $n $n)"
else
  echo "check skipped: ParaView points.ply check: pvpython is not installed (apt-get install python3-paraview)"
fi
# Blender's PLY importer and three.js' PLYLoader open it too (the int patch
# property after the normals is one they skip): every vertex comes in
n=$(metric run2 output_points)
if command -v blender >/dev/null; then
  cat >blply.py <<'EOF'
import bpy, sys
p = sys.argv[sys.argv.index("--") + 1]
bpy.ops.wm.read_factory_settings(use_empty=True)
if bpy.app.version >= (4, 0, 0):
    bpy.ops.wm.ply_import(filepath=p)
else:
    bpy.ops.import_mesh.ply(filepath=p)
print("BLENDER", len(bpy.context.selected_objects[0].data.vertices))
EOF
  bl=$(timeout 300 blender -b --factory-startup --python blply.py -- "$PWD/run2/points.ply" 2>&1 | grep '^BLENDER')
  [[ $bl == "BLENDER $n" ]] && ok "Blender: points.ply imports with $n vertices" || bad "Blender points.ply: '$bl' (want BLENDER $n)"
else
  skipped "Blender points.ply check: blender is not installed"
fi
gltf_dir=$GS_ROOT/build/gltf
if command -v node >/dev/null && [[ -d $gltf_dir/node_modules/three ]]; then
  cat >threeply.mjs <<EOF
import { PLYLoader } from "$gltf_dir/node_modules/three/examples/jsm/loaders/PLYLoader.js";
import fs from "fs";
const b = fs.readFileSync(process.argv[2]);
const g = new PLYLoader().parse(b.buffer.slice(b.byteOffset, b.byteOffset + b.length));
console.log("THREE", g.attributes.position.count, g.attributes.normal ? g.attributes.normal.count : 0);
EOF
  th=$(timeout 120 node threeply.mjs run2/points.ply 2>&1 | grep '^THREE')
  [[ $th == "THREE $n $n" ]] && ok "three.js PLYLoader: $n positions and normals" || bad "three.js points.ply: '$th' (want THREE $n $n)"
else
  skipped "three.js points.ply check: node or build/gltf/node_modules missing (make deps)"
fi
[[ -s run2/patches.csv ]] && [[ $(($(wc -l <run2/patches.csv) - 1)) -eq $(metric run2 patches) ]] &&
  ok "patches.csv has one row per patch" || bad "patches.csv rows"
ratio=$(metric run1 density_ratio)
/usr/bin/python3 -c "import sys; r=float(sys.argv[1]); sys.exit(0 if abs(r-1) < 0.10 else 1)" "$ratio" &&
  ok "output density within 10% of the example's (ratio $ratio)" ||
  bad "output density ratio $ratio is not within 10%"
res=$(metric run1 warp_residual_mean) gap=$(metric run1 pair_gap_mean)
/usr/bin/python3 -c "import sys; sys.exit(0 if float(sys.argv[1]) < float(sys.argv[2]) else 1)" "$res" "$gap" &&
  ok "warp pulls patches onto the neighbourhood (residual $res < pair gap $gap)" ||
  bad "warp residual $res not below the pair gap $gap"
grep -q '"search_seconds"' run1/summary.json && grep -q '"blend_seconds"' run1/summary.json &&
  ok "summary.json has search/warp/blend times" || bad "summary.json lacks phase times"

# --- stop after N patches, resume at another rank count ---------------------
GS_STOP_AFTER_UNITS=13 run_gs 2 points -c "$CFG" -o stop
expect_rc 9 "GS_STOP_AFTER_UNITS=13 at np=2 stops"
expect_err "resume" "interrupted run says how to resume"
run_gs 0 inspect stop/checkpoint.h5
expect_rc 0 "inspect the checkpoint"
expect_out "@cursor = 13" "checkpoint holds cursor 13"
run_gs 3 resume stop
expect_rc 0 "resume at np=3"
d=$(digest_of stop 2>/dev/null)
[[ "$d" == "$ref" ]] && ok "stop at np=2 + resume at np=3 = uninterrupted digest" ||
  bad "stop+resume digest $d != $ref"

# --- kill -9 at a random moment, resume ---------------------------------------
mkdir -p kill
timeout 300 mpirun -np 2 "$GS_BIN" points -c "$CFG" -o kill --set run.checkpoint_every=1 \
  >kill.log 2>&1 &
job=$!
for ((t = 0; t < 400; t++)); do
  [[ -e kill/checkpoint.h5 ]] && break
  sleep 0.05
done
delay_ms=$((RANDOM % 400 + 10))
sleep "$(printf '%d.%03d' $((delay_ms / 1000)) $((delay_ms % 1000)))"
launcher=$(pgrep -d, -P "$job") # mpirun (the child of timeout); the ranks are its children
ranks=$(pgrep -P "$launcher")
kill -KILL $ranks ${launcher//,/ } "$job" 2>/dev/null
wait "$job" 2>/dev/null
for ((t = 0; t < 100; t++)); do # the killed ranks hold the run directory's lock until gone
  kill -0 $ranks 2>/dev/null || break
  sleep 0.05
done
finished=no
[[ -e kill/summary.json ]] && finished=yes
run_gs 1 resume kill
expect_rc 0 "resume after kill -9 (${delay_ms} ms after the first checkpoint, run had finished: $finished)"
d=$(digest_of kill 2>/dev/null)
[[ "$d" == "$ref" ]] && ok "kill -9 at np=2 + resume at np=1 = uninterrupted digest ($d)" ||
  bad "kill+resume digest $d != $ref"

finish
