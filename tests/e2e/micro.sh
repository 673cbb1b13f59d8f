# End-to-end: the micro engine (stochastic microgeometry).
# - configs/micro/quick.ini (3 instances) at np 1, 2, 3: identical digests;
#   outputs exist and are valid (PLY re-parsed with its label property, HDF5
#   through `geosynth inspect`), instance digests combine into the run digest;
# - quality: the verifier finds 0 violations, the achieved histogram differs
#   from the target only by the unassigned triangles, and a distribution
#   measured from a Boolean-model image (a realizable one) is reconstructed
#   with < 0.5% unassigned and realized L1/n <= 0.05; quick.ini realized L1/n <= 0.05,
#   each region's share within 1% and its mean distance within 1/4 bin of the target's,
#   and > 0.05 with micro.correct = no (the measure is not the labels); the
#   reconstruction's metric on planet.ini is isotropic (excess over the straight
#   line < 2/sqrt(3), which hop paths over the dual graph reach); planet.ini's
#   islands (micro.correct_discs) are as many and as round as its disc table
#   asks, their coasts within 3% of an ideal disc's length on the same mesh
#   (analysis/micro_outline.py, from mesh.ply); a CSV table and several meshes work;
# - a table whose sides do not share a coast (the old gallery card 1) is warned
#   about, naming its coast bins; quick.ini gives no such warning;
# - bad inputs: missing mesh, negative probability, table sum, CSV errors,
#   unknown key, wrong type, missing image: exit 2/3 naming the file/key.
# Stop/resume and kill -9 are in micro_resume.sh.
source "$GS_ROOT/tests/e2e/lib.bash"
QUICK=$GS_ROOT/configs/micro/quick.ini

# ---- determinism over rank counts ----
declare -A dg
for np in 1 2 3; do
  run_gs $np micro -c "$QUICK" -o q$np
  expect_rc 0 "quick.ini at np=$np"
  dg[$np]=$(digest_of q$np 2>/dev/null)
done
grep -qF "misses the target" <<<"$err" && bad "quick.ini warns that its realized distribution misses the target" \
  || ok "quick.ini: no missed-target warning"
if [[ -n "${dg[1]}" && "${dg[1]}" == "${dg[2]}" && "${dg[1]}" == "${dg[3]}" ]]; then
  ok "quick.ini digest identical at np 1, 2, 3 (${dg[1]})"
else
  bad "quick.ini digests differ: np1 ${dg[1]} np2 ${dg[2]} np3 ${dg[3]}"
fi

# ---- outputs and quality, from instances.json and the files ----
/usr/bin/python3 - q1 q2 <<'EOF' && ok "outputs valid, checks within tolerance" || bad "outputs/quality (see above)"
import json, os, struct, sys
bad = []
def check(cond, msg):
    if not cond: bad.append(msg)
