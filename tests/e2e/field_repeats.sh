# End-to-end: large-scale repetition of a height-field run (#19 item 2, "the
# same mountain twice"), configs/field/terrain.ini at full size (64^2 ->
# 128x128x16, a few seconds a run):
# - summary.json's repeat_* (src/measure/repeat.c, from the output's and the
#   example's levels alone) equal analysis/field_repeats.py's from field.h5;
# - the measure rates a 2x2 tiling of the example as repeating: two places
#   alike to NCC 1 (the example's most alike two: repeat_ncc_src) and one
#   example feature recurring at least 4 times (the example's own figure: 1);
# - the measure flags the synthesis without field.repeat_span and
#   field.repeat_pairs on seeds 4 and 12 (two places above the example's most
#   alike two: 0.997 and 1.000, seed 12 repeating 25% of its height map 64
#   samples on along x), and terrain.ini's exclusions (src/field/synth.c
#   repeat_span_exclusions) lower it there by more than 0.02; on seed 12 to
#   within 1.15 times the example's (0.889; 0.952 with the span counting only
#   the blocks below, field22's);
# - field.repeat_pairs (field24; no two neighbouring source blocks recur side
#   by side) on seeds 3 and 6: without it two places are more alike than 1.15
#   times the example's most alike two (0.920, 0.943; the brief's 10% is not
#   met on most seeds; within 1.15 times: 10 of seeds 1-12), with it
#   within 1.15 times (0.868, 0.856), lowered by more than 0.02 (these two
#   runs with field.repeat_free 0.5, the share field24 had);
#   Not checked: the example's own figure as a bound on repeat_ncc_out; a
#   maximum over pairs, it grows with the area: non-repeating random relief
#   of the example's spectrum and heights (analysis/field_repeats.py
#   --surrogates 30) scores 0.81 mean at 64^2 and 0.89 (0.85-0.95) at
#   128^2, the example 0.80, terrain.ini seeds 1-18 0.899-0.918 mean;
# - field.repeat_free 0.3 (field28; the exclusions of repeat_span and
#   repeat_pairs may take 70% of the source, not 50%) on seed 2: within 10%
#   of the example's figure (0.838), with half the source free not (0.928);
# - the equal-area figure (field28; repeat_ncc_out_area: the median over the
#   output's 9 example-sized crops of the most alike two places in each)
#   within 10% of the example's repeat_ncc_src on every run with the shipped
#   settings (seeds 3-6, 12: 0.81-0.84; seeds 1-6, 19-30 0.785-0.849, the
#   random relief 0.79-0.84 at 128^2). It is robust, not sensitive: with
#   every exclusion off (copy_limit, repeat_*) seeds 4, 5, 12 score 0.82-0.87
#   (the repeats lie in one or two crops, or farther apart than a crop); the
#   repeats are left to repeat_ncc_out's on/off checks below.
# Broken on purpose (watched): the crops ignored (src/measure/repeat.c
# area_figure measuring the whole output): the equal-area figure becomes
# repeat_ncc_out, seeds 4, 5, 12 fail the bound (0.923, 0.912, 0.889), seeds 3
# and 6 pass (0.868, 0.856), and the comparison with the analysis fails
# (4 checks; unit/test_measure fails too) (field28). repeat_free ignored
# (try_box keeping half the source free): seed 2 scores 0.928 both ways, 2
# checks fail (field28). repeat_span_exclusions returning ne at once
# (the span ignored): seeds 4 and 12 score as without it, both fail
# (field22). The pairs loop skipped (field24): seeds 3 and 6 score as without
# it and fail (4 checks); the span counting only the blocks below (field22's
# loops, d from 0): seed 12 with the exclusions 0.952, fails (and seed 3
# without pairs 0.917, not flagged).
source "$GS_ROOT/tests/e2e/lib.bash"
T=$GS_ROOT/configs/field/terrain.ini
need_config "terrain.ini" "$T" || finish
FAST=(--set output.geometry=none --set output.vdb=no --set output.preview=no)
BASE=()
m() { /usr/bin/python3 -c 'import json,sys;print(json.load(open(sys.argv[1]+"/summary.json"))["metrics"][sys.argv[2]])' "$1" "$2"; }
le() { /usr/bin/python3 -c "import sys; sys.exit(0 if $1 <= $2 else 1)"; }

