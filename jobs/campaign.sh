#!/bin/bash
# Campaign driver: runs a sweep described in one file, configs x sizes x rank
# counts x seeds, every run into its own directory under one campaign folder.
# With Slurm: one job array per rank count (jobs/campaign.sbatch; each array
# task is one run, with the resume/requeue of jobs/lib/job.sh). Without Slurm
# (or with --local): every run here, one after the other, under mpirun.
#
#   jobs/campaign.sh CAMPAIGN_FILE [--out DIR] [--local|--slurm] [--wait] [--dry-run]
#                    [-- extra sbatch options]
#   /usr/bin/python3 analysis/report.py DIR        # then: DIR/report/index.html
#
# Campaign file (example: jobs/campaigns/small.campaign), one directive a line,
# '#' starts a comment:
#   ranks 1 2 4                       rank counts of the config lines that follow
#   seeds 1 2                         seeds (run.seed) of the config lines that follow
#   config ENGINE PATH [--set k=v]... one config (path relative to the campaign file)
#   size NAME --set k=v [--set k=v]   a size of the config above (none: its own size)
# Run directories: DIR/ENGINE-CONFIG[-SIZE]-npN-sSEED; DIR/campaign.tsv lists
# them (name, engine, config, size, np, seed, overrides); DIR defaults to
# runs/campaign-NAME (NAME: the campaign file without extension). Runs that
# already have a summary.json are skipped, so running the same command again
# finishes (or resumes) an interrupted campaign.
# Env: GEOSYNTH (the binary, default bin/geosynth or geosynth on PATH),
#      GS_MPIRUN (local launcher, default "mpirun"), GS_LAUNCH (see jobs/lib/job.sh).
set -euo pipefail
usage() { sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit "${1:-1}"; }
file="" out="" mode=auto wait=0 dry=0
sbatch_extra=()
while [[ $# -gt 0 ]]; do
  case $1 in
    --out) out=$2; shift 2 ;;
    --local) mode=local; shift ;;
    --slurm) mode=slurm; shift ;;
    --wait) wait=1; shift ;;
    --dry-run) dry=1; shift ;;
    -h|--help) usage 0 ;;
    --) shift; sbatch_extra=("$@"); break ;;
    -*) echo "campaign.sh: unknown option $1" >&2; usage ;;
    *) [[ -z "$file" ]] || { echo "campaign.sh: one campaign file only ($file, $1)" >&2; exit 1; }
       file=$1; shift ;;
  esac
done
[[ -n "$file" ]] || usage
[[ -f "$file" ]] || { echo "campaign.sh: cannot open campaign file '$file'" >&2; exit 3; }
here=$(cd "$(dirname "$0")" && pwd)
base=$(cd "$(dirname "$file")" && pwd)
name=$(basename "$file"); name=${name%.*}
out=${out:-runs/campaign-$name}
if [[ $mode == auto ]]; then
  if command -v sbatch >/dev/null && sinfo -h >/dev/null 2>&1; then mode=slurm; else mode=local; fi
fi
geosynth=${GEOSYNTH:-$(command -v geosynth || echo "$here/../bin/geosynth")}