run = sys.argv[1]
summ = json.load(open(os.path.join(run, "summary.json")))
inst = json.load(open(os.path.join(run, "instances.json")))
other = json.load(open(os.path.join(sys.argv[2], "instances.json")))
check(len(inst) == 3, "3 instances expected, got %d" % len(inst))
check([i["digest"] for i in inst] == [i["digest"] for i in other], "instance digests differ between np 1 and 2")
check(len(set(i["digest"] for i in inst)) == 3, "the three seeds gave identical results")
m = summ["metrics"]
check(m["violations"] == 0, "violations %d" % m["violations"])
check(m["pairs_checked"] > 100000, "verifier checked only %d pairs" % m["pairs_checked"])
check(m["unassigned_share_max"] < 0.03, "unassigned share %g >= 3%%" % m["unassigned_share_max"])
check(m["min_angle_deg"] > 30, "min angle %g" % m["min_angle_deg"])
check(m["max_edge_units"] <= 0.9, "max edge %g > bound 0.9" % m["max_edge_units"])
for i in inst:
    # The realized contact distribution (true geodesic distance of every
    # triangle to the interface between its region and the other, measured
    # by src/measure, not the labels' values) matches the target: L1/n <=
    # 0.05 (issue 20), and every triangle has a value (< 1% unassigned).
    check(i["realized_l1"] <= 0.05, "instance %d: realized L1/n %.4f > 0.05 (reconstruction alone %.4f)"
          % (i["instance"], i["realized_l1"], i["recon_realized_l1"]))
    check(i["unassigned_share"] < 0.01, "instance %d: unassigned %.4f" % (i["instance"], i["unassigned_share"]))
    t, r = i["target_count"], i["realized_count"]
    check(sum(t) == sum(r) == i["triangles"], "instance %d: histograms do not count every triangle" % i["instance"])
    check(abs(sum(abs(a - b) for a, b in zip(t, r)) / i["triangles"] - i["realized_l1"]) < 1e-9,
          "instance %d: realized_l1 is not the histograms' L1/n" % i["instance"])
    # Drift the L1 can hide: each region's area share within 1% of the
    # target's and its mean distance to the interface within a quarter of a
    # bin (bins are 1 distribution unit wide) of the target's (bin centres).
    K = len(t) // 2
    for side, tb, rb in (("positive", t[K:], r[K:]), ("negative", t[:K][::-1], r[:K][::-1])):
        mt = sum((k + 0.5) * c for k, c in enumerate(tb)) / max(sum(tb), 1)
        mr = sum((k + 0.5) * c for k, c in enumerate(rb)) / max(sum(rb), 1)
        check(abs(mr - mt) <= 0.25, "instance %d: %s region's mean distance %.3f, target %.3f"
              % (i["instance"], side, mr, mt))
        check(abs(sum(rb) - sum(tb)) <= 0.01 * i["triangles"], "instance %d: %s region %d triangles, target %d"
              % (i["instance"], side, sum(rb), sum(tb)))
    ply = os.path.join(run, i["dir"], "mesh.ply")
    data = open(ply, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    head = data[:end].decode().split("\n")
    nv = nf = 0; props = []
    for line in head:
        w = line.split()
        if w[:2] == ["element", "vertex"]: nv = int(w[2])
        if w[:2] == ["element", "face"]: nf = int(w[2])
        if w[:1] == ["property"] and w[1] != "list" and nf == 0: props.append((w[1], w[2]))
    check(head[0] == "ply" and "format binary_little_endian 1.0" in head, "%s: not a binary PLY" % ply)
    check(("uchar", "label") in props, "%s: no uchar label property: %s" % (ply, props))
    check([p for p in props if p[1] in ("red", "green", "blue")] == [("uchar", "red"), ("uchar", "green"), ("uchar", "blue")],
          "%s: no per-vertex colours: %s" % (ply, props))
    check(nv == i["vertices"] and nf == i["triangles"], "%s: %d vertices %d faces, expected %d %d"
          % (ply, nv, nf, i["vertices"], i["triangles"]))
    vsize = sum(1 if t == "uchar" else 4 for t, _ in props)
    check(len(data) == end + nv * vsize + nf * 13, "%s: size %d does not match its header" % (ply, len(data)))
    off = {n: sum(1 if t == "uchar" else 4 for t, _ in props[:j]) for j, (_, n) in enumerate(props)}
    labels = [data[end + k * vsize + off["label"]] for k in range(nv)]
    check(min(labels) < 128 <= max(labels), "%s: labels do not cover both regions" % ply)
    # colours: positive region (label >= 128) warm (red > blue), negative cool
    warm = sum(1 for k in range(nv) if (data[end + k * vsize + off["red"]] > data[end + k * vsize + off["blue"]]) == (labels[k] >= 128))
    check(warm >= 0.95 * nv, "%s: colours disagree with the regions at %d of %d vertices" % (ply, nv - warm, nv))
    check(os.path.exists(os.path.join(run, i["dir"], "preview.png")), "preview.png missing")
    check(os.path.exists(os.path.join(run, i["dir"], "micro.h5")), "micro.h5 missing")
kinds = [(o["kind"], o["role"]) for o in summ["outputs"]]
meshes = sorted(o["path"].rsplit(".", 1)[1] for o in summ["outputs"] if (o["kind"], o["role"]) == ("mesh", "instance"))
check(meshes == ["glb"] * 3 + ["ply"] * 3 and kinds.count(("h5", "labels")) == 3, "outputs registered: %s" % kinds)
for b in bad: print("  " + b)
sys.exit(1 if bad else 0)
EOF

run_gs 0 inspect q1/instance-0001/micro.h5
expect_rc 0 "inspect instance micro.h5"
for ds in triangle_label vertex_label target_count achieved_count bin_error realized_count triangle_distance; do
  expect_out "$ds" "micro.h5 holds /micro/$ds"
done
# a finished run that never reached a checkpoint leaves none, as in every
# engine (#23 item 7: micro used to write one at the start of every run)
[[ ! -e q1/checkpoint.h5 ]] && ok "a finished run too short for a checkpoint leaves no checkpoint.h5" \
  || bad "q1/checkpoint.h5 left by a run that reached no checkpoint"
GS_STOP_AFTER_UNITS=7 run_gs 0 micro -c "$QUICK" -o qstop --set run.checkpoint_every=1
expect_rc 9 "stopped after 7 units (two rounds of 6)"
run_gs 0 inspect qstop/checkpoint.h5
expect_rc 0 "inspect checkpoint.h5"
expect_out "instance-000002" "checkpoint has a group per instance"

# ---- the realized distribution is measured, not taken from the labels ----
# Without the correction pass the reconstruction's regions miss the target
# (issue 20: L1/n 0.11-0.22 on quick.ini): the measure must say so, and the
# correction must be what brings it under 0.05.
run_gs 1 micro -c "$QUICK" --set micro.correct=no -o qraw
expect_rc 0 "quick.ini without the correction pass"
/usr/bin/python3 - qraw q1 <<'EOF' && ok "measure not fooled by the labels: without correction L1/n > 0.05, with it <= 0.05" || bad "realized measure / correction (see above)"
import json, sys
raw = json.load(open(sys.argv[1] + "/instances.json"))
cor = json.load(open(sys.argv[2] + "/instances.json"))
for a, b in zip(raw, cor):
    print("  instance %d: realized L1/n %.4f without correction (labels' own bin error %.4f), %.4f with"
          % (a["instance"], a["realized_l1"], a["bin_error_share"], b["realized_l1"]))
sys.exit(0 if all(a["realized_l1"] > 0.05 and a["realized_l1"] == b["recon_realized_l1"] for a, b in zip(raw, cor))
         and all(b["realized_l1"] <= 0.05 for b in cor) else 1)
EOF

# The reconstruction's metric (issue 20 item 3): its cones x = a - d(seed, .)
# fill the regions, so the largest |x_i - x_j| / straight line between
# centroids 3-6 units apart (analysis/micro_outline.py) is its metric's
# excess. Hop paths over the dual graph are a honeycomb, >= 2/sqrt(3) = 1.155
# times the straight line off its directions (the hexagonal plateaus of the
# issue; planet.ini 1.59); the ring graph stays near 1.035 on a regular mesh.
# On planet.ini (sphere radius 36.65 units: the chord is within 0.2% of the
# geodesic at 6 units), undisplaced, without the correction pass.
run_gs 1 micro -c "$GS_ROOT/configs/micro/planet.ini" --set micro.correct=no --set micro.pos.scale=0 \
  --set micro.neg.scale=0 -o praw
expect_rc 0 "planet.ini without the correction pass"
ex=$(/usr/bin/python3 "$GS_ROOT/analysis/micro_outline.py" praw/instance-0000 --json 2>&1 |
     /usr/bin/python3 -c 'import json,sys; print("%.3f" % json.load(sys.stdin)["metric_excess"])' 2>&1)
if awk -v x="$ex" 'BEGIN { exit !(x + 0 > 1 && x + 0 < 2 / sqrt(3)) }'; then
  ok "reconstruction's metric isotropic: excess over the straight line $ex < 2/sqrt(3) (dual-graph hops)"
else
  bad "reconstruction's metric excess over the straight line: $ex (dual-graph hops >= 1.155)"
fi

# Round discs where the table asks for them (issue 20 item 3): planet.ini's
# positive table falls linearly to its last bin, the contact distribution of
# n discs of radius r = 12.5 (a disc holds 2 pi (r - k - 1/2) units^2 in bin
# k, n = A[11] / 2 pi = 13.4). With micro.correct_discs the correction pass
# starts from such discs, arranged to fit both tables, and the output's
# islands (measured from mesh.ply's vertex labels alone) stay separate and
# round: at least 3/4 of n islands, none over 1.5 discs' area (two merged
# discs), area-weighted radial cv < 0.04 (a regular hexagon 0.03; an ideal
# disc on this mesh 0.01; started from the reconstruction's regions the
# continents merge: 7 islands, cv 0.235), and coasts as short as circles:
# area-weighted perimeter / 2 pi r within 3% of an ideal disc of each
# island's area drawn on the same mesh (1.09-1.10 here, the staircase of the
# edges; ragged coasts of the greedy rounds from evenly spread discs: 1.08x).
run_gs 1 micro -c "$GS_ROOT/configs/micro/planet.ini" --set micro.pos.scale=0 --set micro.neg.scale=0 -o pdisc
expect_rc 0 "planet.ini (correction pass from discs)"
/usr/bin/python3 - pdisc "$GS_ROOT/analysis" <<'EOF2' && ok "planet.ini: round separate islands as its disc table asks, realized L1/n <= 0.05" || bad "planet.ini islands (see above)"
import json, math, os, subprocess, sys
run, ana = sys.argv[1], sys.argv[2]
inst = json.load(open(os.path.join(run, "instances.json")))[0]
K = inst["bins_per_region"]
tc = inst["target_count"]
area = 4 * math.pi * 36.65 ** 2  # planet.ini: unit sphere, scale_units 36.65
a11 = tc[2 * K - 1] * area / inst["triangles"]  # positive bin K-1 on the signed axis
n = a11 / (2 * math.pi)
disc = math.pi * (K + 0.5) ** 2
out = json.loads(subprocess.check_output([sys.executable, os.path.join(ana, "micro_outline.py"),
                                          os.path.join(run, "instance-0000"), "--json"]))
isl = [r for r in out["discs"] if r["positive"]]
sm = out["summary"]["positive"]
bad = []
if inst["realized_l1"] > 0.05: bad.append("realized L1/n %.4f > 0.05" % inst["realized_l1"])
if inst["unassigned_share"] >= 0.01: bad.append("unassigned %.4f" % inst["unassigned_share"])
if sm["count"] < 0.75 * n: bad.append("%d islands < 3/4 of %.1f discs" % (sm["count"], n))
big = max(r["area"] for r in isl)
if big > 1.5 * disc: bad.append("largest island %.0f units^2 > 1.5 discs (%.0f)" % (big, 1.5 * disc))
if sm["radial_cv"] >= 0.04: bad.append("radial cv %.3f >= 0.04" % sm["radial_cv"])
if sm["perimeter_ratio"] > 1.03 * sm["ideal_ratio"]:
    bad.append("perimeter / 2 pi r %.3f > 1.03 x an ideal disc's on this mesh (%.3f)"
               % (sm["perimeter_ratio"], sm["ideal_ratio"]))
# The engine's own outline measure (src/measure/outline.c, instances.json and
# summary.json) is the same as analysis/micro_outline.py's, from mesh.ply
# alone: equal to 1e-9, and round coasts (<= 1.10, the gallery's bound).
summ = json.load(open(os.path.join(run, "summary.json")))["metrics"]
if not abs(inst["outline_roughness"] - out["roughness"]) <= 1e-9:
    bad.append("engine outline roughness %r != analysis/micro_outline.py's %r" % (inst["outline_roughness"], out["roughness"]))
if not summ["outline_roughness"] == inst["outline_roughness"] <= 1.10:
    bad.append("summary outline_roughness %r (instance %r) not <= 1.10" % (summ["outline_roughness"], inst["outline_roughness"]))
print("planet.ini: %d islands (table: %.1f discs of area %.0f), largest %.0f, radial cv %.3f, perimeter / 2 pi r %.3f "
      "(ideal disc %.3f), L1/n %.4f, outline roughness %.4f (analysis %.4f)"
      % (sm["count"], n, disc, big, sm["radial_cv"], sm["perimeter_ratio"], sm["ideal_ratio"], inst["realized_l1"],
         inst["outline_roughness"], out["roughness"]))
for b in bad: print("  " + b)
sys.exit(1 if bad else 0)
EOF2

# ---- a realizable distribution: measured from a Boolean-model image ----
/usr/bin/python3 - <<'EOF'
import random, struct, zlib
W = H = 160
random.seed(5)
pix = bytearray(W * H)
while sum(1 for p in pix if p) < 0.4 * W * H:
    cx, cy, r = random.uniform(0, W), random.uniform(0, H), random.uniform(4, 9)
    for y in range(int(cy - r) - 1, int(cy + r) + 2):
        for x in range(int(cx - r) - 1, int(cx + r) + 2):
            if (x + 0.5 - cx) ** 2 + (y + 0.5 - cy) ** 2 <= r * r:
                pix[(y % H) * W + (x % W)] = 255
raw = b"".join(b"\0" + bytes(pix[y * W:(y + 1) * W]) for y in range(H))
def chunk(t, d): return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", W, H, 8, 0, 0, 0, 0)) \
    + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")
