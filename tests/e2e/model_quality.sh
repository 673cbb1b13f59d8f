# End-to-end: model outputs look like their example. Runs the engine with its
# default settings (seed 1, one rank) on the repository's two Merrell lattices
# (DeBroglie's CSV copies of escheresque and parliament) and checks the output
# against figures of the EXAMPLE itself, computed here from lattice.h5 and the
# CSV alone (numpy; nothing from the engine's bookkeeping but cross-checks):
# - resemblance: the share of the output's non-empty 3x3x3 windows found in the
#   example is at least the share one half of the example reaches against the
#   other half (the better of the x and y splits): a piece synthesized from the
#   example resembles it at least as well as an unseen piece of the example;
# - completeness: the share of the example's distinct non-empty 3x3x3 windows
#   met in the output is at least the lower share one half of the example
#   meets of the other's;
# - label mix: labels used >= 0.8 x the example's; label L1 to the example at
#   most 2 x the larger L1 between the example's halves;
# - empty share within 20% of the example's;
# - height profile: mean |fill(z) - example fill(z)| at most half the example's
#   mean fill (the old default hung walls from the fixed empty top: 0.24-0.41);
# - no unsupported (floating) cells where the example has none.
# Broken on purpose: region synthesis replaced by a no-op
# fails labels and completeness (parliament also empty share and profile); resemblance removed fails the
# window share, L1, empty share and profile. About 5 s.
source "$GS_ROOT/tests/e2e/lib.bash"
verdict() { # verdict NAME WHAT OUTPUT: OUTPUT's lines indented, one check from its RESULT line
  echo "$3" | sed "s/^/  $1: /"
  if grep -q "^RESULT pass" <<<"$3"; then ok "$1 $2"; else bad "$1: $(grep '^RESULT' <<<"$3")"; fi
}
M=$DATA/model-synthesis/debroglie-samples-merrell
# same_np2_resume NAME DIR UNITS ARGS...: the model run ARGS at np 2 (DIR-np2), and stopped after
# UNITS regions at np 2 then resumed at np 1 (DIR-stop), give DIR's digest (the np 1 run)
same_np2_resume() {
  local name=$1 dir=$2 units=$3
  shift 3
  run_gs 2 model "$@" -o "$dir-np2"
  expect_rc 0 "$name at np 2"
  GS_STOP_AFTER_UNITS=$units run_gs 2 model "$@" -o "$dir-stop"
  expect_rc 9 "$name: stopped after $units regions at np 2"
  run_gs 0 resume "$dir-stop"
  expect_rc 0 "$name: resumed at np 1"
  local d1
  d1=$(digest_of "$dir")
  [[ $(digest_of "$dir-np2") == "$d1" && $(digest_of "$dir-stop") == "$d1" ]] \
    && ok "$name: digest $d1 at np 1, np 2 and stop + resume" \
    || bad "$name: digests differ (np 2 $(digest_of "$dir-np2"), stop + resume $(digest_of "$dir-stop"), np 1 $d1)"
}

for name in escheresque parliament; do
  cat > $name.ini <<EOF
