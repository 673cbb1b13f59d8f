# End-to-end: the field engine's objects are whole (#19 item 3), on
# configs/field/balls.ini at 64^3 -> 64^3 (about 25 s a run on one core).
# The source's balls touch (dropped into a box): its inside is 10
# components, one of them 0.89 of the inside, while its cores (the samples
# deeper than one sample) are its 205 balls apart. So objects are counted
# as core components (analysis/field_objects.py --core, from field.h5
# alone; components touching a face of the grid left out, in the output and
# the source alike; a fragment is one smaller than half the source's
# smallest), and the balls' sizes as the radii of their largest inscribed
# spheres (summary.json, src/field/report.c: maxima of an exact distance
# transform of the inside). Thresholds from the source:
# - fragments: the output's share at most the source's plus 0.05;
# - object size: median within 25% of the source's;
# - inscribed radii: p10 within 25% and p50 within 10% of the source's;
# - volume fraction and surface per volume within 10% of the source's.
# The unrebuilt synthesis (field.complete_objects = no: balls glued from
# pieces of several, 11% fragments, radii p10/p50 1.00/2.24 against the
# source's 2.83/3.16) must fail the radius checks.
# Contacts (analysis/field_contacts.py, from field.h5 alone): the source's
# dropped balls touch (98% of them touch another) and never overlap (no pair
# with centres closer than 0.85 of their radii's sum); the output's share of
# balls touching another at least 0.9 of the source's, and its share of
# overlapping touching pairs at most the source's plus 0.01.
# What the synthesis itself made (summary.json synthesis_*, the field before
# the rebuild, /synthesis/levels): its seam ratio is analysis/field_seams.py's
# on that dataset, and an unlimited unblended synthesis (field.copy_limit = 0,
# field.blend = 0, e2e/field_patchwork's small run) is flagged by
# synthesis_copy_largest_region_of_source (> 0.25) with the rebuild on, while
# the rebuilt output's own copy figure does not show it. Without the rebuild
# synthesis_* are the output's figures.
# Broken on purpose (watched, see notes of #19): complete_objects
# (src/field/synth.c) returning at once fails the fragment share (0.11) and
# the radius checks (p10 1.00, p50 2.24); object_shift reduced to the
# voted offset alone fails the touching share (0.67 against the source's
# 0.98); the overlap test in object_probe a no-op fails the overlap share
# (0.07); report_synthesized (src/field/engine_output.c) giving the output's
# figures fails the unlimited run's flag (0.2 instead of 0.9).
source "$GS_ROOT/tests/e2e/lib.bash"
B=$GS_ROOT/configs/field/balls.ini
SMALL=(--set example.size=64 --set field.target=64 --set output.geometry=none --set output.vdb=no
       --set output.preview=no)

figures() { /usr/bin/python3 - "$1" "$GS_ROOT" <<'PY'
import json, subprocess, sys
run = sys.argv[1]
m = json.load(open(run + "/summary.json"))["metrics"]
o = json.loads(subprocess.check_output(
    ["/usr/bin/python3", sys.argv[2] + "/analysis/field_objects.py", run, "--json", "--core"]))
for k in ("surface_per_volume", "volume_fraction", "inscribed_p10", "inscribed_p50"):
    o[k + "_out"], o[k + "_src"] = m[k + "_out"], m[k + "_src"]
print(json.dumps(o))
PY
}
get() { /usr/bin/python3 -c 'import json,sys;print(json.loads(sys.argv[1])[sys.argv[2]])' "$1" "$2"; }
le() { /usr/bin/python3 -c "import sys; sys.exit(0 if $1 <= $2 else 1)"; }
# within FIGURES KEY SHARE: KEY_out within SHARE of KEY_src
within() {
  local a s
  a=$(get "$1" "$2_out") s=$(get "$1" "$2_src")
  /usr/bin/python3 -c "import sys; sys.exit(0 if abs($a - $s) <= $3 * $s else 1)"
}

run_gs 1 field -c "$B" -o whole "${SMALL[@]}"
expect_rc 0 "balls.ini 64^3"
run_gs 1 field -c "$B" -o cut "${SMALL[@]}" --set field.complete_objects=no
expect_rc 0 "balls.ini 64^3, field.complete_objects = no"
new=$(figures whole) old=$(figures cut)
echo "whole: $new"
echo "cut:   $old"

fs=$(get "$new" fragments_src)
f=$(get "$new" fragments_out)
le "$f" "$fs + 0.05" && ok "fragment share $f (source $fs)" || bad "fragment share $f, the source's $fs"