open("boolean.png", "wb").write(png)
EOF
cat > image.ini <<EOF
[micro]
shape = sphere
scale_units = 14
dist = image
image = boolean.png
image_units_per_pixel = 0.5
instances = 2
EOF
run_gs 2 micro -c image.ini -o img
expect_rc 0 "image-acquired distribution at np=2"
/usr/bin/python3 - img <<'EOF' && ok "Boolean-model image: 0 violations, < 0.5% unassigned, realized L1/n <= 0.05" || bad "Boolean-model image quality"
import json, sys
m = json.load(open(sys.argv[1] + "/summary.json"))["metrics"]
print("  image run: unassigned %.4f%%, bin error share %.4f%%, violations %d, pairs %d"
      % (100 * m["unassigned_share_max"], 100 * m["bin_error_share_max"], m["violations"], m["pairs_checked"]))
print("  image run: realized L1/n %.4f (worst instance %.4f)" % (m["realized_l1"], m["realized_l1_max"]))
sys.exit(0 if m["violations"] == 0 and m["unassigned_share_max"] < 0.005 and m["realized_l1_max"] <= 0.05 else 1)
EOF

# ---- CSV table on two meshes (a mesh list) ----
printf 'bin,pos,neg\n0, 0.14, 0.18\n1,0.085,0.14\n# comment\n2,0.04,0.1\n3,0.005,0.08\n4,0,0.07\n5,0,0.055\n6,0,0.04\n7,0,0.027\n8,0,0.018\n9,0,0.015\n' > t.csv
# spot.obj from the data root (a ${data}/ line) and a built-in example mesh
"$GS_BIN" -q example balls --out balls.obj --size 24 --seed 3 || bad "example balls for the mesh list"
printf '%s\n%s\n' '${data}/meshes/spot.obj' balls.obj > list.txt
cat > csv.ini <<EOF
[micro]
shape = file
mesh_list = list.txt
scale_units = 6
dist = csv
table_csv = t.csv
output_format = both
EOF
run_gs 1 micro -c csv.ini -o csv
expect_rc 0 "CSV table on a mesh list"
[[ -f csv/instance-0000/mesh.obj && -f csv/instance-0001/mesh.ply ]] && ok "both meshes written (OBJ and PLY)" || bad "mesh-list outputs missing"
grep -q '"meshes":2' csv/summary.json && ok "two meshes counted" || bad "summary lacks meshes:2"

