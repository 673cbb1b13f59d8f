#!/usr/bin/env bash
# Atomic checkpoints survive SIGKILL at any moment (src/io/h5_file.c).
#
# tests/mpi/h5_ckpt_loop writes ~24 MiB checkpoints in a loop (checkpoint k
# holds data that is a function of k and attribute k), resuming from the
# last one. It is killed with SIGKILL at 22 pseudo-random moments (most land
# mid-write: writing one takes most of the loop), as a single process and
# every fourth time as a 2-rank mpirun job whose ranks are all killed. After
# every kill checkpoint.h5 must open, validate, match its own k, and k must
# never go backwards; the next run must cope with the leftover .tmp.
# Runs in a scratch directory (tests/run.sh); env GS_BUILD or GS_ROOT.
set -u
LOOP=${GS_BUILD:-${GS_ROOT:-.}/build}/tests/mpi/h5_ckpt_loop
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1
export OMPI_MCA_btl=${OMPI_MCA_btl:-self,vader,tcp} OMPI_MCA_btl_vader_single_copy_mechanism=none
KILLS=${KILLS:-22}
MB=${MB:-24}
RANDOM=20240501 # reproducible delays

failed=0
ok() { echo "check ok: $*"; }
bad() { echo "check FAILED: $*"; failed=1; }

if [[ ! -x $LOOP ]]; then
  bad "helper $LOOP is not built (make tests-build)"
  exit 1
fi
dir=$PWD/run
mkdir -p "$dir"

if "$LOOP" write "$dir" "$MB" 1 >loop.log 2>&1 && "$LOOP" verify "$dir" | grep -q '^verified k=0$'; then
  ok "first checkpoint written and verified (k=0)"
else
  bad "first checkpoint"; cat loop.log; exit 1
fi

prev_k=0
mid_write=0
for ((i = 1; i <= KILLS; i++)); do
  rm -f "$dir"/pid.*
  np=1
  (( i % 4 == 0 )) && np=2
  if [[ $np -eq 1 ]]; then
    "$LOOP" write "$dir" "$MB" 0 >>loop.log 2>&1 &
  else
    mpirun -np 2 "$LOOP" write "$dir" "$MB" 0 >>loop.log 2>&1 &
  fi
  job=$!
  # Time the kill from the moment every rank is up (past MPI start-up).
  for ((t = 0; t < 200; t++)); do
    n=$(ls "$dir"/pid.* 2>/dev/null | wc -l)
    [[ $n -ge $np ]] && break
    sleep 0.05
  done
  delay_ms=$((RANDOM % 1200 + 30))
  sleep "$(printf '%d.%03d' $((delay_ms / 1000)) $((delay_ms % 1000)))"
  pids=$(cat "$dir"/pid.* 2>/dev/null)
  [[ -z "$pids" ]] && pids=$job
  kill -KILL $pids 2>/dev/null
  # mpirun notices its ranks died and exits; give it a bounded time.
  for ((t = 0; t < 100; t++)); do
    kill -0 "$job" 2>/dev/null || break
    sleep 0.1
  done
  kill -0 "$job" 2>/dev/null && kill -KILL "$job" 2>/dev/null
  wait "$job" 2>/dev/null
  tmp=no
  if [[ -e $dir/checkpoint.h5.tmp ]]; then
    tmp=yes
    mid_write=$((mid_write + 1))
  fi
  out=$("$LOOP" verify "$dir" 2>&1)
  k=$(sed -n 's/^verified k=\([0-9]*\)$/\1/p' <<<"$out")
  if [[ -z "$k" ]]; then
    bad "kill $i (np=$np, after ${delay_ms} ms): checkpoint.h5 does not verify: $out"
  elif (( k < prev_k )); then
    bad "kill $i: checkpoint went back from k=$prev_k to k=$k"
  else
    ok "kill $i (np=$np, after ${delay_ms} ms, .tmp left: $tmp): checkpoint.h5 valid, data match k=$k"
    prev_k=$k
  fi
done

if (( mid_write > 0 )); then
  ok "$mid_write of $KILLS kills landed mid-write (a .tmp was left behind)"
else
  bad "no kill landed mid-write: the test did not exercise interrupted writes"
fi
if (( prev_k > 0 )); then
  ok "the loop made progress across kills (last k=$prev_k)"
else
  bad "no checkpoint was ever completed after the first"
fi

# A clean run after all that: a stale .tmp must not get in its way.
[[ -e $dir/checkpoint.h5.tmp ]] || printf 'stale' >"$dir/checkpoint.h5.tmp"
if "$LOOP" write "$dir" "$MB" 1 >>loop.log 2>&1 &&
   out=$("$LOOP" verify "$dir") && [[ "$out" == "verified k=$((prev_k + 1))" ]] &&
   [[ ! -e $dir/checkpoint.h5.tmp ]]; then
  ok "a run after the kills resumes at k=$((prev_k + 1)) over the stale .tmp and leaves none"
else
  bad "run after the kills: ${out:-no output}"; tail -5 loop.log
fi
exit $failed
