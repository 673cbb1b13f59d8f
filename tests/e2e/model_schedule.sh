# End-to-end: the model engine's result does not depend on the order the
# parallel scheduler runs regions in, nor on where a run is killed.
# Regions of different colours run at once when they do not interact
# (gs_model_regions_interact); a pair that interacts but is not declared so
# gives a digest that depends on timing. Seen in CI as a flaky "resume"
# digest (e2e/model kill -9 + resume, e2e/model_features city-10x): at np 2
# about 1 uninterrupted run in 7 differed, because the resemblance window
# (w = 2) reads the cells of a region touching only at a corner.
# The test hook GS_FLOW_PICK=random:SEED makes each rank run a random ready
# region of its share instead of the rule's (src/par/regions_flow.c): any
# order the conflict lists allow, even at one rank, so a missing conflict
# shows without depending on load. With the corner term of box_reads
# removed, 3 of the 8 one-rank seeds here gave another digest.
# Then kill -9 at instants spread over the whole run (checkpoint after every
# region), resumed at np 1, 2, 3 in turn: every digest the uninterrupted one.
# About 80 s here.
source "$GS_ROOT/tests/e2e/lib.bash"
ESCH=$DATA/model-synthesis/debroglie-samples-merrell/escheresque.csv
cat > sched.ini <<EOF
[model]
example = $ESCH
size = 40x40x10
region = 10x10x0
EOF

run_gs 0 model -c sched.ini -o ref --set model.schedule_log=true
expect_rc 0 "escheresque 40x40x10 in 10x10 regions (49 regions, resemblance w = 2), np 1"
ref=$(digest_of ref)

# --- any order the conflicts allow ---------------------------------------------
same=0
for s in 1 2 3 4 5 6 7 8; do
  GS_FLOW_PICK=random:$s run_gs 0 model -c sched.ini -o pick1_$s
  d=$(digest_of pick1_$s 2>/dev/null)
  [[ $rc -eq 0 && $d == "$ref" ]] && same=$((same + 1)) || echo "  np 1 random schedule $s: digest $d (rc $rc)"
done
[[ $same -eq 8 ]] && ok "np 1, 8 random region schedules: digest $ref every time" \
  || bad "np 1: $((8 - same)) of 8 random region schedules changed the digest (a missing conflict)"
same=0
for s in 1 2 3; do
  for np in 2 3; do
    GS_FLOW_PICK=random:$s run_gs $np model -c sched.ini -o pick${np}_$s
    d=$(digest_of pick${np}_$s 2>/dev/null)
    [[ $rc -eq 0 && $d == "$ref" ]] && same=$((same + 1)) || echo "  np $np random schedule $s: digest $d (rc $rc)"
  done
done
[[ $same -eq 6 ]] && ok "np 2 and 3, 3 random region schedules each: digest $ref every time" \
  || bad "np 2/3: $((6 - same)) of 6 random region schedules changed the digest"
same=0
for t in 1 2 3 4; do
  run_gs 2 model -c sched.ini -o plain2_$t --set model.schedule_log=$([[ $t == 1 ]] && echo true || echo false)
  d=$(digest_of plain2_$t 2>/dev/null)
  [[ $rc -eq 0 && $d == "$ref" ]] && same=$((same + 1)) || echo "  np 2 run $t: digest $d (rc $rc)"
done
[[ $same -eq 4 ]] && ok "np 2, 4 plain runs: digest $ref every time" \
  || bad "np 2: $((4 - same)) of 4 plain runs gave another digest"

