# End-to-end: the field seed varies the output (#19). In the default matching
# mode (field.mask_unsynthesized = yes, seed_weight = 0) a block with nothing
# synthesized around it used to be matched against iteration 0's random
# samples, and the one source block closest to noise won whatever the noise:
# configs/field/terrain.ini seeds 2, 3 and 4 gave bit-identical outputs (6
# and 7 too). Such a block now takes a source block uniformly at random
# (random_block, src/field/synth.c). Checks, from summary.json's digest of
# every output:
# - terrain.ini (full size, about 0.5 s a run) seeds 1-4 give four different
#   outputs, and quick.ini seeds 1, 2 two different ones;
# - the same seed gives bit-identical outputs at 1 and 2 ranks (terrain seed
#   3, quick seed 2).
# - quick.ini seeds 1-6: no output collapses (volume fraction at least half
#   the source's): a random first block all outside left quick.ini seed 3 at
#   0.068 (source 0.163) before random_block drew only blocks holding the
#   surface (then 0.133-0.176).
# Broken on purpose (watched): random_block's branch skipped in match_block:
# terrain seeds 2, 3, 4 share one digest and the first check fails; its
# surface test dropped: quick seed 3 at 0.068 fails the collapse check.
# - quick.ini seeds 1-6: volume fraction within 10% of the range the source's
#   own windows of the output's size give (summary.json
#   volume_fraction_src_window_min/max; the period-16 lattice over 48x40x32,
#   2.5 periods along y: 0.142-0.185, its whole 0.163). Seeds 1-12 measured
#   0.141-0.192 (field18/field19), all within; the paper-literal mode's
#   collapse (0.070) is not.
source "$GS_ROOT/tests/e2e/lib.bash"
T=$GS_ROOT/configs/field/terrain.ini Q=$GS_ROOT/configs/field/quick.ini
NOOUT=(--set output.geometry=none --set output.vdb=no --set output.preview=no)

declare -A dig
for s in 1 2 3 4; do
  run_gs 1 field -c "$T" -o "terrain-$s" "${NOOUT[@]}" --set run.seed=$s
  expect_rc 0 "terrain.ini seed $s"
  dig[t$s]=$(digest_of "terrain-$s")
done
for s in 1 2 3 4 5 6; do
  run_gs 1 field -c "$Q" -o "quick-$s" "${NOOUT[@]}" --set run.seed=$s
  expect_rc 0 "quick.ini seed $s"
  dig[q$s]=$(digest_of "quick-$s")
  r=$(/usr/bin/python3 -c 'import json,sys; m=json.load(open(sys.argv[1]))["metrics"]; o,s=m["volume_fraction_out"],m["volume_fraction_src"]; print(f"{o:.3f} (source {s:.3f})", int(o >= 0.5*s))' "quick-$s/summary.json")
  [[ ${r##* } == 1 ]] && ok "quick.ini seed $s: volume fraction ${r% *}, no collapse" ||
    bad "quick.ini seed $s: volume fraction ${r% *} below half the source's (collapsed)"
  # against what the source gives over a box of the output's size (its
  # windows, volume_fraction_src_window_min/max): within 10% of that range
  r=$(/usr/bin/python3 -c 'import json,sys; m=json.load(open(sys.argv[1]))["metrics"]; o,a,b=m["volume_fraction_out"],m["volume_fraction_src_window_min"],m["volume_fraction_src_window_max"]; print(f"{o:.3f} (source windows of its size {a:.3f}-{b:.3f})", int(0.9*a <= o <= 1.1*b))' "quick-$s/summary.json")
  [[ ${r##* } == 1 ]] && ok "quick.ini seed $s: volume fraction ${r% *}, within 10%" ||
    bad "quick.ini seed $s: volume fraction ${r% *}, more than 10% outside"
done
echo "digests: terrain ${dig[t1]} ${dig[t2]} ${dig[t3]} ${dig[t4]}, quick ${dig[q1]} ${dig[q2]}"

n=$(printf '%s\n' "${dig[t1]}" "${dig[t2]}" "${dig[t3]}" "${dig[t4]}" | sort -u | wc -l)
[[ $n -eq 4 ]] && ok "terrain.ini seeds 1-4: 4 different outputs" ||
  bad "terrain.ini seeds 1-4: only $n different outputs (the seed is ignored)"
[[ ${dig[q1]} != "${dig[q2]}" ]] && ok "quick.ini seeds 1, 2: different outputs" ||
  bad "quick.ini seeds 1, 2: the same output ${dig[q1]}"

run_gs 2 field -c "$T" -o terrain-3-np2 "${NOOUT[@]}" --set run.seed=3
expect_rc 0 "terrain.ini seed 3, 2 ranks"
d=$(digest_of terrain-3-np2)
[[ $d == "${dig[t3]}" ]] && ok "terrain.ini seed 3: np 2 = np 1 ($d)" ||
  bad "terrain.ini seed 3: np 2 gives $d, np 1 ${dig[t3]}"
run_gs 2 field -c "$Q" -o quick-2-np2 "${NOOUT[@]}" --set run.seed=2
expect_rc 0 "quick.ini seed 2, 2 ranks"
d=$(digest_of quick-2-np2)
[[ $d == "${dig[q2]}" ]] && ok "quick.ini seed 2: np 2 = np 1 ($d)" ||
  bad "quick.ini seed 2: np 2 gives $d, np 1 ${dig[q2]}"
finish
