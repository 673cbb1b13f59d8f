# End-to-end: the Slurm job script under a real (private, single-node) Slurm.
# Submits jobs/geosynth.sbatch with a model config, sends SIGTERM to the job
# step mid-run (as Slurm does before a time limit), and checks that geosynth
# wrote a checkpoint and exited 9, that the script requeued itself, that the
# requeued job resumed from the checkpoint on another rank count, and that
# the final digest equals a direct uninterrupted run.
source "$GS_ROOT/tests/e2e/lib.bash"
command -v slurmctld >/dev/null || { bad "slurm-wlm is not installed (make deps installs it)"; finish; }

slurm_dir=$PWD/slurm
started=0
pgrep -x slurmctld >/dev/null || started=1
eval "$("$GS_ROOT/tests/slurm/start.sh" "$slurm_dir")" || { bad "private Slurm did not start"; finish; }
[[ $started -eq 1 ]] && trap '"$GS_ROOT/tests/slurm/start.sh" --stop "$slurm_dir"' EXIT
ok "private Slurm is up ($(sinfo -h -o '%N %T'))"

config=$GS_ROOT/configs/model/escheresque-10x.ini
set_args=(--set run.checkpoint_every=20)

# Reference: a direct uninterrupted run.
run_gs 2 model -c "$config" -o ref "${set_args[@]}"
expect_rc 0 "reference run"
ref=$(digest_of ref)

export GEOSYNTH=$GS_BIN
job=$(sbatch --parsable --ntasks=2 --output="$PWD/job-%j.out" \
  "$GS_ROOT/jobs/geosynth.sbatch" model "$config" "$PWD/run" "${set_args[@]}")
[[ -n "$job" ]] && ok "submitted job $job" || { bad "sbatch failed"; finish; }

# Wait until the first checkpoint exists, then signal the running step.
for _ in $(seq 240); do
  [[ -f run/checkpoint.h5 ]] && break
  sleep 0.5
done
[[ -f run/checkpoint.h5 ]] && ok "job wrote a checkpoint while running" || bad "no checkpoint appeared"
scancel --signal=TERM "$job"

# The job must be requeued (restart count 1) and finish.
state=""
for _ in $(seq 600); do
  state=$(scontrol show job "$job" 2>/dev/null | grep -o 'JobState=[A-Z_]*' | cut -d= -f2)
  [[ "$state" == COMPLETED || "$state" == FAILED || "$state" == CANCELLED ]] && break
  sleep 0.5
done
out=$(cat job-"$job".out 2>/dev/null)
[[ "$state" == COMPLETED ]] && ok "job completed after the signal" || bad "job ended in state '$state': ${out: -800}"
grep -q "interrupted with a checkpoint; requeueing" <<<"$out" && ok "job script requeued itself after exit 9" \
  || bad "no requeue in the job log: ${out: -800}"
grep -q "resuming $PWD/run" <<<"$out" && ok "requeued job resumed from the checkpoint" \
  || bad "requeued job did not resume: ${out: -800}"
[[ -f run/summary.json ]] && got=$(digest_of run) || got=none
[[ "$got" == "$ref" ]] && ok "digest after signal + requeue + resume equals the direct run ($ref)" \
  || bad "digest $got differs from the direct run $ref"
grep -q '"resumed":true' run/summary.json && ok "summary records the resume" || bad "summary.json does not say resumed"
finish
