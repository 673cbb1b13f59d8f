#!/bin/bash
# Submits a benchmark campaign: every config given, at every rank count and
# seed, one Slurm job each, run directories named after the combination.
# Afterwards `analysis/campaign_table.py runs/campaign` tabulates summary.json.
#
#   jobs/campaign.sh --ranks "1 2 4" --seeds "1 2 3" field configs/field/*.ini
set -euo pipefail
ranks="1 2 4"
seeds="1"
out=runs/campaign
while [[ $# -gt 0 ]]; do
  case $1 in
    --ranks) ranks=$2; shift 2 ;;
    --seeds) seeds=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    *) break ;;
  esac
done
engine=${1:?usage: jobs/campaign.sh [--ranks "1 2"] [--seeds "1 2"] [--out DIR] ENGINE CONFIG...}
shift
here=$(cd "$(dirname "$0")" && pwd)
for config in "$@"; do
  name=$(basename "$config" .ini)
  for np in $ranks; do
    for seed in $seeds; do
      dir="$out/$engine-$name-np$np-seed$seed"
      mkdir -p "$dir"
      sbatch --parsable --ntasks="$np" --job-name="gs-$name-$np-$seed" \
        --output="$dir/slurm-%j.out" "$here/geosynth.sbatch" "$engine" "$config" "$dir" \
        --set "run.seed=$seed"
    done
  done
done