# area_within WHAT AREA SRC: the equal-area figure (repeat_ncc_out_area, the
# median over the output's example-sized crops) within 10% of the example's
# own figure (one example-sized sample each)
area_within() {
  le "$2" "1.10 * $3" && ok "$1: equal-area repetition $2 within 10% of the example's $3" ||
    bad "$1: equal-area repetition $2 above 1.10 times the example's $3"
}

run_gs 0 field -c "$T" -o t5 --set run.seed=5 "${FAST[@]}"
expect_rc 0 "terrain.ini seed 5"
area_within "seed 5" "$(m t5 repeat_ncc_out_area)" "$(m t5 repeat_ncc_src)"
py=$(/usr/bin/python3 "$GS_ROOT/analysis/field_repeats.py" t5)
echo "analysis: $py"
/usr/bin/python3 - t5 "$py" <<'EOF' && ok "repeat_* of summary.json = analysis/field_repeats.py" || bad "repeat_* differ from analysis/field_repeats.py"
import json, sys
m = json.load(open(sys.argv[1] + "/summary.json"))["metrics"]
p = json.loads(sys.argv[2])
print({k: m["repeat_" + k] for k in ("window", "relief", "ncc_src", "ncc_out", "ncc_out_area",
                                     "ncc_out_area_max", "crops", "recur_out")})
assert m["repeat_window"] == p["window"] and m["repeat_recur_out"] == p["recur_out"]
assert m["repeat_crops"] == p["crops"] == 9
for k in ("relief", "ncc_src", "ncc_out", "ncc_out_area", "ncc_out_area_max"):
    assert abs(m["repeat_" + k] - p[k]) <= 1e-9, k
EOF
tile=$(/usr/bin/python3 "$GS_ROOT/analysis/field_repeats.py" t5 --tile)
echo "2x2 tiling of the example: $tile"
/usr/bin/python3 -c "
import json, sys; t = json.loads(sys.argv[1])
sys.exit(0 if t['ncc_out'] >= 0.999 and t['ncc_out'] > t['ncc_src'] and t['recur_out'] >= 4 else 1)" "$tile" &&
  ok "a tiling of the example rated as repeating" || bad "a tiling of the example not flagged: $tile"

# on_off NAME SEED F KEY=VALUE...: terrain.ini seed SEED as shipped (NAME on;
# plus the --set options in BASE) and with the settings given (NAME off). Without it two places are more
# alike than F times the example's most alike two, and it lowers that by more
# than 0.02; with it (F > 1) they are within F times.
on_off() {
  local name=$1 seed=$2 f=$3 off=() a b s
  shift 3
  for kv in "$@"; do off+=(--set "$kv"); done
  run_gs 0 field -c "$T" -o "on-$name-$seed" --set run.seed=$seed "${FAST[@]}" "${BASE[@]}"
  expect_rc 0 "terrain.ini seed $seed ${BASE[*]}"
  run_gs 0 field -c "$T" -o "off-$name-$seed" --set run.seed=$seed "${FAST[@]}" "${BASE[@]}" "${off[@]}"
  expect_rc 0 "terrain.ini seed $seed, $*"
  a=$(m "on-$name-$seed" repeat_ncc_out) b=$(m "off-$name-$seed" repeat_ncc_out)
  s=$(m "on-$name-$seed" repeat_ncc_src) e=$(m "on-$name-$seed" repeat_ncc_out_area)
  echo "seed $seed: repeat_ncc_out $a with $name, $b with $* (the example's $s); equal-area $e"
  area_within "seed $seed" "$e" "$s"
  if [[ $f != 1 ]]; then
    le "$a" "$f * $s" && ok "seed $seed: with $name $a within $f times the example's $s" ||
      bad "seed $seed: with $name $a above $f times the example's $s"
  fi
  le "$b" "$f * $s" && bad "seed $seed without $name not flagged: $b ($f times the example's $s)" ||
    ok "seed $seed without $name flagged: $b above $f times the example's $s"
  /usr/bin/python3 -c "import sys; sys.exit(0 if $a < $b - 0.02 else 1)" &&
    ok "seed $seed: $name lowers the repetition $b -> $a" ||
    bad "seed $seed: $name does not lower the repetition ($b -> $a)"
}
on_off repeat_span 4 1 field.repeat_span=0 field.repeat_pairs=0
on_off repeat_span 12 1.15 field.repeat_span=0 field.repeat_pairs=0
# repeat_pairs as field24 showed it, with half the source free (with 0.3 the
# span's farther rings take its part on seed 3: 0.880 with, 0.893 without)
BASE=(--set field.repeat_free=0.5)
for seed in 3 6; do
  on_off repeat_pairs $seed 1.15 field.repeat_pairs=0
