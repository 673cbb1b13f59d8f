#!/usr/bin/env bash
# Runs every benchmark program (build/tests/bench/*) and whole-run benchmarks,
# writing one JSON file per benchmark into bench-results/ and printing a table.
# Benchmarks compare methods side by side in one run and report ratios;
# absolute seconds on shared machines are noisy.
set -u
cd "$(dirname "$0")/../.."
BUILD=${BUILD:-build}
out=bench-results
mkdir -p "$out"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
export OMPI_MCA_btl=self,vader,tcp OMPI_MCA_btl_vader_single_copy_mechanism=none
# One machine: the ob1 PML over shared memory. Without it MPI_Init probes the
# OFI/PSM2/UCX transports, 0.2-0.3 s of every mpirun here (an empty 2-rank
# program: 0.46 s default, 0.21 s with ob1). Clusters choose their own.
export OMPI_MCA_pml=${OMPI_MCA_pml:-ob1}
export GS_ROOT=$PWD GS_BIN=$PWD/${BIN:-bin}/geosynth
status=0
for exe in "$BUILD"/tests/bench/*; do
  [[ -x "$exe" && ! -d "$exe" ]] || continue
  name=$(basename "$exe")
  [[ -n "${T:-}" && "$name" != *"$T"* ]] && continue
  echo "== $name"
  if "$exe" >"$out/$name.json" 2>"$out/$name.log"; then
    echo "   -> $out/$name.json"
  else
    echo "   FAILED (see $out/$name.log)"; status=1
  fi
done
for script in tests/bench/*.sh; do
  [[ "$(basename "$script")" == run.sh ]] && continue
  [[ -f "$script" ]] || continue
  name=$(basename "$script" .sh)
  [[ -n "${T:-}" && "$name" != *"$T"* ]] && continue
  echo "== $name"
  if bash "$script" >"$out/$name.json" 2>"$out/$name.log"; then
    echo "   -> $out/$name.json"
  else
    echo "   FAILED (see $out/$name.log)"; status=1
  fi
done
exit $status
