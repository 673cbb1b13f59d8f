# Helpers for end-to-end tests (sourced). Each check prints "check ok: ..." or
# "check FAILED: ..."; tests/run.sh counts them. Env: GS_BIN, GS_ROOT, GS_SHARED.
set -u
GS_BIN=${GS_BIN:-$GS_ROOT/bin/geosynth}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
e2e_failed=0

ok() { echo "check ok: $*"; }
bad() { echo "check FAILED: $*"; e2e_failed=1; }

# run_gs NP ARGS... : runs geosynth (under mpirun when NP > 0), capturing
# stdout in $out, stderr in $err and the exit code in $rc.
run_gs() {
  local np=$1; shift
  local o e
  o=$(mktemp) e=$(mktemp)
  if [[ $np -gt 0 ]]; then
    timeout 600 mpirun -np "$np" "$GS_BIN" "$@" >"$o" 2>"$e"
  else
    timeout 600 "$GS_BIN" "$@" >"$o" 2>"$e"
  fi
  rc=$?
  out=$(cat "$o") err=$(cat "$e")
  rm -f "$o" "$e"
}

# expect_rc CODE "what" : last run_gs exit code must be CODE.
expect_rc() {
  if [[ $rc -eq $1 ]]; then ok "$2 (exit $rc)"; else bad "$2: expected exit $1, got $rc; stderr: ${err:0:600}"; fi
}

# expect_err "text" "what" : last stderr must contain text.
expect_err() {
  if grep -qF -- "$1" <<<"$err"; then ok "$2"; else bad "$2: stderr lacks '$1'; stderr: ${err:0:600}"; fi
}

expect_out() {
  if grep -qF -- "$1" <<<"$out"; then ok "$2"; else bad "$2: stdout lacks '$1'; stdout: ${out:0:600}"; fi
}

# No crash: sanitizer reports, segfaults and aborts are never acceptable.
expect_no_crash() {
  if grep -qE "AddressSanitizer|runtime error:|Segmentation fault|core dumped|signal [0-9]+|Assertion" <<<"$err"; then
    bad "$1: crashed: ${err:0:600}"
  elif [[ $rc -ge 128 ]]; then
    bad "$1: killed by a signal (exit $rc)"
  else
    ok "$1: no crash"
  fi
}

digest_of() { /usr/bin/python3 -c 'import json,sys;print(json.load(open(sys.argv[1]))["digest"])' "$1/summary.json"; }

finish() { exit $e2e_failed; }
