#!/usr/bin/env bash
# Resume after a kill at any instant (#25 item 2), every engine, every phase.
#
# Each engine's golden quick config runs at np 2 with a checkpoint every
# EVERY units (run.checkpoint_seconds=0: the checkpoints, hence the kill
# points, depend on the inputs alone). A first, uninterrupted run lists its
# kill points (the test hook GS_KILL_TRACE, include/geosynth/killpoint.h:
# phase edges, every safe point, every step of writing a checkpoint, an HDF5
# output, an atomic output file, summary.json) and must give the golden
# digest. Then KP trials per engine kill rank 0 with SIGKILL at one of those
# points (GS_KILL_AT=K; mpirun ends the other rank, as when a node dies):
# one point of every (phase, kind) class, the rest drawn at random from a
# fixed seed, so the same points are tested on every run. TIMER more trials
# per engine SIGKILL every process of the job at once after a delay drawn
# from the same seed over the uninterrupted run's wall time (instants inside
# computations, between kill points). Every killed run is resumed at np 1
# or 3 (`geosynth resume`: from the last checkpoint, or from start.ini when
# there is none yet) and must end with exit 0, the golden digest
# (tests/golden/digests.tsv), every output summary.json lists present and no
# *.tmp left in the run directory.
# Env: SEED (default 2025), SCALE (trials per engine = SCALE x the numbers
# below; default 1: 100 trials in all), ENGINES (default: all four).
source "$GS_ROOT/tests/e2e/lib.bash"
SEED=${SEED:-2025}
SCALE=${SCALE:-1}
# engine, config, checkpoint every N units, kill-point trials, timer trials
cases=("field configs/field/quick.ini 300 12 3" "points configs/points/quick.ini 8 12 3"
       "micro configs/micro/quick.ini 15 28 7" "model configs/model/demo.ini 8 28 7")
if ! need_config "model demo" "$GS_ROOT/configs/model/demo.ini"; then
  cases=("${cases[@]:0:3}")
fi

# kill_job PID: SIGKILL to mpirun PID, its children and theirs, all at once.
kill_job() {
  local pids
  pids="$1 $(pgrep -P "$1" | tr '\n' ' ')"
  for p in $pids; do pids+=" $(pgrep -P "$p" | tr '\n' ' ')"; done
  kill -KILL $pids 2>/dev/null
  wait "$1" 2>/dev/null
}

# after_kill DIR NP WHAT REF: resume DIR at NP ranks; one check for the trial.
after_kill() {
  local d=$1 np=$2 what=$3 ref=$4
  rm -f "$d/summary.json.seen"
  [[ -f $d/summary.json ]] && mv "$d/summary.json" "$d/summary.json.seen"
  run_gs "$np" resume "$d" </dev/null
  check_dir "$d" "$what; resumed at np $np" "$ref"
}

# check_dir DIR WHAT REF: the last run_gs finished DIR: one check.
check_dir() {
  local d=$1 what=$2 ref=$3
  local got left missing
  got=$(digest_of "$d" 2>/dev/null)
  left=$(cd "$d" && find . -name '*.tmp' | sort | tr '\n' ' ')
  missing=$(/usr/bin/python3 - "$d" <<'EOF' 2>&1
import json, os, sys
d = sys.argv[1]
try:
    outs = json.load(open(os.path.join(d, "summary.json")))["outputs"]
except Exception as e:
    print("no summary.json (%s)" % e); sys.exit()
print(" ".join(o["path"] for o in outs if not os.path.isfile(os.path.join(d, o["path"]))))
EOF
)
  if [[ $rc -eq 0 && $got == "$ref" && -z $left && -z $missing ]]; then
    ok "$what: digest $got = uninterrupted"
  else
    bad "$what: exit $rc, digest '$got' (expected $ref), *.tmp left: '${left}', outputs missing: '${missing}'; stderr: ${err:0:700}"
  fi
}

trial=0
for c in "${cases[@]}"; do
  read -r eng cfg every nkp ntimer <<<"$c"
  [[ -n ${ENGINES:-} && " $ENGINES " != *" $eng "* ]] && continue
  nkp=$((nkp * SCALE)) ntimer=$((ntimer * SCALE))
  ref=$(golden "$eng" "$cfg")
  sets=(--set run.checkpoint_seconds=0 --set "run.checkpoint_every=$every")
  d=trace-$eng; rm -rf "$d" "$d.tsv"
  t0=$(date +%s%N)
  GS_KILL_TRACE=$PWD/$d.tsv run_gs 2 "$eng" -c "$GS_ROOT/$cfg" -o "$d" "${sets[@]}"
  wall=$(( ($(date +%s%N) - t0) / 1000000 ))e-3
  got=$(digest_of "$d" 2>/dev/null)
  ncp=$(grep -c $'\tcheckpoint.h5.tmp created$' "$d.tsv" 2>/dev/null)
  if [[ $rc -eq 0 && $got == "$ref" && -s $d.tsv ]]; then
    ok "$eng: uninterrupted run at np 2 with $ncp checkpoints and the kill-point trace on: digest $got = golden, $(wc -l <"$d.tsv") kill points"
  else
    bad "$eng: uninterrupted traced run: exit $rc, digest '$got' (golden $ref): ${err:0:500}"
    continue
  fi
  # The plan: "kp K PHASE LABEL" and "timer SECONDS" lines, from SEED alone.
  /usr/bin/python3 - "$d.tsv" "$nkp" "$ntimer" "$SEED$eng" "$wall" >"plan-$eng" <<'EOF'
