#!/usr/bin/env bash
# geosynth test runner (called by `make test`; see tests/README.md).
#
# Suites: unit (cmocka programs), mpi (programs run under mpirun at each rank
# count in NP; every "digest: NAME HEX" line they print must be identical
# across rank counts), e2e (tests/e2e/*.sh), fuzz (libFuzzer targets over
# their seed corpus plus a short bounded run).
# Usage: tests/run.sh [unit|mpi|e2e|fuzz ...]   env: BUILD BIN NP T VALGRIND GS_DATA
# T: words separated by blanks or commas; a test runs when its name contains
# one of them, or when a word "SUITE/NAME" names it exactly (e.g. "e2e/model").
# Counts: one per cmocka case, MPI rank count, e2e "check ok:" line, fuzz
# target; a case that needs fetched data which is absent is skipped with its
# reason (cmocka skip(), e2e "check skipped: REASON" lines; tests/README.md),
# never counted as passed. Ends with one line "N passed, N failed, N skipped"
# and exits non-zero on any failure. The skipped tests and their reasons are
# also in $BUILD/test-logs/skipped.tsv (SUITE/NAME, tab, reason).
set -u
# GS_DATA (the data root, see include/geosynth/data.h) is relative to the
# caller's directory; tests run elsewhere, so make it absolute first.
if [[ -n ${GS_DATA:-} && $GS_DATA != /* ]]; then export GS_DATA=$PWD/$GS_DATA; fi
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
# The data root the tests look in: GS_DATA, else this tree's data/ (what
# bin/geosynth built here uses by default). GS_DATA stays unset unless given,
# so the built-in default is what the tests exercise.
export GS_DATA_ROOT=${GS_DATA:-$PWD/data}
# Sanitizer builds: leaks inside MPI/HDF5 start-up are theirs (tests/lsan.supp).
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$PWD/tests/lsan.supp:print_suppressions=0}
# (Open MPI 4.1 unloads its plugins at MPI_Finalize; sanitizer builds link
# tests/san/nodlclose.c so their leaks keep a module name the suppressions match.)
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}

passed=0
failed=0
skipped=0
failures=()
skips=()
log_dir=$PWD/$BUILD/test-logs
mkdir -p "$log_dir"
: >"$log_dir/skipped.tsv"

# count PATTERN FILE: lines of FILE matching the extended regex PATTERN, always
# a number (0 when FILE is missing or unreadable). `grep -c` alone prints
# nothing for a missing file, and "passed + " was then a bash syntax error that
# abandoned the remaining suites (tests/README.md).
count() { local n; n=$(grep -Ec -- "$1" "$2" 2>/dev/null); echo "${n:-0}"; }
# last_number PATTERN FILE: the number at the end of the last match, or 0.
last_number() { local n; n=$(grep -Eo -- "$1" "$2" 2>/dev/null | grep -Eo '[0-9]+$' | tail -1); echo "${n:-0}"; }
is_count() { [[ $1 =~ ^[0-9]+$ ]]; }
pass() { is_count "$1" && passed=$((passed + $1)); }
fail() { failed=$((failed + 1)); failures+=("$1"); echo "FAIL: $1 (log: $2)"; }
# skip NAME N LOG: N skipped cases of NAME; reasons from its "check skipped:" lines.
skip() {
  is_count "$2" && [[ $2 -gt 0 ]] || return 0
  skipped=$((skipped + $2))
  local reasons
  reasons=$(grep -E '^check skipped: ' "$3" 2>/dev/null | sed 's/^check skipped: //' | sort -u)
  [[ -n $reasons ]] || reasons="(no reason given)"
  while IFS= read -r r; do
    skips+=("$1: $r")
    printf '%s\t%s\n' "$1" "$r" >>"$log_dir/skipped.tsv"
  done <<<"$reasons"
}
# selected SUITE NAME: whether T asks for this test.
selected() {
  [[ -z "$T" ]] && return 0
  local w
  for w in ${T//,/ }; do
    if [[ $w == */* ]]; then [[ "$1/$2" == "$w" ]] && return 0
    elif [[ "$2" == *"$w"* ]]; then return 0; fi
  done
  return 1
}