# ---- bad inputs ----
printf '[micro]\nshape = file\nmesh = no/such/mesh.obj\n' > b1.ini
run_gs 2 micro -c b1.ini -o b1
expect_rc 3 "missing mesh file"
expect_err "no/such/mesh.obj" "missing mesh names the path"
expect_no_crash "missing mesh"

printf '[micro]\ntable_pos = 0.5, -0.1\ntable_neg = 0.6\n' > b2.ini
run_gs 1 micro -c b2.ini -o b2
expect_rc 2 "negative probability"
expect_err "b2.ini:2: [micro] table_pos" "negative probability names file, line and key"

printf '[micro]\ntable_pos = 0.5, 0.1\ntable_neg = 0.1\n' > b3.ini
run_gs 1 micro -c b3.ini -o b3
expect_rc 2 "table that sums to 0.7"
expect_err "sum to 0.7" "table sum is reported"

printf 'bin,pos,neg\n0,0.5,0.3\n1,-0.2,0.4\n' > neg.csv
printf '[micro]\ndist = csv\ntable_csv = neg.csv\n' > b4.ini
run_gs 2 micro -c b4.ini -o b4
expect_rc 2 "CSV with a negative probability"
expect_err "neg.csv:3: positive probability '-0.2'" "CSV error names file and line"

