#!/usr/bin/env bash
# jobs/*.sbatch resume only their own run (#25 item 4): a job whose RUN_DIR
# holds a checkpoint resumes it only when RUN_DIR/start.ini shows a run of the
# job's engine and configuration (run.* keys aside). Another engine's
# checkpoint, another config, or a --set that changes a non-run key is refused
# with exit 2 and a message naming the difference (the job used to resume the
# other run and drop the --set silently; a field job in a model run directory
# ran the model). The job scripts run here without Slurm (GS_LAUNCH=mpirun).
source "$GS_ROOT/tests/e2e/lib.bash"
export GS_LAUNCH="mpirun -np 2" GEOSYNTH=$GS_BIN GS_CONTINUE=none
job() { # job SCRIPT ARGS...: runs a job script; rc, log text (the newest RUN_DIR log)
  local script=$1 dir=$3
  shift
  bash "$GS_ROOT/jobs/$script" "$@" >/dev/null 2>&1
  rc=$?
  log=$(cat "$dir"/slurm-local.out 2>/dev/null)
  rm -f "$dir"/slurm-local.out
}
# A model run stopped with a checkpoint (SIGUSR1 after the first one).
d=model-run; rm -rf $d
mpirun -np 2 "$GS_BIN" model -c "$GS_ROOT/configs/model/demo.ini" -o $d --set run.checkpoint_every=1 >/dev/null 2>&1 &
pid=$!
for ((i = 0; i < 500; i++)); do [[ -f $d/checkpoint.h5 ]] && break; sleep 0.02; done
kill -USR1 $pid; wait $pid; r=$?
[[ -f $d/checkpoint.h5 && ! -f $d/summary.json ]] && ok "model run stopped with a checkpoint (exit $r)" \
  || bad "model run did not stop with a checkpoint (exit $r): the cases below are not meaningful"

job field.sbatch "$GS_ROOT/configs/field/quick.ini" $d
[[ $rc -eq 2 ]] && grep -q "holds a checkpoint of a model run (start.ini), not of field" <<<"$log" \
  && ok "field job in a model run directory: refused, exit 2" \
  || bad "field job in a model run directory: exit $rc: ${log:0:600}"
[[ -f $d/checkpoint.h5 && ! -f $d/summary.json ]] && ok "the model checkpoint is left as it was" \
  || bad "the refused job touched the model run"

job model.sbatch "$GS_ROOT/configs/model/city4d.ini" $d
[[ $rc -eq 2 ]] && grep -q "another configuration" <<<"$log" && grep -q "^[<>] example = " <<<"$log" \
  && ok "model job with another config: refused, exit 2, the differing example line shown" \
  || bad "model job with another config: exit $rc: ${log:0:600}"

job model.sbatch "$GS_ROOT/configs/model/demo.ini" $d --set model.attempts=7
[[ $rc -eq 2 ]] && grep -q "^> attempts = 7" <<<"$log" \
  && ok "model job with a --set of a model key: refused, exit 2 (not dropped)" \
  || bad "model job with --set model.attempts=7: exit $rc: ${log:0:600}"

ref=$(golden model configs/model/demo.ini)
job model.sbatch "$GS_ROOT/configs/model/demo.ini" $d --set run.log_level=info
got=$(digest_of $d 2>/dev/null)
[[ $rc -eq 0 && $got == "$ref" ]] && grep -q "resuming" <<<"$log" \
  && ok "the run's own config (+ a run.* --set) resumes it: digest $got = golden" \
  || bad "own config resume: exit $rc, digest $got (golden $ref): ${log:0:600}"
finish
