# Shared implementation of the Slurm job scripts in jobs/ (sourced by
# jobs/geosynth.sbatch and the per-engine jobs/ENGINE.sbatch; not a job itself).
#
#   gs_job ENGINE CONFIG [RUN_DIR] [--set section.key=value ...]
#
# - RUN_DIR defaults to runs/ENGINE-CONFIGNAME under the submit directory.
# - The job's log goes to RUN_DIR/slurm-JOBID.out (appended to by every
#   restart of the job; #SBATCH --output cannot know RUN_DIR, so the script
#   redirects itself once it does; Slurm's own output file only says where).
# - Launch: srun --mpi=pmix (Open MPI here is built for PMIx). GS_LAUNCH
#   replaces the launcher, e.g. GS_LAUNCH="mpirun -np 4" where srun has no
#   PMIx plugin (`srun --mpi=list`).
# - Threads per rank: OMP_NUM_THREADS and GS_THREADS (OpenVDB's TBB pool) are
#   set from SLURM_CPUS_PER_TASK (sbatch -c N), default 1.
# - A checkpoint in RUN_DIR means "resume": `geosynth resume RUN_DIR`, once
#   RUN_DIR/start.ini shows it is a run of this engine and configuration
#   (gs_job_same_run; run.* --set may differ and pass through, others refuse).
# - Time limits: the scripts ask for SIGUSR1 120 s before the limit
#   (#SBATCH --signal=USR1@120, sent to the job step, i.e. every rank).
#   geosynth writes a checkpoint at the next safe point on all ranks and
#   exits with code 9 (README, exit codes). The script then continues the run:
#   GS_CONTINUE=requeue (default) `scontrol requeue`s the same job (same job
#   id, SLURM_RESTART_COUNT counts up); GS_CONTINUE=chain submits a new job
#   with --dependency=afterany:JOBID running the same script and arguments;
#   GS_CONTINUE=none stops (resume by hand: sbatch the same command again).
#   Either way the next job resumes from the checkpoint and the final output
#   is bit-identical to an uninterrupted run (same digest).
# - The batch shell forwards TERM/USR1 it receives itself (scancel --signal,
#   #SBATCH --signal=B:...) to the job step. TERM to the batch shell is
#   scancel (or the hard limit): geosynth still checkpoints, but the run is
#   not continued. One job at a time per RUN_DIR.
# Exit code: geosynth's (0 done, 9 interrupted and continued, others: README).

# gs_job_script: absolute path of the submitted script. sbatch runs a copy
# from its spool directory, so ask Slurm for the original (Command=).
gs_job_script() {
  local cmd=""
  if [[ -n "${SLURM_JOB_ID:-}" ]]; then
    cmd=$(scontrol show job "$SLURM_JOB_ID" 2>/dev/null | sed -n 's/^ *Command=\([^ ]*\).*/\1/p' | head -1)
  fi
  echo "${cmd:-$0}"
}

# The configuration part of a resolved config on stdin (comments, blank
# lines and the [run] keys a resume may change left out; run.seed stays).
gs_job_config_body() {
  awk '/^\[/ { sec = $0 } /^[;#]/ || /^[[:space:]]*$/ { next }
       sec != "[run]" || $1 == "seed" { print }'
}

# A checkpoint in RUN_DIR must be of this job's engine and configuration:
# start.ini records both (first line "; geosynth ENGINE", then the resolved
# config), and `geosynth ENGINE -c CONFIG --set ... --check` prints what this
# job asks for in the same form. A RUN_DIR of another engine, or a config or
# --set that differ from the run's (other than run.* keys), is refused with
# exit 2 instead of resuming the other run and dropping the --set silently.
gs_job_same_run() {
  local engine=$1 config=$2 run_dir=$3 geosynth=$4 job=$5
  shift 5
  local start=$run_dir/start.ini was want d
  [[ -f $start ]] || return 0 # written by every run since 7e7307f; nothing to compare
  was=$(sed -n '1s/^; geosynth \([a-z]*\).*/\1/p' "$start")
  if [[ -n $was && $was != "$engine" ]]; then
    echo "geosynth job $job: error: $run_dir holds a checkpoint of a $was run (start.ini), not of" \
      "$engine: submit jobs/$was.sbatch to resume it, or give this job another RUN_DIR" >&2
    return 2
  fi
  if ! want=$("$geosynth" "$engine" -c "$config" "$@" --check); then # (its error: above)
    echo "geosynth job $job: error: $config with these --set does not load; not resuming $run_dir" >&2
    return 2
  fi
  d=$(diff <(gs_job_config_body <"$start") <(gs_job_config_body <<<"$want"))
  if [[ -n $d ]]; then
    echo "geosynth job $job: error: $run_dir holds a checkpoint of another configuration than" \
      "$config with these --set: resuming would ignore the difference (only run.* keys may" \
      "change on resume). Lines of $start (<) against this job's (>):" >&2
    echo "$d" | grep '^[<>]' | head -20 >&2
    echo "geosynth job $job: give this job another RUN_DIR, or submit the run's own config again" >&2
    return 2
  fi
}