for p in "median 0.25" "inscribed_p10 0.25" "inscribed_p50 0.1" "volume_fraction 0.1" \
         "surface_per_volume 0.1"; do
  set -- $p
  within "$new" "$1" "$2" && ok "$1 $(get "$new" "$1_out") within $2 of the source's $(get "$new" "$1_src")" ||
    bad "$1 $(get "$new" "$1_out"), not within $2 of the source's $(get "$new" "$1_src")"
done
c=$(/usr/bin/python3 "$GS_ROOT/analysis/field_contacts.py" whole --json)
echo "contacts: $c"
t=$(get "$c" touching_out) ts=$(get "$c" touching_src)
le "0.9 * $ts" "$t" && ok "balls touching another $t (source $ts)" ||
  bad "balls touching another $t, under 0.9 of the source's $ts"
v=$(get "$c" overlap_pairs_out) vs=$(get "$c" overlap_pairs_src)
le "$v" "$vs + 0.01" && ok "overlapping pairs $v (source $vs)" || bad "overlapping pairs $v, the source's $vs"

# what the synthesis made, before the rebuild
syn() { /usr/bin/python3 - "$1" "$GS_ROOT" <<'PY'
import json, subprocess, sys
run, root = sys.argv[1], sys.argv[2]
m = json.load(open(run + "/summary.json"))["metrics"]
out = {k: m[k] for k in ("objects_rebuilt", "copy_largest_region_of_source", "seam_ratio_out",
                         "synthesis_copy_largest_region_of_source", "synthesis_seam_ratio")}
seams = lambda d: json.loads(subprocess.check_output(
    ["/usr/bin/python3", root + "/analysis/field_seams.py", run, "8", "--dataset", d]))["seam_ratio"]
out["py_out"] = seams("/field/levels")
if m["objects_rebuilt"]:
    out["py_synthesis"] = seams("/synthesis/levels")
print(json.dumps(out))
PY
}
sw=$(syn whole) sc=$(syn cut)
echo "synthesis, rebuilt: $sw"
echo "synthesis, not rebuilt: $sc"
[ "$(get "$sw" objects_rebuilt)" = 1 ] && ok "balls.ini: objects_rebuilt 1" || bad "balls.ini: objects_rebuilt not 1"
close() { /usr/bin/python3 -c "import sys; sys.exit(0 if abs($1 - $2) <= 1e-3 else 1)"; }
close "$(get "$sw" synthesis_seam_ratio)" "$(get "$sw" py_synthesis)" && close "$(get "$sw" seam_ratio_out)" "$(get "$sw" py_out)" &&
  ok "seam ratios as analysis/field_seams.py: synthesis $(get "$sw" py_synthesis), output $(get "$sw" py_out)" ||
  bad "seam ratios differ from analysis/field_seams.py: $sw"
[ "$(get "$sc" objects_rebuilt)" = 0 ] && close "$(get "$sc" synthesis_copy_largest_region_of_source)" "$(get "$sc" copy_largest_region_of_source)" &&
  close "$(get "$sc" synthesis_seam_ratio)" "$(get "$sc" seam_ratio_out)" &&
  ok "without the rebuild synthesis_* are the output's figures" || bad "without the rebuild: $sc"
run_gs 1 field -c "$B" -o unlimited --set example.size=32 --set field.target=64 --set output.geometry=none \
  --set output.vdb=no --set output.preview=no --set field.copy_limit=0 --set field.blend=0
expect_rc 0 "balls.ini 32^3 -> 64^3, field.copy_limit = 0, field.blend = 0, rebuilt"
su=$(syn unlimited)
echo "unlimited, rebuilt: $su"
l=$(get "$su" synthesis_copy_largest_region_of_source)
le "$l" 0.25 && bad "unlimited synthesis hidden by the rebuild: synthesis_copy_largest_region_of_source $l" ||
  ok "unlimited synthesis flagged through the rebuild: its largest copy $l of the source (the rebuilt output's $(get "$su" copy_largest_region_of_source))"

if within "$old" inscribed_p10 0.25 && within "$old" inscribed_p50 0.1; then
  bad "pieced balls not flagged: radii p10/p50 $(get "$old" inscribed_p10_out)/$(get "$old" inscribed_p50_out)"
else
  ok "pieced balls flagged: radii p10/p50 $(get "$old" inscribed_p10_out)/$(get "$old" inscribed_p50_out)"
fi
finish