run_unit() {
  for exe in "$BUILD"/tests/unit/test_*; do
    [[ -x "$exe" ]] || continue
    name=$(basename "$exe")
    selected unit "$name" || continue
    log="$log_dir/$name.log"
    if [[ -n "$VALGRIND" ]]; then
      cmd=(valgrind --quiet --error-exitcode=99 --leak-check=full --errors-for-leak-kinds=definite --num-callers=50
           --suppressions=$GS_ROOT/tests/valgrind.supp "$GS_ROOT/$exe")
    else
      cmd=("$GS_ROOT/$exe")
    fi
    (cd tests && "${cmd[@]}") >"$log" 2>&1
    rc=$?
    ok=$(last_number '\[  PASSED  \] [0-9]+' "$log")
    nskip=$(last_number '\[  SKIPPED \] [0-9]+' "$log")
    bad=$(grep -Eo '\[  FAILED  \] [0-9]+ test' "$log" 2>/dev/null | grep -Eo '[0-9]+' | tail -1)
    pass "$ok"
    skip "unit/$name" "$nskip" "$log"
    if [[ $rc -ne 0 || -n "$bad" ]]; then
      fail "unit/$name (${bad:-?} failed, rc=$rc)" "$log"
    elif [[ $ok -eq 0 && $nskip -eq 0 ]]; then
      fail "unit/$name (no cmocka summary in its output)" "$log"
    else
      echo "ok   unit/$name ($ok cases$([[ $nskip -gt 0 ]] && echo ", $nskip skipped"))"
    fi
  done
}

run_mpi() {
  for exe in "$BUILD"/tests/mpi/*; do
    [[ -x "$exe" && ! -d "$exe" ]] || continue
    name=$(basename "$exe")
    selected mpi "$name" || continue
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
    selected e2e "$name" || continue
    log="$log_dir/e2e-$name.log"
    if ! work=$(mktemp -d "${TMPDIR:-/tmp}/gs-e2e-$name.XXXX"); then
      fail "e2e/$name (cannot create a scratch directory)" "$log"; continue
    fi
    (cd "$work" && timeout 900 bash "$GS_ROOT/$script") >"$log" 2>&1
    rc=$?
    # An e2e script counts its own checks with lines "check ok: ...",
    # "check FAILED: ..." and "check skipped: REASON" (tests/README.md).
    nok=$(count '^check ok' "$log")
    nbad=$(count '^check FAILED' "$log")
    nskip=$(count '^check skipped: ' "$log")
    skip "e2e/$name" "$nskip" "$log"
    if [[ ! -r $log ]]; then
      fail "e2e/$name (rc=$rc; its log $log could not be written or read)" "$log"
    elif [[ $rc -ne 0 || $nbad -ne 0 ]]; then
      pass "$nok"; fail "e2e/$name (rc=$rc, $nbad checks failed)" "$log"
      grep '^check FAILED' "$log" | head -5
    else
      # a script that reports no check at all counts once, unless all it did was skip
      pass $((nok > 0 || nskip > 0 ? nok : 1))
      echo "ok   e2e/$name ($nok checks$([[ $nskip -gt 0 ]] && echo ", $nskip skipped"))"
      rm -rf "$work"
    fi
  done
}

run_fuzz() {
  for exe in build-fuzz/fuzz_*; do
    [[ -x "$exe" && "$exe" != *.o && "$exe" != *.d ]] || continue
    name=$(basename "$exe")
    selected fuzz "$name" || continue
    corpus=tests/fuzz/corpus/${name#fuzz_}
    log="$log_dir/$name.log"
    scratch=$(mktemp -d)
    cp -r "$corpus"/. "$scratch"/ 2>/dev/null
    # Corpus replay, then a short bounded fuzzing run (new inputs go to scratch).
    # A fixed seed (FUZZ_SEED, default 1) walks the same inputs on every run, so a
    # commit's result does not depend on luck; FUZZ_SEED=0 draws a fresh one (campaigns).
    ASAN_OPTIONS=detect_leaks=1 timeout $(( ${FUZZ_SECONDS:-15} + 105 )) "$exe" -max_total_time="${FUZZ_SECONDS:-15}" -timeout=10 \
      -seed="${FUZZ_SEED:-1}" -artifact_prefix="$log_dir/$name-" \
      -rss_limit_mb=2048 "$scratch" >"$log" 2>&1
    rc=$?
    rm -rf "$scratch"
    if [[ $rc -ne 0 ]]; then fail "fuzz/$name (rc=$rc)" "$log"; else pass 1; echo "ok   fuzz/$name"; fi
  done
}

for s in "${suites[@]}"; do
  if declare -F "run_$s" >/dev/null; then "run_$s"; else fail "unknown suite '$s' (unit, mpi, e2e, fuzz)" "-"; fi
done

echo
if [[ ${#skips[@]} -gt 0 ]]; then
  echo "skipped (the data they need is not under the data root $GS_DATA_ROOT; \`make data\` fetches it):"
  printf '  %s\n' "${skips[@]}"
fi
if [[ $failed -gt 0 ]]; then
  echo "failed tests:"; printf '  %s\n' "${failures[@]}"
fi
echo "$passed passed, $failed failed, $skipped skipped"
[[ $failed -eq 0 ]]
