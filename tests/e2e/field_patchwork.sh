# End-to-end: the field engine makes new geometry, not a patchwork of the
# source (#19 items 2 and 7), on configs/field/balls.ini at a small size
# (BALLS 32^3 -> 64^3, blocks 8 and 16, about 5 s on one core):
# - copies: no piece copied verbatim from one source offset is larger than a
#   quarter of the source (copy_largest_region_of_source, src/measure/copy.c,
#   from the output and the source alone);
# - seams: the field's steps across the planes where the last iteration's
#   pieces meet (every block/2 = 8 samples) are no larger than the source's
#   own steps at any phase of that period allow (analysis/field_seams.py:
#   seam_ratio <= source max + the source's spread over phases);
# - statistics: volume fraction and surface per volume no further from the
#   source's than without the copy limit, plus 10% of the source's.
# The measures flag the unlimited synthesis (field.copy_limit = 0: one copy
# of 0.93 of the source) and the unblended one (field.blend = 0: seam ratio
# 2.5 against the source's 1.11), checked below too.
# Broken on purpose, each fails here (watched, see notes of #19):
#   copy_exclusions (src/field/synth.c) returning no exclusion: largest copy 0.93;
#   blend_seams returning at once: seam ratio 2.5.
source "$GS_ROOT/tests/e2e/lib.bash"
B=$GS_ROOT/configs/field/balls.ini
# balls.ini's field.complete_objects rebuilds the output from whole source
# balls after the synthesis (4e3fc40; e2e/field_objects checks it), which
# also hides what the copy limit and the blend do: with it on, the unlimited
# unblended run scored largest copy 0.216 and seam ratio 1.070, passing for
# a limited one. This test is about those two, so both runs leave it off.
SMALL=(--set example.size=32 --set field.target=64 --set output.geometry=none --set output.vdb=no --set field.complete_objects=no)

figures() { /usr/bin/python3 - "$1" "$GS_ROOT" <<'PY'
import json, subprocess, sys
run = sys.argv[1]
m = json.load(open(run + "/summary.json"))["metrics"]
s = json.loads(subprocess.check_output(
    ["/usr/bin/python3", sys.argv[2] + "/analysis/field_seams.py", run, "8"]))
print(json.dumps({"largest": m["copy_largest_region_of_source"], "vf": m["volume_fraction_out"],
                  "vf_src": m["volume_fraction_src"], "spv": m["surface_per_volume_out"],
                  "spv_src": m["surface_per_volume_src"], "seam": s["seam_ratio"],
                  "seam_max": s["source_ratio_max"] + (s["source_ratio_max"] - s["source_ratio_min"])}))
PY
}
get() { /usr/bin/python3 -c 'import json,sys;print(json.loads(sys.argv[1])[sys.argv[2]])' "$1" "$2"; }
le() { /usr/bin/python3 -c "import sys; sys.exit(0 if $1 <= $2 else 1)"; }

run_gs 1 field -c "$B" -o limited "${SMALL[@]}"
expect_rc 0 "balls.ini small"
run_gs 1 field -c "$B" -o unlimited "${SMALL[@]}" --set field.copy_limit=0 --set field.blend=0
expect_rc 0 "balls.ini small, field.copy_limit = 0, field.blend = 0"
new=$(figures limited) old=$(figures unlimited)
echo "limited:   $new"
echo "unlimited: $old"

l=$(get "$new" largest)
le "$l" 0.25 && ok "largest copy $l of the source (at most a quarter)" || bad "largest copy $l of the source, more than a quarter"
lo=$(get "$old" largest)
le "$lo" 0.25 && bad "unlimited synthesis not flagged: largest copy $lo" || ok "unlimited synthesis flagged: largest copy $lo"

s=$(get "$new" seam) sm=$(get "$new" seam_max)
le "$s" "$sm" && ok "seam ratio $s within the source's $sm" || bad "seams: ratio $s, the source's phases reach $sm"
so=$(get "$old" seam)
le "$so" "$sm" && bad "unblended seams not flagged: ratio $so" || ok "unblended seams flagged: ratio $so > $sm"

