# End-to-end: micro checkpoint/restart. A 6-instance run (quick.ini, finer)
# uninterrupted at np 1 gives the reference digest; then
# - GS_STOP_AFTER_UNITS stops it at np 2 (exit 9, mid-reconstruction: the
#   checkpoint holds partially labelled states) and `resume` at np 3 ends
#   with the reference digest;
# - a run at np 2 whose ranks get SIGKILL at a random moment after the first
#   checkpoint is resumed at np 1 and ends with the reference digest.
source "$GS_ROOT/tests/e2e/lib.bash"
QUICK=$GS_ROOT/configs/micro/quick.ini
SETS=(--set micro.instances=6 --set micro.scale_units=14 --set run.checkpoint_every=1)
RANDOM=$$

run_gs 1 micro -c "$QUICK" "${SETS[@]}" -o ref
expect_rc 0 "reference run at np=1"
ref=$(digest_of ref 2>/dev/null)
total=$(/usr/bin/python3 -c 'import json,sys
for l in open(sys.argv[1]):
    j = json.loads(l)
    if j["phase"] == "setup": print(j["units_total"])' ref/metrics.jsonl)
[[ -n "$ref" && -n "$total" ]] && ok "reference digest $ref, $total units" || bad "no reference digest"

# ---- deterministic stop + resume at another rank count ----
stop_at=$((total / 3))
GS_STOP_AFTER_UNITS=$stop_at run_gs 2 micro -c "$QUICK" "${SETS[@]}" -o st
expect_rc 9 "GS_STOP_AFTER_UNITS=$stop_at stops with exit 9"
expect_err "geosynth resume" "the stop message tells how to resume"
[[ ! -f st/summary.json ]] && ok "no summary.json after the stop" || bad "summary.json written by a stopped run"
run_gs 0 inspect st/checkpoint.h5
steps=$(grep -A20 'instance-000000 ' <<<"$out" | grep -Eo '@step = [0-9]+' | grep -Eo '[0-9]+$' | head -1)
[[ -n "$steps" && $steps -gt 0 ]] && ok "checkpoint taken mid-run (instance 0 at step $steps)" || bad "checkpoint state: ${out:0:400}"
run_gs 3 resume st
expect_rc 0 "resume at np=3"
d=$(digest_of st 2>/dev/null)
[[ "$d" == "$ref" ]] && ok "stop at np 2 + resume at np 3 = reference ($d)" || bad "resumed digest $d != $ref"
grep -q '"resumed":true' st/summary.json && ok "summary says resumed" || bad "summary lacks resumed:true"

# ---- kill -9 at a random moment + resume ----
rm -rf kl
mpirun -np 2 "$GS_BIN" micro -c "$QUICK" "${SETS[@]}" -o kl >kill.out 2>&1 &
job=$!
for ((t = 0; t < 300; t++)); do
  [[ -f kl/checkpoint.h5 ]] && break
  sleep 0.02
done
delay_ms=$((RANDOM % 1500))
sleep "$(printf '%d.%03d' $((delay_ms / 1000)) $((delay_ms % 1000)))"
ranks=$(pgrep -P "$job" 2>/dev/null)
[[ -n "$ranks" ]] && kill -KILL $ranks 2>/dev/null
for ((t = 0; t < 100; t++)); do
  kill -0 "$job" 2>/dev/null || break
  sleep 0.1
done
kill -0 "$job" 2>/dev/null && kill -KILL "$job" 2>/dev/null
wait "$job" 2>/dev/null
if [[ -f kl/summary.json ]]; then
  ok "run finished before the kill after ${delay_ms} ms (resume still checked)"
else
  ok "ranks killed with SIGKILL after ${delay_ms} ms"
fi
run_gs 1 resume kl
expect_rc 0 "resume after kill -9 at np=1"
d=$(digest_of kl 2>/dev/null)
[[ "$d" == "$ref" ]] && ok "kill -9 + resume = reference ($d)" || bad "digest after kill -9 + resume $d != $ref; ${err:0:400}"

finish
