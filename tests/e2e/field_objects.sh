# End-to-end: the field engine's objects are whole (#19 item 3), on
# configs/field/balls.ini at 64^3 -> 64^3 (about 25 s a run on one core).
# Measured from field.h5 alone (analysis/field_objects.py): the inside
# components that touch no face of the grid, in the output and the source
# alike; a fragment is one smaller than half the source's smallest.
# - fragments: the output's share at most the source's plus 0.1 (the
#   source's is 0: every ball is whole);
# - the unrepaired synthesis (field.complete_objects = no: 9 of 18 interior
#   components are fragments) is flagged by that check;
# - size distribution: the KS distance of the interior components' sizes to
#   the source's no larger than without the pass;
# - statistics: volume fraction and surface per volume within 10% of the
#   source's (completing puts the cut balls' volume back, removing alone
#   would lower it).
# Broken on purpose (watched, see notes of #19): complete_objects
# (src/field/synth.c) returning at once fails the fragment check (0.5).
source "$GS_ROOT/tests/e2e/lib.bash"
B=$GS_ROOT/configs/field/balls.ini
SMALL=(--set example.size=64 --set field.target=64 --set output.geometry=none --set output.vdb=no
       --set output.preview=no)

figures() { /usr/bin/python3 - "$1" "$GS_ROOT" <<'PY'
import json, subprocess, sys
run = sys.argv[1]
m = json.load(open(run + "/summary.json"))["metrics"]
o = json.loads(subprocess.check_output(
    ["/usr/bin/python3", sys.argv[2] + "/analysis/field_objects.py", run, "--json"]))
o.update({"spv": m["surface_per_volume_out"], "spv_src": m["surface_per_volume_src"]})
print(json.dumps(o))
PY
}
get() { /usr/bin/python3 -c 'import json,sys;print(json.loads(sys.argv[1])[sys.argv[2]])' "$1" "$2"; }
le() { /usr/bin/python3 -c "import sys; sys.exit(0 if $1 <= $2 else 1)"; }

run_gs 1 field -c "$B" -o whole "${SMALL[@]}"
expect_rc 0 "balls.ini 64^3"
run_gs 1 field -c "$B" -o cut "${SMALL[@]}" --set field.complete_objects=no
expect_rc 0 "balls.ini 64^3, field.complete_objects = no"
new=$(figures whole) old=$(figures cut)
echo "whole: $new"
echo "cut:   $old"

fs=$(get "$new" fragments_src)
f=$(get "$new" fragments_out)
le "$f" "$fs + 0.1" && ok "fragment share $f (source $fs)" || bad "fragment share $f, the source's $fs"
fo=$(get "$old" fragments_out)
le "$fo" "$fs + 0.1" && bad "cut objects not flagged: fragment share $fo" ||
  ok "cut objects flagged: fragment share $fo"

k=$(get "$new" size_ks) ko=$(get "$old" size_ks)
le "$k" "$ko" && ok "size KS $k (without the pass $ko)" || bad "size KS $k, without the pass $ko"

for p in "vf_out vf_src" "spv spv_src"; do
  set -- $p
  a=$(get "$new" $1) src=$(get "$new" $2)
  /usr/bin/python3 -c "import sys; sys.exit(0 if abs($a - $src) <= 0.1 * $src else 1)" &&
    ok "$1 $a within 10% of the source's $src" || bad "$1 $a, not within 10% of the source's $src"
done
finish
