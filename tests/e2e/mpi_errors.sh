#!/usr/bin/env bash
# A rank that fails in the middle of a search or a region must not leave the
# others hung in a collective: mpirun ends within a timeout, non-zero, with
# the failing rank's message. Collective failures (gs_par_agree, and the
# search/region failures that psearch/regions make collective) exit with the
# error's code and print the message exactly once.
# Uses tests/mpi/abort_on_error (built by `make tests-build`).
set -u
GS_ROOT=${GS_ROOT:-$(cd "$(dirname "$0")/../.." && pwd)}
GS_BUILD=${GS_BUILD:-$GS_ROOT/build}
exe=$GS_BUILD/tests/mpi/abort_on_error
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1
export OMPI_MCA_btl=${OMPI_MCA_btl:-self,vader,tcp} OMPI_MCA_btl_vader_single_copy_mechanism=none
LIMIT=30
status=0

ok() { echo "check ok: $*"; }
bad() { echo "check FAILED: $*"; status=1; }

if [[ ! -x "$exe" ]]; then
  bad "$exe not built (run make tests-build)"
  exit 1
fi

# run NP MODE: sets rc, secs, out (stdout+stderr)
run() {
  local start end
  start=$(date +%s)
  out=$(timeout "$LIMIT" mpirun -np "$1" "$exe" "$2" 2>&1)
  rc=$?
  end=$(date +%s)
  secs=$((end - start))
  printf '%s\n' "---- np=$1 $2 (rc=$rc, ${secs}s)" "$out" | head -40
}

# A clean run first: the injection harness itself works.
run 4 none
[[ $rc -eq 0 ]] && ok "np=4 without failure exits 0" || bad "np=4 without failure exits $rc"

# Local failures: gs_fatal(err, 0) on one rank while the others wait in a collective.
for np in 2 4; do
  frank=$((np >= 3 ? 2 : np - 1))
  for mode in search-abort region-abort; do
    run "$np" "$mode"
    if [[ $rc -eq 124 ]]; then
      bad "np=$np $mode: hung (killed after ${LIMIT}s)"
      continue
    fi
    [[ $rc -ne 0 ]] && ok "np=$np $mode: mpirun exits non-zero ($rc) after ${secs}s" \
                    || bad "np=$np $mode: mpirun exits 0"
    n=$(grep -c "^\[rank $frank\] error (file format): abort_on_error: injected failure" <<<"$out")
    [[ $n -eq 1 ]] && ok "np=$np $mode: message printed once with the [rank $frank] prefix" \
                   || bad "np=$np $mode: '[rank $frank] error ... injected failure' printed $n times"
  done
done

# Collective failures: every rank exits with the code; the failing rank prints once.
for np in 2 4; do
  frank=$((np >= 3 ? 2 : np - 1))
  for spec in "search-collective 4 file format" "region-collective 4 file format" "agree 2 bad input"; do
    read -r mode code name <<<"$spec"
    run "$np" "$mode"
    if [[ $rc -eq 124 ]]; then
      bad "np=$np $mode: hung (killed after ${LIMIT}s)"
      continue
    fi
    [[ $rc -eq $code ]] && ok "np=$np $mode: exit code $code" \
                        || bad "np=$np $mode: exit code $rc, expected $code"
    n=$(grep -c "injected failure" <<<"$out")
    # agreed by every rank: reported once, by the rank it came from (#24 item 2)
    m=$(grep -c "^\[rank $frank\] error ($name): abort_on_error: injected failure" <<<"$out")
    [[ $n -eq 1 && $m -eq 1 ]] && ok "np=$np $mode: message printed once, naming rank $frank" \
                               || bad "np=$np $mode: message lines $n (naming rank $frank: $m), expected 1"
    grep -q "MPI_ABORT" <<<"$out" && bad "np=$np $mode: collective failure went through MPI_Abort"
  done
done
exit $status