done
BASE=()
on_off repeat_free 2 1.10 field.repeat_free=0.5

# The height distribution (summary.json's height_*, src/measure/heights.c;
# analysis/field_heights.py the same from field.h5) of the runs above with
# the shipped settings (seeds 5, 4, 12, 2): the example's highest ground (at
# or above its 95th percentile, 0.050 of the example) at least half as common
# in the outputs, pooled (0.026, 0.035, 0.049, 0.018: mean 0.032; seeds 1-6
# 0.030, fresh 31-42 0.028). A guard, not the target: the outputs hold it
# about 0.6 times as often as the example, less the stronger the exclusions
# (field32: repeat_span 0, 3, 4, 5, 8: seeds 1-6 mean 0.052, 0.044, 0.037,
# 0.031, 0.030; at or above the 90th 0.107, 0.093, 0.083, 0.074, 0.068 of the
# example's 0.100). Broken on purpose (watched): field.repeat_span=16 and
# field.repeat_reach=7 in FAST: seeds 5, 4, 12, 2 0.028, 0.012, 0.017, 0.010,
# pooled 0.017, fails (the other checks pass).
py=$(/usr/bin/python3 "$GS_ROOT/analysis/field_heights.py" t5)
echo "heights, analysis: $py"
/usr/bin/python3 - t5 "$py" <<'EOF' && ok "height_* of summary.json = analysis/field_heights.py" || bad "height_* differ from analysis/field_heights.py"
import json, sys
m = json.load(open(sys.argv[1] + "/summary.json"))["metrics"]
p = json.loads(sys.argv[2])
for k in ("below_p10_out", "below_p10_src", "above_p90_out", "above_p90_src", "above_p95_out",
          "above_p95_src", "above_p99_out", "above_p99_src", "ks"):
    print(k, m["height_" + k], p[k])
    assert abs(m["height_" + k] - p[k]) <= 1e-12, k
EOF
/usr/bin/python3 - t5 on-repeat_span-4 on-repeat_span-12 on-repeat_free-2 <<'EOF' && ok "the example's highest ground at least half as common in the outputs" || bad "the example's highest ground less than half as common in the outputs"
import json, sys
ms = [json.load(open(r + "/summary.json"))["metrics"] for r in sys.argv[1:]]
out = sum(m["height_above_p95_out"] for m in ms) / len(ms)
src = ms[0]["height_above_p95_src"]
print("at or above the example's 95th percentile: %s, pooled %.4f (the example's %.4f); KS %s" % (
    ", ".join("%.4f" % m["height_above_p95_out"] for m in ms), out, src,
    ", ".join("%.3f" % m["height_ks"] for m in ms)))
sys.exit(0 if out >= 0.5 * src else 1)
EOF
finish
