# End-to-end: a failure on one rank in the middle of a points synthesis
# never leaves the other ranks hung (STYLE.md). With the test-only hook
# GS_FAIL_RANK=R GS_FAIL_POINTS_AT=SITE@K (src/points/engine_parallel.c, "fault
# injection") rank R fails at SITE while placing patch K of quick.ini at
# np=2. Every case must: end within the timeout, exit with the failure's
# code, print the cause once naming the failing rank, keep the last good
# checkpoint (written after patch K), and resuming it without the fault
# must give the uninterrupted digest.
source "$GS_ROOT/tests/e2e/lib.bash"
CFG=$GS_ROOT/configs/points/quick.ini
LIMIT=60
K=20

run_gs 2 points -c "$CFG" -o ref
expect_rc 0 "quick.ini at np=2 without a fault"
ref=$(digest_of ref 2>/dev/null)

# run_fault NP RANK SITE DIR: like run_gs, under a timeout of LIMIT seconds.
run_fault() {
  local o e start
  o=$(mktemp) e=$(mktemp)
  start=$(date +%s)
  GS_FAIL_RANK=$2 GS_FAIL_POINTS_AT=$3@$K timeout "$LIMIT" mpirun -np "$1" "$GS_BIN" points \
    -c "$CFG" -o "$4" --set run.checkpoint_every=5 >"$o" 2>"$e"
  rc=$?
  secs=$(($(date +%s) - start))
  out=$(cat "$o") err=$(cat "$e")
  rm -f "$o" "$e"
}

# SITE CODE NAME RANK: a collective failure (the status travels in an
# exchange) is reported once by rank 0 as "rank R failed: ..."; a local one
# by the failing rank with its "[rank R]" prefix, then MPI_Abort.
for spec in "map-fn 8 internal 1 collective" "search-scan 8 internal 1 collective" \
            "search-scan 8 internal 0 collective" "map-alloc 5 out.of.memory 1 local" \
            "search-merge 5 out.of.memory 1 local" "step 7 library 1 local" \
            "step 7 library 0 local"; do
  read -r site code name frank kind <<<"$spec"
  what="np=2, rank $frank fails at $site of patch $K"
  dir="fail-$site-$frank"
  run_fault 2 "$frank" "$site" "$dir"
  if [[ $rc -eq 124 ]]; then
    bad "$what: hung (killed after ${LIMIT}s)"
    continue
  fi
  ok "$what: ends after ${secs}s"
  expect_rc "$code" "$what: exit code $code"
  cause="points: injected failure at $site of patch $K"
  n=$(grep -cF "$cause" <<<"$err")
  if [[ $kind == collective ]]; then
    if [[ $frank -eq 0 ]]; then
      m=$(grep -cE "^error \($name\): $cause" <<<"$err")
    else
      # agreed by every rank: reported once, by the rank it came from (#24 item 2)
      m=$(grep -cE "^\[rank $frank\] error \($name\): $cause" <<<"$err")
    fi
    grep -q "MPI_ABORT" <<<"$err" && bad "$what: a collective failure went through MPI_Abort"
  else
    m=$(grep -cE "^\[rank $frank\] error \($name\): $cause" <<<"$err")
  fi
  [[ $n -eq 1 && $m -eq 1 ]] && ok "$what: the cause is printed once, naming rank $frank ($kind)" ||
    bad "$what: cause printed $n times, $m in the expected form; stderr: $(grep -iE 'error|abort' <<<"$err" | head -6)"
  [[ ! -e $dir/summary.json ]] && ok "$what: no summary.json" || bad "$what: summary.json written"
  run_gs 0 inspect "$dir/checkpoint.h5"
  expect_out "@cursor = $K" "$what: the last good checkpoint (patch $K) is intact"
  run_gs 1 resume "$dir"
  expect_rc 0 "$what: resume without the fault"
  d=$(digest_of "$dir" 2>/dev/null)
  [[ -n "$ref" && "$d" == "$ref" ]] && ok "$what: resumed digest = uninterrupted ($d)" ||
    bad "$what: resumed digest $d != uninterrupted $ref"
done

# A local failure of one rank while every rank generates the example (the
# generator's agreements, before any checkpoint): all ranks stop, the cause
# is reported once by rank 0 naming the failing rank, nothing is written.
for frank in 1 0; do
  what="np=2, rank $frank fails while generating the example"
  o=$(mktemp) e=$(mktemp); start=$(date +%s)
  GS_FAIL_RANK=$frank GS_FAIL_POINTS_AT=generate timeout "$LIMIT" mpirun -np 2 "$GS_BIN" points \
    -c "$CFG" -o "gen-$frank" >"$o" 2>"$e"
  rc=$?; secs=$(($(date +%s) - start)); out=$(cat "$o") err=$(cat "$e"); rm -f "$o" "$e"
  if [[ $rc -eq 124 ]]; then bad "$what: hung (killed after ${LIMIT}s)"; continue; fi
  ok "$what: ends after ${secs}s"
  expect_rc 8 "$what: exit code 8"
  cause="points: injected failure at generate"
  if [[ $frank -eq 0 ]]; then pat="^error \(internal\): $cause"; else pat="^\[rank $frank\] error \(internal\): $cause"; fi
  n=$(grep -cF "$cause" <<<"$err"); m=$(grep -cE "$pat" <<<"$err")
  [[ $n -eq 1 && $m -eq 1 ]] && ok "$what: the cause is printed once, naming rank $frank" ||
    bad "$what: cause printed $n times, $m in the expected form; stderr: $(grep -iE 'error|abort' <<<"$err" | head -6)"
  grep -q "MPI_ABORT" <<<"$err" && bad "$what: went through MPI_Abort" || ok "$what: no MPI_Abort (every rank returned it)"
  [[ ! -e gen-$frank/summary.json && ! -e gen-$frank/points.ply ]] && ok "$what: no outputs" || bad "$what: outputs written"
done

# A bad hook value is a usage error on every rank, reported once.
GS_FAIL_RANK=1 GS_FAIL_POINTS_AT=nowhere run_gs 2 points -c "$CFG" -o badhook
expect_rc 1 "unknown GS_FAIL_POINTS_AT site"
n=$(grep -c "GS_FAIL_POINTS_AT = 'nowhere'" <<<"$err")
[[ $n -eq 1 ]] && ok "unknown site reported once" || bad "unknown site reported $n times"

finish
