#!/usr/bin/env bash
# `make demo`: runs every configs/*/demo.ini with its engine on 2 ranks into
# runs/demo-ENGINE (no input files needed) and prints each digest.
set -eu
cd "$(dirname "$0")/.."
export OMPI_ALLOW_RUN_AS_ROOT=${OMPI_ALLOW_RUN_AS_ROOT:-1} OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=${OMPI_ALLOW_RUN_AS_ROOT_CONFIRM:-1}
for ini in configs/*/demo.ini; do
  engine=$(basename "$(dirname "$ini")")
  echo "== demo: geosynth $engine -c $ini"
  mpirun -np 2 bin/geosynth "$engine" -c "$ini" -o "runs/demo-$engine"
  echo "   outputs in runs/demo-$engine"
done