gs_job() {
  local engine=${1:?usage: sbatch jobs/ENGINE.sbatch CONFIG [RUN_DIR] [--set section.key=value ...]}
  local config=${2:?usage: sbatch jobs/$engine.sbatch CONFIG [RUN_DIR] [--set section.key=value ...]}
  shift 2
  local run_dir=""
  if [[ $# -gt 0 && "$1" != --* ]]; then run_dir=$1; shift; fi
  [[ -z "$run_dir" ]] && run_dir=runs/$engine-$(basename "$config" .ini)
  local job=${SLURM_JOB_ID:-local}
  mkdir -p "$run_dir" || { echo "geosynth job $job: cannot create $run_dir" >&2; return 3; }
  run_dir=$(cd "$run_dir" && pwd)
  local log=$run_dir/slurm-$job.out
  echo "geosynth job $job: log in $log"
  exec >>"$log" 2>&1

  local geosynth=${GEOSYNTH:-$(command -v geosynth || echo "${SLURM_SUBMIT_DIR:-$PWD}/bin/geosynth")}
  local threads=${SLURM_CPUS_PER_TASK:-1}
  export OMP_NUM_THREADS=$threads GS_THREADS=$threads
  local -a launch=(srun --mpi=pmix --kill-on-bad-exit=1)
  [[ -n "${GS_LAUNCH:-}" ]] && read -r -a launch <<<"$GS_LAUNCH"

  echo "geosynth job $job: $(date -Is) on ${SLURM_JOB_NODELIST:-$(hostname)}, ${SLURM_NTASKS:-?} ranks x $threads threads, restart ${SLURM_RESTART_COUNT:-0}"
  local -a cmd
  if [[ -f "$run_dir/checkpoint.h5" ]]; then
    gs_job_same_run "$engine" "$config" "$run_dir" "$geosynth" "$job" "$@" || return
    echo "geosynth job $job: resuming $run_dir"
    # Only run.* keys may change on resume; pass those through.
    local -a runset=()
    local i args=("$@")
    for ((i = 0; i < ${#args[@]}; i++)); do
      [[ "${args[i]}" == --set && "${args[i+1]:-}" == run.* ]] && runset+=(--set "${args[i+1]}")
    done
    cmd=("${launch[@]}" "$geosynth" resume "$run_dir" "${runset[@]}")
  else
    echo "geosynth job $job: starting $engine $config -> $run_dir"
    cmd=("${launch[@]}" "$geosynth" "$engine" -c "$config" -o "$run_dir" "$@")
  fi
  echo "geosynth job $job: ${cmd[*]}"
  "${cmd[@]}" &
  local pid=$! rc cancelled=0
  # TERM to the batch shell itself means scancel (or the hard time limit):
  # forward it, and do not continue the run afterwards.
  trap 'cancelled=1; kill -TERM $pid 2>/dev/null' TERM
  trap 'kill -USR1 $pid 2>/dev/null' USR1
  wait $pid
  rc=$?
  # wait returns early (>128) when a trapped signal arrives: wait again, and
  # once more after it is gone (its status is still held if the interrupted
  # wait did not collect it; 127 means it was collected already).
  while kill -0 $pid 2>/dev/null; do wait $pid; rc=$?; done
  local last
  wait $pid 2>/dev/null
  last=$?
  [[ $last -ne 127 ]] && rc=$last
  trap - TERM USR1
  echo "geosynth job $job: geosynth exited with code $rc"
  if [[ $rc -eq 9 && $cancelled -eq 1 ]]; then
    echo "geosynth job $job: cancelled; checkpoint kept, resume with the same sbatch command"
  elif [[ $rc -eq 9 && -n "${SLURM_JOB_ID:-}" ]]; then
    case ${GS_CONTINUE:-requeue} in
      requeue)
        echo "geosynth job $job: interrupted with a checkpoint; requeueing"
        scontrol requeue "$SLURM_JOB_ID" ;;
      chain)
        local script next limit
        script=$(gs_job_script)
        # The same shape as this job: ranks, threads, time limit, partition, account.
        limit=$(scontrol show job "$SLURM_JOB_ID" 2>/dev/null | grep -o 'TimeLimit=[^ ]*' | head -1 | cut -d= -f2)
        [[ "$limit" == UNLIMITED || "$limit" == Partition_Limit ]] && limit=""
        next=$(sbatch --parsable --dependency=afterany:"$SLURM_JOB_ID" --ntasks="${SLURM_NTASKS:-1}" \
          --output="$run_dir/slurm-%j.out" --open-mode=append \
          ${SLURM_CPUS_PER_TASK:+--cpus-per-task=$SLURM_CPUS_PER_TASK} ${limit:+--time=$limit} \
          ${SLURM_JOB_PARTITION:+--partition=$SLURM_JOB_PARTITION} ${SLURM_JOB_ACCOUNT:+--account=$SLURM_JOB_ACCOUNT} \
          "$script" "${GS_JOB_ARGS[@]}")
        echo "geosynth job $job: interrupted with a checkpoint; chained job $next resumes it" ;;
      *)
        echo "geosynth job $job: interrupted with a checkpoint; resume with the same sbatch command" ;;
    esac
  fi
  return $rc
}
