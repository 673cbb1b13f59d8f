# End-to-end: the job scripts in jobs/ under a real (private, single-node)
# Slurm (tests/slurm/start.sh: slurmctld + slurmd + munge, proctrack/linuxproc,
# task/none, MpiDefault=pmix; stopped again at the end when this test started it).
#  1. jobs/model.sbatch (per-engine script, srun --mpi=pmix): SIGUSR1 to the
#     job step mid-run (what #SBATCH --signal=USR1@120 sends before the time
#     limit) -> checkpoint + exit 9 -> the script requeues the job -> the
#     requeued job resumes; final digest == an uninterrupted direct run.
#  2. jobs/field.sbatch with GS_CONTINUE=chain: the same, but the script
#     submits a dependent job that resumes (a two-job chain).
#     scancel instead: checkpoint, but no requeue.
#  3. jobs/campaign.sh as job arrays (one per rank count); digests agree.
# Logs: RUN_DIR/slurm-JOBID.out (the scripts redirect themselves there).
source "$GS_ROOT/tests/e2e/lib.bash"
command -v slurmctld >/dev/null || { bad "slurm-wlm is not installed (make deps installs it)"; finish; }
t0=$SECONDS
slurm_dir=$PWD/slurm
started=0
pgrep -x slurmctld >/dev/null || started=1
eval "$("$GS_ROOT/tests/slurm/start.sh" "$slurm_dir")" || { bad "private Slurm did not start"; finish; }
[[ $started -eq 1 ]] && trap 'scancel --user=root 2>/dev/null; "$GS_ROOT/tests/slurm/start.sh" --stop "$slurm_dir"' EXIT
ok "private Slurm is up ($(sinfo -h -o '%N %T %c CPUs'))"
export GEOSYNTH=$GS_BIN
here=$PWD

# job_state JOB: Slurm's state of a job (empty once forgotten).
job_state() { scontrol show job "$1" 2>/dev/null | grep -o 'JobState=[A-Z_]*' | head -1 | cut -d= -f2; }
# wait_end JOB SECONDS: waits until JOB has ended; sets $state.
wait_end() {
  local i
  for ((i = 0; i < $2 * 2; i++)); do
    state=$(job_state "$1")
    [[ "$state" == COMPLETED || "$state" == FAILED || "$state" == CANCELLED || "$state" == TIMEOUT ]] && return 0
    sleep 0.5
  done
  return 1
}
# signal_after_checkpoint DIR JOB: waits for DIR/checkpoint.h5, then SIGUSR1 to the job's steps.
signal_after_checkpoint() {
  local i
  for ((i = 0; i < 600; i++)); do [[ -f "$1/checkpoint.h5" ]] && break; sleep 0.2; done
  [[ -f "$1/checkpoint.h5" ]] && ok "job $2 wrote a checkpoint while running" || bad "job $2: no checkpoint appeared"
  scancel --signal=USR1 "$2"
}

# 1. Per-engine script, requeue.
# (the repository's CSV copy of escheresque: no fetched data needed)
config=$GS_ROOT/configs/model/escheresque-10x.ini
set_args=(--set 'model.example=${data}/model-synthesis/debroglie-samples-merrell/escheresque.csv'
          --set run.checkpoint_every=20)
run_gs 2 model -c "$config" -o ref-model "${set_args[@]}"
expect_rc 0 "reference model run (direct, np 2)"
ref=$(digest_of ref-model)
job=$(sbatch --parsable --ntasks=2 --output="$here/sbatch-%j.out" \
  "$GS_ROOT/jobs/model.sbatch" "$config" "$here/model" "${set_args[@]}")
[[ -n "$job" ]] && ok "sbatch jobs/model.sbatch: job $job" || { bad "sbatch failed"; finish; }
signal_after_checkpoint model "$job"
wait_end "$job" 300 || bad "job $job still '$state' after 300 s"
log=$(cat model/slurm-"$job".out 2>/dev/null)
[[ "$state" == COMPLETED ]] && ok "job $job completed after the signal" || bad "job $job ended '$state': $(tail -c 800 <<<"$log")"
grep -q "srun --mpi=pmix" <<<"$log" && ok "launched with srun --mpi=pmix" || bad "no srun --mpi=pmix in the log"
grep -q "2 ranks x 1 threads" <<<"$log" && ok "log in RUN_DIR/slurm-$job.out names ranks and threads" || bad "log: ${log:0:400}"
grep -q "exited with code 9" <<<"$log" && grep -q "interrupted with a checkpoint; requeueing" <<<"$log" \
  && ok "geosynth exited 9 on SIGUSR1 and the script requeued the job" || bad "no exit 9 + requeue: $(tail -c 800 <<<"$log")"
grep -q "restart 1" <<<"$log" && grep -q "resuming $PWD/model" <<<"$log" \
  && ok "the requeued job (restart 1) resumed from the checkpoint" || bad "requeued job did not resume: $(tail -c 800 <<<"$log")"