[model]
example = $M/$name.csv
size = 30x30x10
region = 10x10x0
EOF
  run_gs 0 model -c $name.ini -o $name
  expect_rc 0 "$name 30x30x10 in 10x10 regions, default settings"
  [[ $rc -eq 0 ]] || continue
  /usr/bin/python3 -c 'import sys, matplotlib.image as im; a = im.imread(sys.argv[1]); assert a.shape[:2] == (512, 1028), a.shape; l, r = a[:, :512, :3], a[:, 516:, :3]; assert l.std() > 0.05 and r.std() > 0.05' "$name/preview.png" \
    && ok "$name: preview.png, example | output, 2 x 512 px, both panels drawn" || bad "$name: preview.png missing or blank"
  res=$(/usr/bin/python3 - "$M/$name.csv" "$name" <<'EOF'
import json, os, sys
sys.path.insert(0, os.environ["GS_ROOT"] + "/analysis")
import lattice_measures as lm

ex = lm.read_lattice(sys.argv[1])
out = lm.read_lattice(sys.argv[2] + "/lattice.h5")
m = json.load(open(sys.argv[2] + "/summary.json"))["metrics"]
f, h = lm.figures(ex, out, ks=(3,)), lm.half_figures(ex, ks=(3,))
half_share, half_l1, half_cmp = h["share_3"], h["label_l1"], h["completeness_3"]
r3, cmp3, L1 = f["share_3"], f["completeness_3"], f["label_l1"]
used, ex_used = f["labels_used"], f["labels_example"]
empty, ex_empty = f["empty_share"], f["empty_share_example"]
prof, fe_mean = f["height_fill_mean_abs"], f["height_fill_example_mean"]
chk = lm.Checks()
need = chk.need
need(r3 >= half_share, "non-empty 3x3x3 share %.3f >= example half vs half %.3f" % (r3, half_share))
need(abs(r3 - m["resemblance_3x3x3"]) < 1e-9, "summary.json resemblance_3x3x3 %.3f = independent %.3f" % (m["resemblance_3x3x3"], r3))
need(cmp3 >= half_cmp, "completeness %.3f >= example half vs half (the lower) %.3f" % (cmp3, half_cmp))
need(used >= 0.8 * ex_used, "labels used %d >= 0.8 x example's %d" % (used, ex_used))
need(L1 <= 2 * half_l1, "label L1 %.3f <= %.3f = 2 x example half vs half %.3f" % (L1, 2 * half_l1, half_l1))
need(abs(empty - ex_empty) <= 0.2 * ex_empty, "empty share %.3f within 20%% of example's %.3f" % (empty, ex_empty))
need(prof <= 0.5 * fe_mean, "height profile mean |diff| %.3f <= half the example's mean fill %.3f" % (prof, 0.5 * fe_mean))
need(m["unsupported_share_example"] > 0 or m["unsupported_share"] == 0,
     "unsupported share %.4f where the example has %.4f" % (m["unsupported_share"], m["unsupported_share_example"]))
need(m["violations"] == 0 and m["failed_regions"] == 0, "0 violations, 0 failed regions")
chk.result()
EOF
)
  verdict "$name" "output resembles its example (figures from the example)" "$res"
done

# A terrain nobody tuned for (scripts/gen-lattice.py terrain 3: stone, dirt, grass, water; its
# bottom layer holds stone and dirt): model.fix_z_faces = auto synthesizes the bottom and top
# layers (limited to the labels of the example's own bottom and top layers) instead of fixing
# them to the start column, which held the whole output flat (2 of 4 labels, top layer 1 of
# the example's 5, completeness 0.003). Checks from the example: labels used >= 0.8 x its,
# completeness >= its half vs half (the lower), non-empty 3x3x3 share >= 0.8 x its half vs half,
# top layer within 1 of its; the face layers hold only the example's face labels, also with
# model.resemblance = 0 (then only the face masks keep dirt and grass out of the top layer).
# Broken on purpose: fix_z_faces = true (the old behaviour) fails labels, completeness and top
# layer; the face masks removed fail the resemblance = 0 face check.
/usr/bin/python3 "$GS_ROOT/scripts/gen-lattice.py" terrain 3 terrain3.txt
printf '[model]\nexample = terrain3.txt\nsize = 40x40x8\nregion = 20x20x0\n' > terrain.ini
run_gs 0 model -c terrain.ini -o terrain
expect_rc 0 "terrain 40x40x8 in 20x20 regions, default settings"
expect_err "z faces synthesized" "terrain: the log says the z faces are synthesized"
run_gs 0 model -c terrain.ini -o terrain0 --set model.resemblance=0
expect_rc 0 "terrain, model.resemblance = 0"
res=$(/usr/bin/python3 - terrain3.txt terrain terrain0 <<'EOF'
import json, os, sys
import numpy as np
sys.path.insert(0, os.environ["GS_ROOT"] + "/analysis")
import lattice_measures as lm
ex = lm.read_lattice(sys.argv[1])
out, out0 = (lm.read_lattice(d + "/lattice.h5") for d in sys.argv[2:4])
f, h = lm.figures(ex, out, ks=(3,)), lm.half_figures(ex, ks=(3,))
top = lambda a: max([z for z in range(a.shape[0]) if a[z].any()] or [-1])
chk = lm.Checks()
need = chk.need
need(f["labels_used"] >= 0.8 * f["labels_example"], "labels used %d >= 0.8 x example's %d" % (f["labels_used"], f["labels_example"]))
need(f["completeness_3"] >= h["completeness_3"], "completeness %.3f >= example half vs half %.3f" % (f["completeness_3"], h["completeness_3"]))
need(f["share_3"] >= 0.5, "non-empty 3x3x3 share %.3f >= 0.5 (issue #18 item 4, untuned examples)" % f["share_3"])
need(abs(top(out) - top(ex)) <= 1, "top layer %d within 1 of example's %d" % (top(out), top(ex)))
for name, o in (("default", out), ("resemblance 0", out0)):
    for face, zo, ze in (("bottom", 0, 0), ("top", -1, -1)):
        extra = set(np.unique(o[zo]).tolist()) - set(np.unique(ex[ze]).tolist())
        need(not extra, "%s: %s layer holds only the example's %s labels (extra: %s)" % (name, face, face, sorted(extra)))
chk.result()
EOF
)
verdict terrain "output has the example's relief (figures from the example)" "$res"
# the synthesized faces are decided from the config and the example alone: the same digest at
# np 2 and after a stop at np 2 resumed at np 1
same_np2_resume terrain terrain 2 -c terrain.ini