printf 'bin,pos,neg\n0,0.5,0.3\n2,0.1,0.1\n' > gap.csv
printf '[micro]\ndist = csv\ntable_csv = gap.csv\n' > b5.ini
run_gs 1 micro -c b5.ini -o b5
expect_rc 2 "CSV with a missing bin"
expect_err "expected bin 1" "CSV bin order is checked"

printf '[micro]\ninstance = 3\n' > b6.ini
run_gs 1 micro -c b6.ini -o b6
expect_rc 2 "unknown key"
expect_err "did you mean 'instances'" "unknown key gets a suggestion"

printf '[micro]\ninstances = many\nshape = cube\n' > b7.ini
run_gs 1 micro -c b7.ini -o b7
expect_rc 2 "wrong type and bad choice"
expect_err "instances = many" "wrong type names the key"
expect_err "shape = cube" "bad choice names the key (all problems at once)"

printf '[micro]\ndist = image\nimage = none.png\n' > b8.ini
run_gs 2 micro -c b8.ini -o b8
expect_rc 3 "missing image"
expect_err "none.png" "missing image names the path"

# ---- a table no partition gives is not missed silently ----
# The stop-29 gallery's card 1, drawn per side: 1500 of 3200 triangles in
# negative bin 0 against 211 in positive bin 0, with land 6 units deep.
cat > coast.ini <<EOF
[micro]
scale_units = 7.302126195691006
table_pos = 0.0659375, 0.0625, 0.0553125, 0.0475, 0.0321875, 0.015625, 0.00875
table_neg = 0.46875, 0.14, 0.1034375
EOF
run_gs 1 micro -c coast.ini -o coast
expect_rc 0 "an unrealizable table still gives an output"
expect_err "warning: instance 0: the realized contact distribution misses the target by L1/n" \
  "an unrealizable table is warned about"
expect_err "1500 triangles in negative bin 0 and 211 in positive bin 0" "the warning names the coast bins"
/usr/bin/python3 -c 'import json,sys; sys.exit(0 if json.load(open("coast/instances.json"))[0]["realized_l1"] > 0.05 else 1)' \
  && ok "the warned run's instances.json holds realized L1/n > 0.05" || bad "coast.ini: realized L1/n not above 0.05"

printf '[micro]\nshape = sphere\nmesh = x.obj\n' > b9.ini
run_gs 1 micro -c b9.ini -o b9
expect_rc 2 "mesh given for a built-in shape"
expect_err "micro.shape = sphere" "conflicting keys explained"

finish