# --- the schedule figures (schedule_* metrics) --------------------------------------
# analysis/model_schedule.py recomputes them from schedule.jsonl (each region's
# CPU seconds, rank, order and the regions it waited for) and must agree with
# the engine's; then what must hold whatever the machine's load: no 2-rank
# schedule beats 2x, the dataflow's rule and this run's own schedule cannot
# beat the bound, one rank's replay is 1x, and the dataflow's rule on 2 ranks
# comes within 15% of the bound. The issue's 1.8x is the benchmark's figure
# (tests/bench/model_scaling.sh, the 10x configs); these 49 regions take ~2 ms
# each, so their measured CPU seconds are noisy (a clean-checkout CI measured
# the rule at 1.79x of a 2.00x bound). (With the waits dropped from
# the engine's longest chain the recomputed figure differs: check fails.)
for r in ref plain2_1; do
  out=$(/usr/bin/python3 "$GS_ROOT/analysis/model_schedule.py" $r --check 2>&1)
  if [[ $? -eq 0 ]] && msg=$(/usr/bin/python3 - "$out" $r <<'EOF2'
import json, sys
f = json.loads(sys.argv[1])
b, p, r = (f["schedule_speedup_" + k] for k in ("bound_2ranks", "policy_2ranks", "replay"))
assert f["regions"] == 49, f
assert 1 <= b <= 2 + 1e-9 and p <= b + 1e-9 and r <= b + 1e-9, f
assert sys.argv[2] != "ref" or abs(r - 1) < 1e-9, f
assert p >= 0.85 * b, f
print(f"bound {b:.3f}x, the rule on 2 ranks {p:.3f}x, this run's schedule {r:.3f}x")
EOF2
  ); then ok "$r: schedule figures recomputed from schedule.jsonl agree: $msg"
  else bad "$r: schedule figures wrong: $out"; fi
done

# --- the jittered region plan (model.region_jitter, castle-10x.ini) ------------------
# Staggered cuts give each row of regions its own x edges: the figures must still be
# recomputable (the 2-rank simulation once gave up when both ranks were free and only
# the second rank's regions were ready: the engine wrote no schedule_* metrics and
# analysis/model_schedule.py stopped with an error), and any order the conflicts allow
# gives one digest (a jittered plan's colours must keep interacting regions apart).
JIT=(--set model.overlap=0 --set model.region_jitter=3 --set run.seed=2)
run_gs 0 model -c sched.ini -o jit_ref --set model.schedule_log=true "${JIT[@]}"
expect_rc 0 "escheresque 40x40x10, 10x10 regions jittered by 3, seed 2, np 1"
jref=$(digest_of jit_ref)
out=$(/usr/bin/python3 "$GS_ROOT/analysis/model_schedule.py" jit_ref --check 2>&1)
[[ $? -eq 0 ]] && grep -q '"check": "ok"' <<<"$out" \
  && ok "jittered plan: schedule figures recomputed from schedule.jsonl agree with the engine's" \
  || bad "jittered plan: schedule figures missing or wrong: $out"
same=0
for s in 1 2 3; do
  for np in 1 2; do
    GS_FLOW_PICK=random:$s run_gs $np model -c sched.ini -o jit${np}_$s "${JIT[@]}"
    d=$(digest_of jit${np}_$s 2>/dev/null)
    [[ $rc -eq 0 && $d == "$jref" ]] && same=$((same + 1)) || echo "  jittered np $np random schedule $s: digest $d (rc $rc)"
  done
done
[[ $same -eq 6 ]] && ok "jittered plan, np 1 and 2, 3 random region schedules each: digest $jref every time" \
  || bad "jittered plan: $((6 - same)) of 6 random region schedules changed the digest"

# --- the pick rule on castle-10x (#18: >= 1.8x with two ranks) ---------------------
# castle-10x (seed 1: 63 regions of ~1 ms, two of 4 and 6 tries taking 10-19 ms) is where
# the rule matters: lowest position of the own share first (k mod 2) left both long
# regions to rank 1, one after the other: 1.75-1.86x on 2 ranks in the regions' CPU
# seconds against a 2.00x bound; most dependents first, a busy rank's share in the
# same choice, gives 1.99x (src/par/regions_flow.c). So within 5% of the bound.
if need_config "castle-10x pick rule" "$GS_ROOT/configs/model/castle-10x.ini"; then
  run_gs 0 model -c "$GS_ROOT/configs/model/castle-10x.ini" -o castle --set model.schedule_log=true \
    --set model.mesh=none --set model.preview=false --set model.vox=false
  out=$(/usr/bin/python3 "$GS_ROOT/analysis/model_schedule.py" castle --check 2>&1)
  if [[ $rc -eq 0 ]] && msg=$(/usr/bin/python3 - "$out" <<'EOF2'
import json, sys
f = json.loads(sys.argv[1])
b, p = f["schedule_speedup_bound_2ranks"], f["schedule_speedup_policy_2ranks"]
assert f["check"] == "ok" and p >= 0.95 * b, f
print(f"bound {b:.3f}x, the rule on 2 ranks {p:.3f}x")
EOF2
  ); then ok "castle-10x: the rule within 5% of the 2-rank bound: $msg"
  else bad "castle-10x: the rule on 2 ranks is not within 5% of the bound (rc $rc): $out"; fi