# Parse: one row per run into $rows (tab-separated).
rows=() ranks="1" seeds="1" cfg_engine="" cfg_path="" cfg_set="" sizes=() lineno=0
emit() {
  [[ -n "$cfg_engine" ]] || return 0
  local cname s np seed sname sset run
  cname=$(basename "$cfg_path" .ini)
  [[ ${#sizes[@]} -eq 0 ]] && sizes=("-")
  for s in "${sizes[@]}"; do
    sname=${s%% *} sset=""
    [[ "$s" == *" "* ]] && sset=${s#* }
    for np in $cfg_ranks; do
      for seed in $cfg_seeds; do
        run=$cfg_engine-$cname
        [[ $sname != - ]] && run+=-$sname
        run+=-np$np-s$seed
        rows+=("$run"$'\t'"$cfg_engine"$'\t'"$cfg_path"$'\t'"$sname"$'\t'"$np"$'\t'"$seed"$'\t'"$(echo $cfg_set $sset) --set run.seed=$seed")
      done
    done
  done
  cfg_engine="" sizes=()
}
while IFS= read -r line || [[ -n "$line" ]]; do
  lineno=$((lineno + 1))
  line=${line%%#*}
  read -r kw rest <<<"$line" || true
  [[ -z "${kw:-}" ]] && continue
  case $kw in
    ranks) ranks=$rest ;;
    seeds) seeds=$rest ;;
    config)
      emit
      read -r cfg_engine cfg_path cfg_set <<<"$rest" || true
      [[ -n "${cfg_path:-}" ]] || { echo "$file:$lineno: config needs ENGINE PATH" >&2; exit 2; }
      [[ "$cfg_path" == /* ]] || cfg_path=$(realpath -m "$base/$cfg_path")
      [[ -f "$cfg_path" ]] || { echo "$file:$lineno: no config file $cfg_path" >&2; exit 3; }
      cfg_ranks=$ranks cfg_seeds=$seeds ;;
    size)
      [[ -n "$cfg_engine" ]] || { echo "$file:$lineno: size before any config line" >&2; exit 2; }
      [[ "$rest" == *" --set "* ]] || { echo "$file:$lineno: size needs NAME --set k=v" >&2; exit 2; }
      sizes+=("$rest") ;;
    *) echo "$file:$lineno: unknown directive '$kw' (ranks, seeds, config, size)" >&2; exit 2 ;;
  esac
done <"$file"
emit
[[ ${#rows[@]} -gt 0 ]] || { echo "$file: no config lines" >&2; exit 2; }

if [[ $dry -eq 0 ]]; then
  mkdir -p "$out"
  out=$(cd "$out" && pwd)
  printf '%s\n' "${rows[@]}" >"$out/campaign.tsv"
  cp "$file" "$out/campaign.txt"
fi
echo "campaign $name: ${#rows[@]} runs into $out ($mode$([[ $dry -eq 1 ]] && echo ', dry run: nothing written'))"

todo() { [[ ! -f "$out/$1/summary.json" ]]; }

if [[ $mode == local ]]; then
  read -r -a mpirun <<<"${GS_MPIRUN:-mpirun}"
  failed=0
  for row in "${rows[@]}"; do
    IFS=$'\t' read -r run engine config size np seed sets <<<"$row"
    todo "$run" || { echo "  $run: done already"; continue; }
    read -r -a setargs <<<"$sets"
    dir=$out/$run
    if [[ -f "$dir/checkpoint.h5" ]]; then
      cmd=("${mpirun[@]}" -np "$np" "$geosynth" resume "$dir")
    else
      cmd=("${mpirun[@]}" -np "$np" "$geosynth" "$engine" -c "$config" -o "$dir" "${setargs[@]}")
    fi
    echo "  $run: ${cmd[*]}"
    [[ $dry -eq 1 ]] && continue
    mkdir -p "$dir"
    rc=0
    "${cmd[@]}" >>"$dir/run.log" 2>&1 || rc=$?
    [[ $rc -eq 0 ]] || { echo "  $run: FAILED (exit $rc, log $dir/run.log)"; failed=$((failed + 1)); }
  done
  [[ $failed -eq 0 ]] || { echo "campaign $name: $failed runs failed" >&2; exit 1; }
  exit 0
fi

# Slurm: one job array per rank count, over the runs not done yet.
jobs=()
for np in $(printf '%s\n' "${rows[@]}" | cut -f5 | sort -nu); do
  list=$out/array-np$np.tsv
  selected=()
  for row in "${rows[@]}"; do
    IFS=$'\t' read -r run _ _ _ rnp _ _ <<<"$row"
    [[ $rnp == "$np" ]] && todo "$run" && selected+=("$row")
  done
  n=${#selected[@]}
  [[ $dry -eq 0 && $n -gt 0 ]] && printf '%s\n' "${selected[@]}" >"$list"
  [[ $n -gt 0 ]] || continue
  cmd=(sbatch --parsable --array=0-$((n - 1)) --ntasks="$np" --job-name="gs-$name-np$np"
       --output="$out/slurm-%A_%a.out" "${sbatch_extra[@]}" "$here/campaign.sbatch" "$list")
  echo "  np=$np: $n runs: ${cmd[*]}"
  [[ $dry -eq 1 ]] && continue
  jobs+=("$(GEOSYNTH=$geosynth "${cmd[@]}" | cut -d';' -f1)")
done
[[ ${#jobs[@]} -gt 0 ]] && echo "submitted job arrays: ${jobs[*]} (squeue -j $(IFS=,; echo "${jobs[*]}"))"
if [[ $wait -eq 1 && ${#jobs[@]} -gt 0 ]]; then
  ids=$(IFS=,; echo "${jobs[*]}")
  while [[ -n "$(squeue -h -j "$ids" 2>/dev/null)" ]]; do sleep 2; done
  missing=0
  for row in "${rows[@]}"; do todo "${row%%$'\t'*}" && missing=$((missing + 1)); done
  [[ $missing -eq 0 ]] || { echo "campaign $name: $missing runs have no summary.json" >&2; exit 1; }
  echo "campaign $name: all ${#rows[@]} runs done"
fi
