#!/usr/bin/env bash
# Resume after a kill before the first checkpoint (#25 item 2): a fresh run
# writes RUN_DIR/start.ini (engine + resolved config) before anything else;
# `geosynth resume RUN_DIR` with no checkpoint starts the run again from it
# (it used to stop with "checkpoint.h5: cannot open") and ends with the
# uninterrupted digest (tests/golden/digests.tsv). Every engine's quick
# config at np 2 with checkpoints off, every rank killed with SIGKILL at a
# random moment after start.ini appears, resumed at np 1 or 3.
# TRIALS=N kills per engine (default 1).
source "$GS_ROOT/tests/e2e/lib.bash"
TRIALS=${TRIALS:-1}
RANDOM=${SEED:-4242}
golden() { awk -F'\t' -v e="$1" -v c="$2" '$1 == e && $2 == c { print $5; exit }' \
  "$GS_ROOT/tests/golden/digests.tsv"; }
cases=("field configs/field/quick.ini" "points configs/points/quick.ini"
       "micro configs/micro/quick.ini" "model configs/model/demo.ini")
for c in "${cases[@]}"; do
  read -r eng cfg <<<"$c"
  ref=$(golden "$eng" "$cfg")
  for ((t = 1; t <= TRIALS; t++)); do
    d=k-$eng-$t; rm -rf "$d"
    mpirun -np 2 "$GS_BIN" "$eng" -c "$GS_ROOT/$cfg" -o "$d" --set run.checkpoint_seconds=0 >"$d.out" 2>&1 &
    job=$!
    for ((i = 0; i < 200; i++)); do [[ -f $d/start.ini ]] && break; sleep 0.02; done
    sleep "0.$((RANDOM % 8))"
    pkill -KILL -P "$(pgrep -d, -P $job)" 2>/dev/null # the ranks (children of mpirun's children)
    pkill -KILL -P $job 2>/dev/null
    kill -KILL $job 2>/dev/null; wait $job 2>/dev/null
    when=killed; [[ -f $d/summary.json ]] && when="finished before the kill"
    [[ -f $d/start.ini && ! -f $d/checkpoint.h5 ]] && ok "$eng trial $t: start.ini written, no checkpoint ($when)" \
      || bad "$eng trial $t: start.ini missing or a checkpoint written with checkpoints off"
    rm -f "$d/summary.json"
    np=$((t % 2 ? 1 : 3))
    run_gs $np resume "$d"
    got=$(digest_of "$d" 2>/dev/null)
    [[ $rc -eq 0 && $got == "$ref" ]] && grep -q "starting it again from" <<<"$err" \
      && ok "$eng trial $t: resume at np $np with no checkpoint starts again: digest $got = uninterrupted" \
      || bad "$eng trial $t: resume with no checkpoint: exit $rc, digest $got (expected $ref): ${err:0:500}"
  done
done
finish
