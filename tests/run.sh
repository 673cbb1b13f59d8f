#!/usr/bin/env bash
# geosynth test runner (called by `make test`; see tests/README.md).
#
# Suites: unit (cmocka programs), mpi (programs run under mpirun at each rank
# count in NP; every "digest: NAME HEX" line they print must be identical
# across rank counts), e2e (tests/e2e/*.sh), fuzz (libFuzzer targets over
# their seed corpus plus a short bounded run).
# Usage: tests/run.sh [unit|mpi|e2e|fuzz ...]   env: BUILD BIN NP T VALGRIND
# Ends with one line "N passed, N failed" and exits non-zero on any failure.
set -u
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
BIN=${BIN:-bin}
NP=${NP:-1 2 3 4}
T=${T:-}
VALGRIND=${VALGRIND:-}
suites=("$@")
[[ ${#suites[@]} -eq 0 ]] && suites=(unit mpi e2e fuzz)

export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1
# Quiet Open MPI's transport probing on machines without InfiniBand.
export OMPI_MCA_btl=self,vader,tcp OMPI_MCA_btl_vader_single_copy_mechanism=none
# One machine: the ob1 PML over shared memory. Without it MPI_Init probes the
# OFI/PSM2/UCX transports, 0.2-0.3 s of every mpirun here (an empty 2-rank
# program: 0.46 s default, 0.21 s with ob1). Clusters choose their own.
export OMPI_MCA_pml=${OMPI_MCA_pml:-ob1}
export GS_ROOT=$PWD GS_BIN=$PWD/$BIN/geosynth GS_BUILD=$PWD/$BUILD
export GS_SHARED=${GS_SHARED:-$PWD/../shared}
# Sanitizer builds: leaks inside MPI/HDF5 start-up are theirs (tests/lsan.supp).
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$PWD/tests/lsan.supp:print_suppressions=0}
# (Open MPI 4.1 unloads its plugins at MPI_Finalize; sanitizer builds link
# tests/san/nodlclose.c so their leaks keep a module name the suppressions match.)
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}

passed=0
failed=0
failures=()
log_dir=$BUILD/test-logs
mkdir -p "$log_dir"

pass() { passed=$((passed + $1)); }
fail() { failed=$((failed + 1)); failures+=("$1"); echo "FAIL: $1 (log: $2)"; }
selected() { [[ -z "$T" || "$1" == *"$T"* ]]; }

run_unit() {
  for exe in "$BUILD"/tests/unit/test_*; do
    [[ -x "$exe" ]] || continue
    name=$(basename "$exe")
    selected "$name" || continue
    log="$log_dir/$name.log"
    if [[ -n "$VALGRIND" ]]; then
      cmd=(valgrind --quiet --error-exitcode=99 --leak-check=full --errors-for-leak-kinds=definite --num-callers=50
           --suppressions=$GS_ROOT/tests/valgrind.supp "$GS_ROOT/$exe")
    else
      cmd=("$GS_ROOT/$exe")
    fi
    (cd tests && "${cmd[@]}") >"$log" 2>&1
    rc=$?
    ok=$(grep -Eo '\[  PASSED  \] [0-9]+' "$log" | grep -Eo '[0-9]+$' | tail -1)
    bad=$(grep -Eo '\[  FAILED  \] [0-9]+ test' "$log" | grep -Eo '[0-9]+' | tail -1)
    pass "${ok:-0}"
    if [[ $rc -ne 0 || -n "$bad" ]]; then
      fail "unit/$name (${bad:-?} failed, rc=$rc)" "$log"
    else
      echo "ok   unit/$name (${ok:-0} cases)"
    fi
  done
}

run_mpi() {
  for exe in "$BUILD"/tests/mpi/*; do
    [[ -x "$exe" && ! -d "$exe" ]] || continue
    name=$(basename "$exe")
    selected "$name" || continue
    src=tests/mpi/$name.c
    nps=$(grep -Eo 'np: [0-9 ]+' "$src" 2>/dev/null | head -1 | cut -d: -f2)
    [[ -z "$nps" ]] && nps=$NP
    ref=""
    for np in $nps; do
      log="$log_dir/mpi-$name-np$np.log"
      (cd tests && timeout 300 mpirun -np "$np" "$GS_ROOT/$exe") >"$log" 2>&1
      rc=$?
      if [[ $rc -ne 0 ]]; then fail "mpi/$name np=$np (rc=$rc)" "$log"; continue; fi
      digests=$(grep -E '^digest: ' "$log" | sort)
      if [[ -z "$ref" ]]; then
        ref=$digests refnp=$np
        pass 1; echo "ok   mpi/$name np=$np"
      elif [[ "$digests" != "$ref" ]]; then
        fail "mpi/$name np=$np digests differ from np=$refnp" "$log"
      else
        pass 1; echo "ok   mpi/$name np=$np (digests match np=$refnp)"
      fi
    done
  done
}

run_e2e() {
  for script in tests/e2e/*.sh; do
    [[ -f "$script" ]] || continue
    name=$(basename "$script" .sh)
    selected "$name" || continue
    log="$log_dir/e2e-$name.log"
    work=$(mktemp -d "${TMPDIR:-/tmp}/gs-e2e-$name.XXXX")
    (cd "$work" && timeout 900 bash "$GS_ROOT/$script") >"$log" 2>&1
    rc=$?
    # An e2e script may count its own checks with lines "check ok: ..." / "check FAILED: ...".
    nok=$(grep -c '^check ok' "$log")
    nbad=$(grep -c '^check FAILED' "$log")
    if [[ $rc -ne 0 || $nbad -ne 0 ]]; then
      pass "$nok"; fail "e2e/$name (rc=$rc, $nbad checks failed)" "$log"
      grep '^check FAILED' "$log" | head -5
    else
      pass $((nok > 0 ? nok : 1)); echo "ok   e2e/$name ($nok checks)"
      rm -rf "$work"
    fi
  done
}

run_fuzz() {
  for exe in build-fuzz/fuzz_*; do
    [[ -x "$exe" && "$exe" != *.o && "$exe" != *.d ]] || continue
    name=$(basename "$exe")
    selected "$name" || continue
    corpus=tests/fuzz/corpus/${name#fuzz_}
    log="$log_dir/$name.log"
    scratch=$(mktemp -d)
    cp -r "$corpus"/. "$scratch"/ 2>/dev/null
    # Corpus replay, then a short bounded fuzzing run (new inputs go to scratch).
    ASAN_OPTIONS=detect_leaks=1 timeout 120 "$exe" -max_total_time=15 -timeout=10 \
      -rss_limit_mb=2048 "$scratch" >"$log" 2>&1
    rc=$?
    rm -rf "$scratch"
    if [[ $rc -ne 0 ]]; then fail "fuzz/$name (rc=$rc)" "$log"; else pass 1; echo "ok   fuzz/$name"; fi
  done
}

for s in "${suites[@]}"; do "run_$s"; done

echo
if [[ $failed -gt 0 ]]; then
  echo "failed tests:"; printf '  %s\n' "${failures[@]}"
fi
echo "$passed passed, $failed failed"
[[ $failed -eq 0 ]]