fi

# --- tries that replay (castle-10x, solver.c run_box) --------------------------------
# With resemblance at the minimum distance nearly every choice has one closest
# neighbourhood, so the tries of a region in the author's scan replayed one search: on 14
# of castle-10x's seeds 1-30 one region failed 13-20 tries (24 with the split sub-boxes)
# and held 44-87% of the synthesis CPU (no 2-rank schedule beat 1.12-1.52x). Try k now
# scans from corner k mod 4 of its box: at most 3 tries on seeds 1-30. Seeds 6, 13, 16:
# 24, 16, 24 tries before; at most 4 (one per corner) here. (With every try from the
# author's corner: check fails.)
if need_config "castle-10x tries" "$GS_ROOT/configs/model/castle-10x.ini"; then
  worst=""
  for s in 6 13 16; do
    run_gs 0 model -c "$GS_ROOT/configs/model/castle-10x.ini" -o tries_$s --set run.seed=$s \
      --set model.schedule_log=true --set model.mesh=none --set model.preview=false --set model.vox=false
    [[ $rc -eq 0 ]] || { worst="$worst seed $s: rc $rc;"; continue; }
    worst="$worst $(/usr/bin/python3 -c 'import json, sys
r = [json.loads(l) for l in open(sys.argv[1] + "/schedule.jsonl")]
m = max(r, key=lambda x: x["attempts"])
print("seed %s: %d tries (region %d)%s;" % (sys.argv[2], m["attempts"], m["id"], "" if m["attempts"] <= 4 else " TOO MANY"))' tries_$s $s)"
  done
  [[ $worst != *TOO* && $worst != *rc* ]] && ok "castle-10x: no region needs more than 4 tries:$worst" \
    || bad "castle-10x: a region needs more than 4 tries (tries replaying one search):$worst"
fi

# --- kill -9 at instants spread over the run, resume at another np --------------
# the run's length from the reference's synthesis phase (np 1: an upper bound for np 2)
span_ms=$(/usr/bin/python3 -c 'import json,sys
ph=[json.loads(l) for l in open(sys.argv[1]) if "\"synthesis\"" in l][-1]
print(int(1000*ph["seconds"]["max"]))' ref/metrics.jsonl)
K=10 resumed=0 same=0
for ((t = 0; t < K; t++)); do
  d=kill_$t; rm -rf $d
  mpirun -np 2 "$GS_BIN" -q model -c sched.ini -o $d --set run.checkpoint_every=1 >$d.log 2>&1 &
  job=$!
  for ((i = 0; i < 500; i++)); do [[ -s $d/checkpoint.h5 || -s $d/summary.json ]] && break; sleep 0.01; done
  ms=$((span_ms * t / K))
  sleep "$(printf '%d.%03d' $((ms / 1000)) $((ms % 1000)))"
  pkill -KILL -P "$(pgrep -d, -P $job)" 2>/dev/null # the ranks (children of mpirun's children)
  pkill -KILL -P $job 2>/dev/null
  kill -KILL $job 2>/dev/null; wait $job 2>/dev/null
  np=$((t % 3 + 1))
  if [[ ! -s $d/summary.json ]]; then
    resumed=$((resumed + 1))
    if ((t % 2)); then GS_FLOW_PICK=random:$t run_gs $np resume $d; else run_gs $np resume $d; fi
  fi
  g=$(digest_of $d 2>/dev/null)
  [[ $g == "$ref" ]] && same=$((same + 1)) || echo "  kill at ${ms} ms, resume at np $np: digest $g (rc ${rc:-})"
done
[[ $same -eq $K ]] && ok "kill -9 at $K instants over ${span_ms} ms, resumed at np 1-3: digest $ref every time" \
  || bad "kill -9 + resume: $((K - same)) of $K digests differ from the uninterrupted run"
[[ $resumed -ge $((K / 2)) ]] && ok "$resumed of $K kills landed before the end (resumed from a checkpoint)" \
  || bad "only $resumed of $K kills landed before the run ended: the kill loop tests little"
finish