# castle.ini (Merrell's castle.txt, fetched): its features near its own faces (labels every one
# of whose example cells lies within 2 cells of the example's x/y faces: the bushes) keep their
# share, and the output meets the example's windows. model.resemblance_outside = background
# scores a neighbourhood cell past the example's faces as a match only against the example's
# face background of that layer. Checks from the example, seeds 1 and 2: near-face labels'
# share of all cells within [0.5, 2] x the example's; completeness >= the example's half vs
# half (the lower); non-empty 3x3x3 share >= the better half vs half; labels used >= 0.8 x;
# label L1 at most 1.05 x what the example's layers copied to the output's height score
# (castle.txt: 0.146; model.frequency_weight).
# Broken on purpose: resemblance_outside = half (the previous castle.ini) fails the first check;
# frequency_weight = 0 fails the label L1 (0.180, 0.184 > 0.153).
CASTLE=model-synthesis/merrell42-model-synthesis/samples/castle.txt
if need_data "castle: near-face features (bushes) and windows" $CASTLE; then
  for s in 1 2; do
    run_gs 0 model -c "$GS_ROOT/configs/model/castle.ini" --set run.seed=$s --set model.mesh=none -o castle$s
    expect_rc 0 "castle.ini seed $s"
    res=$(/usr/bin/python3 - "$DATA/$CASTLE" castle$s <<'EOF'
import json, os, sys
import numpy as np
sys.path.insert(0, os.environ["GS_ROOT"] + "/analysis")
import lattice_measures as lm
ex = lm.read_lattice(sys.argv[1])
out = lm.read_lattice(sys.argv[2] + "/lattice.h5")
m = json.load(open(sys.argv[2] + "/summary.json"))["metrics"]
labels = lm.near_face_labels(ex)
se, so = np.isin(ex, labels).mean(), np.isin(out, labels).mean()
f, h = lm.figures(ex, out, ks=(3,)), lm.half_figures(ex, ks=(3,))
chk = lm.Checks()
need = chk.need
need(len(labels) > 0, "the example has near-face labels: %s (share %.4f)" % (labels, se))
need(0.5 * se <= so <= 2 * se, "near-face labels' share %.4f within [0.5, 2] x the example's %.4f" % (so, se))
need(f["completeness_3"] >= h["completeness_3"], "completeness %.3f >= example half vs half %.3f" % (f["completeness_3"], h["completeness_3"]))
need(f["share_3"] >= h["share_3"], "non-empty 3x3x3 share %.3f >= example half vs half %.3f" % (f["share_3"], h["share_3"]))
need(f["labels_used"] >= 0.8 * f["labels_example"], "labels used %d >= 0.8 x example's %d" % (f["labels_used"], f["labels_example"]))
need(f["label_l1"] <= 1.05 * f["label_l1_stacked_example"], "label L1 %.3f <= 1.05 x the example's layers stacked to the output's height %.3f" % (f["label_l1"], f["label_l1_stacked_example"]))
need(m["violations"] == 0 and m["failed_regions"] == 0, "0 violations, 0 failed regions")
chk.result()
EOF
)
    verdict castle$s "keeps the example's near-face features and windows" "$res"
  done
fi