[[ -f model/summary.json ]] && got=$(digest_of model) || got=none
[[ "$got" == "$ref" ]] && ok "model: digest after USR1 + requeue + resume equals the direct run ($ref)" \
  || bad "model: digest $got differs from the direct run $ref"
grep -q '"resumed":true' model/summary.json 2>/dev/null && ok "summary records the resume" || bad "summary.json does not say resumed"

# 2. Per-engine script, chained dependent job.
config=$GS_ROOT/configs/field/quick.ini
set_args=(--set field.target=96x80x64 --set run.checkpoint_every=1500)
run_gs 1 field -c "$config" -o ref-field "${set_args[@]}"
expect_rc 0 "reference field run (direct, np 1)"
ref=$(digest_of ref-field)
job=$(GS_CONTINUE=chain sbatch --parsable --ntasks=1 --cpus-per-task=2 \
  --output="$here/sbatch-%j.out" "$GS_ROOT/jobs/field.sbatch" "$config" "$here/field" "${set_args[@]}")
[[ -n "$job" ]] && ok "sbatch jobs/field.sbatch (GS_CONTINUE=chain): job $job" || { bad "sbatch failed"; finish; }
signal_after_checkpoint field "$job"
wait_end "$job" 120 || bad "job $job still '$state' after 120 s"
log=$(cat field/slurm-"$job".out 2>/dev/null)
[[ "$state" == FAILED ]] && grep -q "exited with code 9" <<<"$log" \
  && ok "first job $job ended with exit 9 (interrupted)" || bad "first job '$state': $(tail -c 600 <<<"$log")"
next=$(grep -o 'chained job [0-9]*' <<<"$log" | grep -o '[0-9]*$')
[[ -n "$next" ]] && ok "the script chained job $next (afterany:$job)" || bad "no chained job: $(tail -c 600 <<<"$log")"
grep -q "1 ranks x 2 threads" <<<"$log" && ok "threads per rank from --cpus-per-task" || bad "threads: ${log:0:400}"
if [[ -n "$next" ]]; then
  wait_end "$next" 120 || bad "chained job $next still '$state' after 120 s"
  log2=$(cat field/slurm-"$next".out 2>/dev/null)
  [[ "$state" == COMPLETED ]] && grep -q "resuming $PWD/field" <<<"$log2" \
    && ok "chained job $next resumed and completed" || bad "chained job '$state': $(tail -c 600 <<<"$log2")"
fi
[[ -f field/summary.json ]] && got=$(digest_of field) || got=none
[[ "$got" == "$ref" ]] && ok "field: digest after USR1 + chained resume equals the direct run ($ref)" \
  || bad "field: digest $got differs from the direct run $ref"

# 2b. scancel (TERM to the batch shell too): checkpoint, but no requeue/chain.
job=$(sbatch --parsable --ntasks=1 --output="$here/sbatch-%j.out" \
  "$GS_ROOT/jobs/field.sbatch" "$config" "$here/cancel" "${set_args[@]}")
for ((i = 0; i < 600; i++)); do [[ -f cancel/checkpoint.h5 ]] && break; sleep 0.2; done
scancel "$job"
wait_end "$job" 120
log=$(cat cancel/slurm-"$job".out 2>/dev/null)
[[ "$state" == CANCELLED ]] && grep -q "cancelled; checkpoint kept" <<<"$log" && ! grep -q "requeueing" <<<"$log" \
  && ok "scancel: job $job stopped with a checkpoint and was not requeued" || bad "scancel: '$state': $(tail -c 600 <<<"$log")"

# 3. A campaign as job arrays.
cat >camp.campaign <<CAMP
ranks 1 2
config field $GS_ROOT/configs/field/quick.ini
config model $GS_ROOT/configs/model/demo.ini
CAMP
cout=$(timeout 300 "$GS_ROOT/jobs/campaign.sh" "$here/camp.campaign" --slurm --wait --out "$here/camp" 2>&1)
rc=$?
[[ $rc -eq 0 ]] && ok "campaign of 4 runs as job arrays finished" || bad "campaign.sh --slurm (rc=$rc): $(tail -c 800 <<<"$cout")"
grep -q -- "--array=0-1 --ntasks=1" <<<"$cout" && grep -q -- "--array=0-1 --ntasks=2" <<<"$cout" \
  && ok "one job array per rank count" || bad "no arrays: $cout"
n=$(ls camp/*/summary.json 2>/dev/null | wc -l)
[[ $n -eq 4 ]] && ok "every array task wrote summary.json ($n)" || bad "$n summary.json files in camp/"
ls camp/field-quick-np2-s1/slurm-*.out >/dev/null 2>&1 && ok "array task logs are in the run directories" || bad "no task log in camp/field-quick-np2-s1"
table=$(/usr/bin/python3 "$GS_ROOT/analysis/campaign_table.py" camp 2>&1) \
  && ok "campaign digests agree across rank counts" || bad "campaign_table: $table"
ok "Slurm test took $((SECONDS - t0)) s"
finish
