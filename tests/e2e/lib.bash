# Helpers for end-to-end tests (sourced). Each check prints "check ok: ...",
# "check FAILED: ..." or "check skipped: REASON"; tests/run.sh counts them.
# Env: GS_BIN, GS_ROOT, GS_DATA_ROOT (the data root, tests/run.sh sets it:
# GS_DATA or the tree's data/; configs name files there as ${data}/...).
set -u
GS_BIN=${GS_BIN:-$GS_ROOT/bin/geosynth}
DATA=${GS_DATA_ROOT:-${GS_DATA:-$GS_ROOT/data}}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
e2e_failed=0

ok() { echo "check ok: $*"; }
bad() { echo "check FAILED: $*"; e2e_failed=1; }
skipped() { echo "check skipped: $*"; }

# need_data WHAT REL... : 0 when every REL (a path under the data root, as in
# ${data}/REL) is there. Otherwise 1, after one line "check skipped: WHAT:
# needs ${data}/REL, ... (fetched by `make data`)" naming the missing files that
# `make data` fetches, and a failed check for each missing file that is not in
# scripts/data-manifest.tsv (a file the repository itself should hold: never a
# skip). Use as   if need_data "castle runs" model-synthesis/.../castle.txt; then ...; fi
need_data() {
  local what=$1 rel missing=() have=0; shift
  for rel in "$@"; do
    [[ -r $DATA/$rel ]] && continue
    have=1
    if "$GS_ROOT/scripts/fetch-data.sh" --has "$rel"; then
      missing+=("\${data}/$rel")
    else
      bad "$what: $DATA/$rel is missing, and it is not a file \`make data\` fetches"
    fi
  done
  if [[ ${#missing[@]} -gt 0 ]]; then
    local list
    printf -v list '%s, ' "${missing[@]}"
    skipped "$what: needs ${list%, } (fetched by \`make data\`)"
  fi
  return $have
}

# need_config WHAT CONFIG: need_data for every ${data}/ path CONFIG names
# (lines "key = ${data}/REL" of an INI file, or lines "${data}/REL" of a list).
need_config() {
  local what=$1 cfg=$2 rels
  mapfile -t rels < <(sed -nE 's/^[^;#]*\$\{data\}\/([^;#]*[^;# ])[[:space:]]*([;#].*)?$/\1/p' "$cfg")
  [[ ${#rels[@]} -eq 0 ]] || need_data "$what" "${rels[@]}"
}

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

# golden ENGINE CONFIG: the digest tests/golden/digests.tsv pins for CONFIG.
golden() { awk -F'\t' -v e="$1" -v c="$2" '$1 == e && $2 == c { print $5; exit }' \
  "$GS_ROOT/tests/golden/digests.tsv"; }

digest_of() { /usr/bin/python3 -c 'import json,sys;print(json.load(open(sys.argv[1]))["digest"])' "$1/summary.json"; }

# Two "nodes" of the multi-node rehearsals (e2e/multinode, e2e/multinode_slurm):
# network namespace N1 (made by the caller: its failure means skip) and N2,
# made here, joined by a veth pair VA (in N1, PREFIX.1/24) and VB (in N2,
# PREFIX.2/24), loopback up. At exit both are removed with every process in
# them.
netns_pair() {
  netns_nodes=("$1" "$2")
  trap netns_pair_remove EXIT
  trap 'exit 1' INT TERM
  ip netns add "$2"
  ip link add "$3" type veth peer name "$4"
  ip link set "$3" netns "$1"
  ip link set "$4" netns "$2"
  ip -n "$1" addr add "$5.1/24" dev "$3"
  ip -n "$2" addr add "$5.2/24" dev "$4"
  for ns in "$1" "$2"; do ip -n "$ns" link set lo up; done
  ip -n "$1" link set "$3" up
  ip -n "$2" link set "$4" up
}
netns_pair_remove() {
  for ns in "${netns_nodes[@]}"; do
    pids=$(ip netns pids "$ns" 2>/dev/null)
    [[ -n $pids ]] && kill -KILL $pids 2>/dev/null
    ip netns del "$ns" 2>/dev/null
  done
}

finish() { exit $e2e_failed; }