# castle-10x.ini (castle.txt at 126x126x10 in 16x16 regions, no overlap; #18 "a field of towers"): the
# keep is what rises above the walls. Keep layers, from the example alone: its non-empty
# layers filled less than half as much as its fullest partly filled layer (castle.txt: z = 5, 6,
# fill 0.062 / 0.031; the walls fill 0.25-0.33). Checks from lattice.h5 and the example, seeds 1
# and 2: each keep layer's fill within [0.5, 2] x the example's; non-empty 3x3x3 share at least
# the author's lower figure for castle (issue #18: 0.51).
# Broken on purpose: castle-10x.ini's settings before (frequency_weight 0, resemblance_slack 0)
# fail the keep layers (seed 1: 0.016 / 0.007, seed 2: 0.012 / 0.005 against 0.062 / 0.031).
# Castles on open ground (model19): the share of clear columns (open, with their 8 column
# neighbours open: room between structures) within [0.8, 1.25] x the example's (castle.txt
# 0.238) and the largest structure (6-connected non-empty cells above the ground layer) at most
# 4 x the example's (castle.txt 120 cells; analysis/lattice_measures.py layout_figures), label
# L1 <= 0.16 (the author's castle figure). Broken on purpose: model.overlap = -1 (half-region
# overlap, castle-10x.ini's layout before, region 16 or 20) fails both layout checks (region 20:
# seed 1 clear 0.168, largest 12.3 x; seed 2 0.173, 20.0 x). Keeps inside rings: the share of
# structure cells in nested structures (none of whose columns meets the outside ground) at least
# half the example's (castle.txt 0.444: its keep). Broken on purpose: order = entropy with
# resemblance_slack = 1 (castle-10x.ini before) fails it (seeds 1, 2: 0.006, 0.006).
# No region grid (model20): the share of neighbouring structure column pairs across the lines
# x, y = k * 16 (the region edge) at least half that across all other lines (1 = structures
# ignore the grid; summary.json region_grid_crossing_ratio equal to lattice_measures.py's), and
# straight open streets through the whole output (lattice_measures.py straight_streets) at most
# a quarter of the region lines. Broken on purpose: model.region_jitter = 0 (the regular grid,
# castle-10x.ini before: one castle per region) fails both (seeds 1, 2: ratio 0.08, 0.09;
# 11 + 12, 12 + 12 streets); staggered rows with straight row lines (tried) fail the streets check (seeds 1-3: 11-14).
# These see the nominal lines only: with region_jitter the real region sides leave them, so they
# passed while castle-10x.ini's castles stayed inside their regions (across the first sweep's real
# sides / elsewhere 0.00-0.01, model29). Castles across the real sides (model34): castle-10x.ini's
# later sweeps (model.open_blocks with open_blocks_largest) rebuild regions grown over the castles
# they meet, each structure met by one region of a sweep and a rebuild kept only if the structures it
# makes or joins hold at most 2.75x the example's largest. Check, seeds 1 and 2: region_lines_crossing
# (as the tile's below) >= 0.25; the largest structure check above bounds the chains. Broken on
# purpose: model.open_blocks = 0 with model.passes = 1 (castle-10x.ini before) fails it (seeds 1, 2:
# 0.01, 0.00); open_blocks = 0 with the four sweeps (the engine's plain sweeps, every region) crosses
# (0.83, 0.85) but fails the largest structure (22.7x, 9.6x), clear and nested shares; the keep test
# never rejecting (engine_regions.c open_block_too_large) fails the largest structure (9.3x, 4.6x).
# Stop after the first sweep at np 2, resume at np 1: the digest of the run without a stop.
# castle-10x-tile.ini (castle-10x with castle.txt taken as a tile, model.resemblance_outside = wrap;
# #18, model23): castle.txt's open ground and every bush lie within 2 cells of its x/y faces, so
# scored as mismatches past the faces (castle-10x.ini) their neighbourhoods lose to the interior
# ones, a wall starts after two open columns and the bushes vanish. Checks from the example, seeds
# 1 and 2: its wall layers (partly filled, at least half its fullest partly filled layer: castle.txt
# z = 2-4) each filled within 15% of the example's; near-face labels (the bushes, as castle.ini's
# check) within [0.5, 2] x the example's share; keep layers within [0.5, 2] x; non-empty 3x3x3
# share >= 0.51 (the author's lower castle figure); label L1 at most 1.25 x the example's layers
# stacked to the output's height; the log names the tile; np 2 = np 1 digest (seed 1).
# Broken on purpose: the tile removed in resemble.c (gs_model_resem_build_wrap a plain build, i.e.
# castle-10x.ini's mismatch past the faces) fails the wall layers (seeds 1, 2: z = 3 0.346, 0.345
# against 0.25) and the near-face labels (0.0029, 0.0023 against 0.0107); the author's corner
# start column (a bush layer in the regions not yet synthesized) fails the walls (z = 3 0.198,
# 0.209), the label L1 (0.192, 0.183 > 0.1826) and seed 1's keeps (z = 5 0.028).
# Castles across region lines (model29): with overlap 0 each region closes its castles inside it,
# so none crosses a region side; castle-10x-tile.ini's later sweeps (model.open_blocks) rebuild
# regions grown over the castles they meet. Check, seeds 1 and 2: of the neighbouring column pairs
# across the first sweep's region sides (schedule.jsonl) and of all others, the shares that are
# both structure columns: ratio >= 0.25 (1 = the regions leave no trace; castle-10x.ini 0.00-0.01);
# stop after the first sweep at np 2, resume at np 1: the digest of the run without a stop.
# Broken on purpose: model.open_blocks = 0 with one sweep (castle-10x-tile.ini before) fails it
# (seeds 1, 2: ratio 0.10, 0.08). A rebuilt region is kept only if its label mix per layer is no
# further from the example's: label L1 <= 0.16 (the author's castle figure); broken on purpose (that
# test removed in engine_regions.c open_block_worse) it fails (seeds 1, 2: 0.162, 0.168).
for cfg in castle-10x castle-10x-tile; do
  need_config "$cfg: keeps (and for the tile walls and bushes) at the example's rates" "$GS_ROOT/configs/model/$cfg.ini" || continue
  tag=${cfg#castle-10x}; tag=${tag:+t}
  for s in 1 2; do
    run_gs 0 model -c "$GS_ROOT/configs/model/$cfg.ini" --set run.seed=$s --set model.mesh=none --set model.schedule_log=true -o castle10x$tag$s
    expect_rc 0 "$cfg.ini seed $s"
    [[ $rc -eq 0 ]] || continue
    [[ $cfg == castle-10x ]] || expect_err "the example taken as a tile along x and y" "$cfg seed $s: the log says the example is taken as a tile"
    res=$(/usr/bin/python3 - "$DATA/$CASTLE" castle10x$tag$s $cfg <<'EOF'
import json, os, sys
import numpy as np
sys.path.insert(0, os.environ["GS_ROOT"] + "/analysis")
import lattice_measures as lm
ex = lm.read_lattice(sys.argv[1])
out = lm.read_lattice(sys.argv[2] + "/lattice.h5")
m = json.load(open(sys.argv[2] + "/summary.json"))["metrics"]
(fe, walls, keep), fo = lm.fill_classes(ex, out.shape[0]), lm.fill(out, out.shape[0])
chk = lm.Checks()
need = chk.need
need(len(keep) > 0, "the example has keep layers (fill below half its fullest partly filled layer %.3f): %s" % (max(fe[walls]), keep))
for z in keep:
    need(0.5 * fe[z] <= fo[z] <= 2 * fe[z], "keep layer z = %d: fill %.4f within [0.5, 2] x the example's %.4f" % (z, fo[z], fe[z]))
need(lm.share(ex, out, 3) >= 0.51, "non-empty 3x3x3 share %.3f >= 0.51 (the author's lower castle figure, issue #18)" % lm.share(ex, out, 3))
need(m["violations"] == 0 and m["failed_regions"] == 0, "0 violations, 0 failed regions")
if sys.argv[3] == "castle-10x-tile":
    labels = lm.near_face_labels(ex)
    se, so = np.isin(ex, labels).mean(), np.isin(out, labels).mean()
    f = lm.figures(ex, out, ks=(3,))
    need(len(walls) > 0, "the example has wall layers %s" % walls)
    for z in walls:
        need(abs(fo[z] - fe[z]) <= 0.15 * fe[z], "wall layer z = %d: fill %.4f within 15%% of the example's %.4f" % (z, fo[z], fe[z]))
    need(len(labels) > 0 and 0.5 * se <= so <= 2 * se, "near-face labels %s (the bushes): share %.4f within [0.5, 2] x the example's %.4f" % (labels, so, se))
    need(f["label_l1"] <= 1.25 * f["label_l1_stacked_example"], "label L1 %.3f <= 1.25 x the example's layers stacked to the output's height %.3f" % (f["label_l1"], f["label_l1_stacked_example"]))
    need(f["label_l1"] <= 0.16, "label L1 %.3f <= 0.16 (the author's castle figure, issue #18)" % f["label_l1"])
    # castles across the first sweep's region lines (model29): model.open_blocks' later sweeps
    rl = lm.region_lines_crossing(out, lm.ground_layer(ex), lm.plan_boxes(sys.argv[2] + "/schedule.jsonl", 0))
    need(rl["region_lines_crossing_ratio"] >= 0.25, "structures across the first sweep's region sides %.3f >= 0.25 x across other lines %.3f (ratio %.2f; 1 = no region lines, castle-10x.ini 0.00-0.01)" % (rl["region_lines_crossing"], rl["region_lines_crossing_other"], rl["region_lines_crossing_ratio"]))
else:
    # layout above the ground (#18, model19): castles on open ground, not a labyrinth of walls
    lf = lm.layout_figures(ex, out)
    rc = lf["open_ground_clear_share"] / lf["open_ground_clear_share_example"]
    need(0.8 <= rc <= 1.25, "open ground with room (clear columns) %.3f within [0.8, 1.25] x the example's %.3f" % (lf["open_ground_clear_share"], lf["open_ground_clear_share_example"]))
    need(lf["structure_max_ratio"] <= 4, "largest structure %d cells <= 4 x the example's %d" % (lf["structure_max"], lf["structure_max_example"]))
    need(lm.label_l1(ex, out) <= 0.16, "label L1 %.3f <= 0.16 (the author's castle figure, issue #18)" % lm.label_l1(ex, out))
    need(lf["structure_nested_share"] >= 0.5 * lf["structure_nested_share_example"], "structure cells in nested structures (keeps inside rings) %.3f >= half the example's %.3f" % (lf["structure_nested_share"], lf["structure_nested_share_example"]))
    # no region grid (model20): structures cross the lines x, y = k * 16 (model.region) about as
    # often as any other line, and no straight open street crosses the output
    per = (m["region_grid_period_x"], m["region_grid_period_y"])
    g = lm.grid_crossing(out, lf["layout_ground_layer"], per)
    need(per == (16, 16) and all(abs(g[k] - m[k]) < 1e-12 for k in g), "summary.json's region_grid_* = analysis/lattice_measures.py's (%s, period %s)" % (g, per))
    need(g["region_grid_crossing_ratio"] >= 0.5, "structures across the region grid's lines %.3f >= 0.5 x across other lines %.3f (ratio %.2f; 1 = no grid)" % (g["region_grid_crossing"], g["region_grid_crossing_other"], g["region_grid_crossing_ratio"]))
    sx, sy = lm.straight_streets(out, lf["layout_ground_layer"])
    lines = (out.shape[2] - 1) // per[0] + (out.shape[1] - 1) // per[1]
    need(sx + sy <= lines // 4, "straight open streets across the output %d + %d <= a quarter of the %d region lines" % (sx, sy, lines))
    # castles across the first sweep's real region sides (model34)
    rl = lm.region_lines_crossing(out, lf["layout_ground_layer"], lm.plan_boxes(sys.argv[2] + "/schedule.jsonl", 0))
    need(rl["region_lines_crossing_ratio"] >= 0.25, "structures across the first sweep's region sides %.3f >= 0.25 x across other lines %.3f (ratio %.2f; 1 = no region lines, one sweep 0.00-0.01)" % (rl["region_lines_crossing"], rl["region_lines_crossing_other"], rl["region_lines_crossing_ratio"]))
chk.result()
EOF
)
    verdict castle10x$tag$s "keeps (the layers above the walls) at the example's rate${tag:+, walls and bushes too}" "$res"
  done
done
if [[ -f castle10x1/summary.json ]]; then
  # castle-10x's later sweeps (model.open_blocks_largest: claims, keep test, rounds of tries) are
  # decided from the config and the lattice a sweep starts from: np 2 = np 1, and a stop after the
  # first sweep at np 2 resumed at np 1 gives the run without a stop
  same_np2_resume castle-10x castle10x1 "$(grep -c '"pass":0' castle10x1/schedule.jsonl)" \
    -c "$GS_ROOT/configs/model/castle-10x.ini" --set run.seed=1 --set model.mesh=none --set model.schedule_log=true
fi
if [[ -f castle10xt1/summary.json ]]; then
  run_gs 2 model -c "$GS_ROOT/configs/model/castle-10x-tile.ini" --set run.seed=1 --set model.mesh=none --set model.schedule_log=true -o castle10xt1np2
  expect_rc 0 "castle-10x-tile.ini seed 1 at np 2"
  [[ $(digest_of castle10xt1np2) == "$(digest_of castle10xt1)" ]] \
    && ok "castle-10x-tile: digest $(digest_of castle10xt1) at np 1 and np 2" || bad "castle-10x-tile: digests differ between np 1 and np 2"
  # the second sweep's plan is made from the lattice the sweep starts from: a stop at the end of
  # the first sweep (np 2), resumed at np 1, makes it again from the checkpoint's lattice
  units=$(grep -c '"pass":0' castle10xt1/schedule.jsonl)
  GS_STOP_AFTER_UNITS=$units run_gs 2 model -c "$GS_ROOT/configs/model/castle-10x-tile.ini" --set run.seed=1 --set model.mesh=none --set model.schedule_log=true -o castle10xt1stop
  expect_rc 9 "castle-10x-tile.ini seed 1: stopped after the first sweep's $units regions at np 2"
  run_gs 0 resume castle10xt1stop
  expect_rc 0 "castle-10x-tile.ini seed 1: resumed at np 1"
  [[ $(digest_of castle10xt1stop) == "$(digest_of castle10xt1)" ]] \
    && ok "castle-10x-tile: digest $(digest_of castle10xt1) after stop + resume" || bad "castle-10x-tile: stop + resume digest $(digest_of castle10xt1stop) != $(digest_of castle10xt1)"
  # a later sweep's rebuild is optional: a region gives up after 4 tries and keeps its content
  # (seed 32: a region of the last sweep took 12 tries before; broken on purpose, that limit
  # removed in engine_regions.c, this fails)
  run_gs 0 model -c "$GS_ROOT/configs/model/castle-10x-tile.ini" --set run.seed=32 --set model.mesh=none --set model.schedule_log=true -o castle10xt32
  expect_rc 0 "castle-10x-tile.ini seed 32"
  tries=$(/usr/bin/python3 -c 'import json,sys;print(max(json.loads(l)["attempts"] for l in open(sys.argv[1])))' castle10xt32/schedule.jsonl)
  [[ $tries -le 4 ]] && ok "castle-10x-tile seed 32: at most $tries tries per region" || bad "castle-10x-tile seed 32: a region took $tries tries (> 4)"
fi
# A village nobody tuned for (scripts/gen-lattice.py village 5: houses, roofs, trees; every
# non-empty cell stands on the ground), 40x40x8 in 20x20 regions, default settings: no floating
# cell where the example has none (the repair after the passes, engine_regions.c repair_pieces),
# computed from lattice.h5 and the example (analysis/lattice_measures.py unsupported_share), and
# the issue's non-empty 3x3x3 share >= 0.5 for untuned examples. Broken on purpose: the repair
# a no-op fails the first check (0.019 of the non-empty cells float).
/usr/bin/python3 "$GS_ROOT/scripts/gen-lattice.py" village 5 village5.txt
printf '[model]\nexample = village5.txt\nsize = 40x40x8\nregion = 20x20x0\nmesh = none\n' >village5.ini
run_gs 0 model -c village5.ini -o village5
expect_rc 0 "village 5, 40x40x8 in 20x20 regions, default settings"
if [[ $rc -eq 0 ]]; then
  res=$(/usr/bin/python3 - village5.txt village5 <<'EOF'
import json, os, sys
sys.path.insert(0, os.environ["GS_ROOT"] + "/analysis")
import lattice_measures as lm
ex = lm.read_lattice(sys.argv[1])
out = lm.read_lattice(sys.argv[2] + "/lattice.h5")
m = json.load(open(sys.argv[2] + "/summary.json"))["metrics"]
f = lm.figures(ex, out, ks=(3,))
chk = lm.Checks()
need = chk.need
need(f["unsupported_share_example"] == 0 and f["unsupported_share"] == 0, "floating share %.4f where the example's is %.4f" % (f["unsupported_share"], f["unsupported_share_example"]))
need(f["share_3"] >= 0.5, "non-empty 3x3x3 share %.3f >= 0.5 (issue #18 item 4, untuned examples)" % f["share_3"])
need(m["violations"] == 0 and m["failed_regions"] == 0, "0 violations, 0 failed regions")
# the yards (enclosed empty cells of the layer above the ground) of summary.json are the files'
e = lm.enclosure_figures(ex, out)
need(e["enclosed_layer"] == 1 and all(abs(e[k] - m[k]) < 1e-12 for k in e),
     "summary.json's enclosed_* = analysis/lattice_measures.py's (%s)" % e)
# the layout above the ground (open columns, structures) of summary.json is the files' too
lf = lm.layout_figures(ex, out)
need(lf.get("layout_ground_layer") == 1 and all(abs(lf[k] - m[k]) < 1e-12 for k in lf),
     "summary.json's layout figures = analysis/lattice_measures.py's (%s)" % lf)
chk.result()
EOF
)
  verdict village5 "stands on the ground like its example" "$res"
fi

# Examples nobody tuned for whose z faces are synthesized (their bottom layer holds several
# labels), default settings (model.order = auto: entropy_columns, ties to the cells nearest a
# region's decided shell, then to the lowest layer): scripts/gen-lattice.py village 7 and
# fortress 1, 40x40x8 in 20x20 regions, the issue's non-empty 3x3x3 share >= 0.5 (item 4,
# untuned examples) with the top layer within 1 of the example's, from lattice.h5 and the
# example. Broken on purpose: layer_ties (solver.c) a no-op, i.e. random ties as with
# model.order = entropy, fails both (village 7 0.408: roof sheets over walls that never close;
# fortress 1 0.485: towers scattered). Terrain 89, 92 and fortress 120: with the layer first
# (entropy_layers, the order before; solver.c layer_ties' key with columns = 0) a region's
# ground layer was decided before anything above it and each layer up came out narrower than
# the example's: terrain 89 and 92 end at top layer 3 (examples' 5), fortress 120's share is
# 0.495 (towers and wall pieces scattered over the yard); broken on purpose that way, all three
# fail. With synthesized z faces model.resemblance_outside = auto is half a match past the
# example's faces, model.frequency_weight = auto is 2 and model.start_column_from = auto the
# commonest column of the example's x/y faces (terrain 7 and 44: their corner column is a hill;
# configs/model/DEFAULTS.md). Under entropy_layers each was what kept a top layer here (broken
# on purpose then: mismatch and weight 0 failed terrain 4, top layer 3 of 5; mismatch alone
# fortress 1, 0.488; weight 0 terrain 15, top 3 of 5; start corner terrain 7 and 44, top 2 and
# 3 of 5); under entropy_columns these breaks no longer fail the checks below (terrain 4 top 5,
# fortress 1 0.509, terrain 15 top 5, terrain 7 top 5 with label L1 0.205 against 0.012,
# terrain 44 top 4, L1 0.175 against 0.040): the examples stay as checks of the defaults.
for ex in village:7 fortress:1 terrain:4 terrain:15 terrain:7 terrain:44 terrain:89 terrain:92 fortress:120; do
  kind=${ex%%:*} s=${ex##*:}
  /usr/bin/python3 "$GS_ROOT/scripts/gen-lattice.py" $kind $s $kind$s.txt
  printf '[model]\nexample = %s\nsize = 40x40x8\nregion = 20x20x0\nmesh = none\n' $kind$s.txt >$kind$s.ini
  run_gs 0 model -c $kind$s.ini -o $kind$s
  expect_rc 0 "$kind $s, 40x40x8 in 20x20 regions, default settings"
  [[ $rc -eq 0 ]] || continue
  expect_err "cell order: entropy_columns" "$kind $s: the log names the cell order model.order = auto chose"
  expect_err "z faces synthesized: resemblance outside the example's faces half (model.resemblance_outside = auto), frequency weight 2 (model.frequency_weight = auto)" "$kind $s: the log names the settings auto chose"
  expect_err "preferring the example's commonest column on its x/y faces" "$kind $s: the log names the start column model.start_column_from = auto chose"
  res=$(/usr/bin/python3 - $kind$s.txt $kind$s <<'EOF'
import os, sys
sys.path.insert(0, os.environ["GS_ROOT"] + "/analysis")
import lattice_measures as lm
lm.untuned_checks(sys.argv[1], sys.argv[2])
EOF
)
  verdict $kind$s "resembles its example" "$res"
done
finish