import random, sys
trace, nkp, ntimer, seed, wall = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4], float(sys.argv[5])
rows = [l.rstrip("\n").split("\t") for l in open(trace)]
def kind(label):
    if label.startswith("checkpoint"): return "checkpoint write"
    if label.startswith("safe point"): return "safe point"
    if label.startswith("phase"): return "phase edge"
    return "output write"
rng = random.Random(seed)
classes = {}
for k, phase, label in rows:
    classes.setdefault((phase, kind(label)), []).append(int(k))
picked = [rng.choice(classes[c]) for c in sorted(classes)]
rest = [int(r[0]) for r in rows if int(r[0]) not in picked]
picked += rng.sample(rest, max(0, min(len(rest), nkp - len(picked))))
for k in sorted(picked):
    _, phase, label = rows[k - 1]
    print("kp", k, phase, kind(label).replace(" ", "_"), label)
for _ in range(ntimer):
    print("timer", "%.2f" % rng.uniform(0.3, wall))
EOF
  classes=$(awk '$1 == "kp" { print $3 "/" $4 }' "plan-$eng" | LC_ALL=C sort -u | tr '\n' ' ')
  need=(start/output_write setup/phase_edge synthesis/safe_point synthesis/checkpoint_write
        output/phase_edge output/output_write summary/output_write)
  lack=""
  for n in "${need[@]}"; do [[ " $classes" == *" $n "* ]] || lack+=" $n"; done
  [[ -z $lack ]] && ok "$eng: $(grep -c '^kp' "plan-$eng") kill points planned, in every (phase, kind) of the run: $classes" \
    || bad "$eng: no kill point planned in$lack (planned: $classes)"
  while read -r what a phase kind label <&3; do
    trial=$((trial + 1))
    np=$((trial % 2 ? 1 : 3))
    d=kill-$eng-$trial; rm -rf "$d" "$d.tsv"
    if [[ $what == kp ]]; then
      GS_KILL_AT=$a GS_KILL_TRACE=$PWD/$d.tsv timeout 300 mpirun -x GS_KILL_AT -x GS_KILL_TRACE \
        -np 2 "$GS_BIN" "$eng" -c "$GS_ROOT/$cfg" -o "$d" "${sets[@]}" >"$d.log" 2>&1 </dev/null
      krc=$?
      last=$(tail -n 1 "$d.tsv" 2>/dev/null | cut -f1)
      if [[ $krc -eq 0 || $last != "$a" ]]; then
        bad "$eng trial $trial: kill point $a ($phase, $label) was not where the run died: exit $krc, last point ${last:-none}"
        continue
      fi
      what="$eng trial $trial: rank 0 killed at point $a of $(wc -l <"trace-$eng.tsv") ($phase, $label)"
      if [[ $phase == start && $label != "start.ini renamed" ]]; then
        # Killed before start.ini is in place: nothing records the config yet.
        run_gs "$np" resume "$d" </dev/null
        if [[ $rc -ne 3 ]] || ! grep -q "there is neither .*checkpoint.h5 nor .*start.ini" <<<"$err"; then
          bad "$what: resume: expected exit 3 naming checkpoint.h5 and start.ini, got $rc: ${err:0:500}"
          continue
        fi
        what+=", resume says start it again (exit 3); started again"
        run_gs "$np" "$eng" -c "$GS_ROOT/$cfg" -o "$d" "${sets[@]}" </dev/null
        check_dir "$d" "$what" "$ref"
      else
        after_kill "$d" "$np" "$what" "$ref"
      fi
    else
      mpirun -np 2 "$GS_BIN" "$eng" -c "$GS_ROOT/$cfg" -o "$d" "${sets[@]}" >"$d.log" 2>&1 </dev/null &
      job=$!
      sleep "$a"
      kill_job $job
      state="killed"
      [[ -f $d/summary.json ]] && state="finished before the kill"
      [[ -f $d/checkpoint.h5 ]] && state+=", a checkpoint on disk" || state+=", no checkpoint"
      after_kill "$d" "$np" "$eng trial $trial: every process killed after ${a} s ($state)" "$ref"
    fi
    rm -rf "$d" "$d.tsv" "$d.log"
  done 3<"plan-$eng"
done
echo "resume_anywhere: $trial kill trials"
finish