for k in vf spv; do
  a=$(get "$new" $k) b=$(get "$old" $k) src=$(get "$new" ${k}_src)
  /usr/bin/python3 -c "import sys; sys.exit(0 if abs($a - $src) <= abs($b - $src) + 0.1 * $src else 1)" &&
    ok "$k $a (unlimited $b, source $src)" || bad "$k $a moved away from the source $src (unlimited $b)"
done
# --- terrain.ini (#19 item 2: no straight seams on the height field) ---
# Full size (64^2 -> 128x128x16), seeds 1-6 (the seed varies the output since
# the random first block, e2e/field_seeds), about 2-6 s a seed. Every seed:
# largest copy at most a quarter of the source, vf within 10% of the source's,
# and the seams (analysis/field_seams.py over x and y; z is one block deep, no
# seams across it) within thresholds from the example: the seam ratio within
# the example's range over phases (at most its largest, 1.050), and no plane
# of the seam phase (every 8 samples) stepping more against its axis' mean
# than the example's largest plane (1.878). Per seed, not by the mean: the
# mean hid seeds 1 and 3 above 1.050 and seed 5's straight flat strip (plane
# 2.21) before field.seam_gradient and field.repeat_reach (field16): seeds 1-6
# seam ratio 0.982, 1.008, 1.008, 0.983, 1.017, 0.962, plane 1.38-1.67.
# Broken on purpose, each fails here (field16, watched): field.blend = 0 (seam
# ratio 1.073-1.121 on all six); field.copy_limit_reach = 0 (block/4: seed 4's
# vf 24% off); field.seam_gradient = no (seeds 1, 2, 3, 5 at 1.057-1.072);
# field.repeat_reach = 0 (seed 5's plane 2.18); seam_gradient in
# src/field/synth.c returning at once (as seam_gradient = no). Env
# TERRAIN_SEEDS, TERRAIN_SET (extra --set): other seeds, or a setting to
# break it on purpose.
T=$GS_ROOT/configs/field/terrain.ini
for seed in ${TERRAIN_SEEDS:-1 2 3 4 5 6}; do
  run_gs 1 field -c "$T" -o "terrain-$seed" --set run.seed=$seed --set output.geometry=none \
    --set output.vdb=no --set output.preview=no ${TERRAIN_SET:-}
  expect_rc 0 "terrain.ini seed $seed"
  ts=$(/usr/bin/python3 "$GS_ROOT/analysis/field_seams.py" "terrain-$seed" 8)
  echo "terrain seed $seed: $ts"
  tp=$(get "$ts" plane_ratio_max) tsp=$(get "$ts" source_plane_max)
  tr=$(get "$ts" seam_ratio) tmax=$(get "$ts" source_ratio_max) tmin=$(get "$ts" source_ratio_min)
  le "$tp" "$tsp" && ok "terrain seed $seed: steepest seam plane $tp times its axis' mean (the example's largest plane $tsp)" ||
    bad "terrain seed $seed: a seam plane steps $tp times its axis' mean, the example's largest plane $tsp"
  le "$tr" "$tmax" && ok "terrain seed $seed: seam ratio $tr within the example's phases ($tmin-$tmax)" ||
    bad "terrain seed $seed: seam ratio $tr above the example's phases $tmin-$tmax"
  /usr/bin/python3 - "terrain-$seed/summary.json" <<'EOF3' && ok "terrain seed $seed: largest copy <= 0.25, vf within 10%" || bad "terrain seed $seed: largest copy or vf out of bounds"
import json, sys
m = json.load(open(sys.argv[1]))["metrics"]
# terrain.ini's height match moves columns along z after the synthesis, which
# hides copied pieces from the output's copy_*: judge the synthesis' own
# (synthesis_copy_*, measured before the match; equal to copy_* without it)
print("largest copy", round(m["synthesis_copy_largest_region_of_source"], 3), "(output's", round(m["copy_largest_region_of_source"], 3), ") vf", round(m["volume_fraction_out"], 3), "source", round(m["volume_fraction_src"], 3))
assert m["synthesis_copy_largest_region_of_source"] <= 0.25
assert abs(m["volume_fraction_out"] / m["volume_fraction_src"] - 1) <= 0.10
EOF3
done
finish
