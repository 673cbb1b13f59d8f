#!/usr/bin/env bash
# Resume after a kill before the first checkpoint (#25 item 2): a fresh run
# writes RUN_DIR/start.ini (engine + resolved config) before anything else;
# `geosynth resume RUN_DIR` with no checkpoint starts the run again from it
# (it used to stop with "checkpoint.h5: cannot open") and ends with the
# uninterrupted digest (tests/golden/digests.tsv). Every engine's quick
# config at np 2 with checkpoints off, every rank killed with SIGKILL at a
# random moment after start.ini appears, resumed at np 1 or 3.
# TRIALS=N kills per engine (default 1). Then the inputs' digests (below),
# also of files that input files name (a mesh list's meshes, tile-set tiles).
source "$GS_ROOT/tests/e2e/lib.bash"
TRIALS=${TRIALS:-1}
RANDOM=${SEED:-4242}
cases=("field configs/field/quick.ini" "points configs/points/quick.ini"
       "micro configs/micro/quick.ini" "model configs/model/demo.ini")
for c in "${cases[@]}"; do
  read -r eng cfg <<<"$c"
  ref=$(golden "$eng" "$cfg")
  for ((t = 1; t <= TRIALS; t++)); do
    d=k-$eng-$t; rm -rf "$d"
    mpirun -np 2 "$GS_BIN" "$eng" -c "$GS_ROOT/$cfg" -o "$d" --set run.checkpoint_seconds=0 >"$d.out" 2>&1 &
    job=$!
    for ((i = 0; i < 200; i++)); do [[ -f $d/start.ini ]] && break; sleep 0.02; done
    sleep "0.$((RANDOM % 8))"
    pkill -KILL -P "$(pgrep -d, -P $job)" 2>/dev/null # the ranks (children of mpirun's children)
    pkill -KILL -P $job 2>/dev/null
    kill -KILL $job 2>/dev/null; wait $job 2>/dev/null
    when=killed; [[ -f $d/summary.json ]] && when="finished before the kill"
    [[ -f $d/start.ini && ! -f $d/checkpoint.h5 ]] && ok "$eng trial $t: start.ini written, no checkpoint ($when)" \
      || bad "$eng trial $t: start.ini missing or a checkpoint written with checkpoints off"
    rm -f "$d/summary.json"
    np=$((t % 2 ? 1 : 3))
    run_gs $np resume "$d"
    got=$(digest_of "$d" 2>/dev/null)
    [[ $rc -eq 0 && $got == "$ref" ]] && grep -q "starting it again from" <<<"$err" \
      && ok "$eng trial $t: resume at np $np with no checkpoint starts again: digest $got = uninterrupted" \
      || bad "$eng trial $t: resume with no checkpoint: exit $rc, digest $got (expected $ref): ${err:0:500}"
  done
done

# The inputs' digests: start.ini (and every checkpoint) records each input
# file's XXH3; resume refuses a changed input (exit 2, naming the key, the
# file and both digests) and goes on once the original is back, both from a
# checkpoint and from start.ini alone.
if need_config "model demo" "$GS_ROOT/configs/model/demo.ini"; then
  src=$DATA/model-synthesis/debroglie-samples-merrell/parliament.csv
  for how in checkpoint start.ini; do
    d=inputs-$how; rm -rf "$d"; cp "$src" "$PWD/example-$how.csv"
    if [[ $how == checkpoint ]]; then
      GS_STOP_AFTER_UNITS=10 run_gs 2 model -c "$GS_ROOT/configs/model/demo.ini" -o "$d" \
        --set "model.example=$PWD/example-$how.csv" </dev/null
    else # killed at the setup phase's start (GS_KILL_AT: kill point 5 of rank 0)
      GS_KILL_AT=5 run_gs 2 model -c "$GS_ROOT/configs/model/demo.ini" -o "$d" \
        --set "model.example=$PWD/example-$how.csv" --set run.checkpoint_seconds=0 </dev/null
    fi
    grep -q "^; input model.example xxh3 [0-9a-f]\{16\} [0-9]* $PWD/example-$how.csv$" "$d/start.ini" \
      && [[ ($how == checkpoint && -f $d/checkpoint.h5) || ($how == start.ini && ! -f $d/checkpoint.h5) ]] \
      && ok "inputs ($how): start.ini records model.example's digest and size" \
      || bad "inputs ($how): no input digest in start.ini or wrong state: $(grep '^; input' "$d/start.ini")"
    printf '\n' >>"example-$how.csv" # one more byte
    run_gs 1 resume "$d"
    [[ $rc -eq 2 ]] && grep -q "cannot resume .*model.example = $PWD/example-$how.csv has changed since the run started (then XXH3 [0-9a-f]*, 19066 bytes; now [0-9a-f]*, 19067 bytes)" <<<"$err" \
      && ok "inputs ($how): resume with a changed input is refused (exit 2) naming it" \
      || bad "inputs ($how): resume with a changed input: exit $rc: ${err:0:500}"
    cp "$src" "example-$how.csv"
    run_gs 3 resume "$d"
    got=$(digest_of "$d" 2>/dev/null)
    [[ $rc -eq 0 && $got == "$(golden model configs/model/demo.ini)" ]] \
      && ok "inputs ($how): with the original back, resume at np 3 gives the uninterrupted digest $got" \
      || bad "inputs ($how): resume with the original input: exit $rc, digest $got: ${err:0:500}"
  done
fi

# Files that input files name in turn (#25): a mesh list's meshes and a tile
# set's tiles are recorded in start.ini and every checkpoint by their readers
# (gs_input_note); a changed one used to be resumed silently. A micro run
# over a mesh list, stopped with a checkpoint; a model run over a copied
# DeBroglie tile set, killed as its synthesis begins (start.ini only).
mkdir -p named; "$GS_BIN" example grid --out named/m.obj --size 16 >/dev/null
printf '# one mesh\nm.obj\n' >named/list.txt
d=named-micro; rm -rf "$d"
GS_STOP_AFTER_UNITS=3 run_gs 2 micro -c "$GS_ROOT/configs/micro/quick.ini" -o "$d" \
  --set micro.shape=file --set "micro.mesh_list=$PWD/named/list.txt" --set micro.instances=2 </dev/null
rec="^ *; input micro.mesh_list xxh3 [0-9a-f]\{16\} [0-9]* $PWD/named/m.obj\$"
[[ $rc -eq 9 ]] && grep -q "$rec" "$d/start.ini" && h5dump -d /geosynth/config "$d/checkpoint.h5" | grep -q "$rec" \
  && ok "named inputs: start.ini and the checkpoint record the mesh the mesh list names" \
  || bad "named inputs: the listed mesh is not recorded (exit $rc): $(grep '^; input' "$d/start.ini")"
cp named/m.obj named/m.orig; printf '# changed\n' >>named/m.obj
run_gs 1 resume "$d"
[[ $rc -eq 2 ]] && grep -q "cannot resume .*micro.mesh_list = $PWD/named/m.obj has changed since the run started" <<<"$err" \
  && ok "named inputs: resume with a changed listed mesh is refused (exit 2) naming it" \
  || bad "named inputs: resume with a changed listed mesh: exit $rc: ${err:0:500}"
cp named/m.orig named/m.obj
run_gs 3 resume "$d"
[[ $rc -eq 0 && -f $d/summary.json ]] && grep -q "micro.mesh_list xxh3 .* $PWD/named/m.obj" "$d/summary.json" \
  && ok "named inputs: with the mesh back, resume at np 3 finishes and summary.json records it" \
  || bad "named inputs: resume with the original mesh: exit $rc: ${err:0:500}"
if need_config "model tiles-castle" "$GS_ROOT/configs/model/tiles-castle.ini"; then
  rm -rf named/ts; cp -r "$DATA/vox/DeBroglie-castle" named/ts
  tsargs=(model -c "$GS_ROOT/configs/model/tiles-castle.ini" --set "model.tileset=$PWD/named/ts/castle.json")
  d=named-model; rm -rf "$d" "$d-trace"
  GS_KILL_TRACE=$PWD/named/trace GS_KILL_AT=100000 run_gs 2 "${tsargs[@]}" -o "$d-trace" </dev/null
  at=$(awk -F'\t' '$2 == "synthesis" && $3 == "phase begins" { print $1; exit }' named/trace)
  GS_KILL_AT=${at:-0} run_gs 2 "${tsargs[@]}" -o "$d" </dev/null
  [[ -n $at && ! -f $d/checkpoint.h5 && ! -f $d/summary.json ]] \
    && grep -q "^; input model.tileset xxh3 [0-9a-f]\{16\} [0-9]* $PWD/named/ts/turret.vox$" "$d/start.ini" \
    && ok "named inputs: killed at kill point $at (synthesis begins), start.ini records the tile set's .vox tiles" \
    || bad "named inputs: tiles not recorded in start.ini (kill point '$at', exit $rc): $(grep -c '^; input' "$d/start.ini") input lines"
  cp named/ts/turret.vox named/turret.orig; printf 'x' >>named/ts/turret.vox
  run_gs 1 resume "$d"
  [[ $rc -eq 2 ]] && grep -q "cannot resume .*model.tileset = $PWD/named/ts/turret.vox has changed since the run started" <<<"$err" \
    && ok "named inputs: resume with a changed tile is refused (exit 2) naming it" \
    || bad "named inputs: resume with a changed tile: exit $rc: ${err:0:500}"
  cp named/turret.orig named/ts/turret.vox
  run_gs 1 resume "$d"
  [[ $rc -eq 0 && $(digest_of "$d") == $(digest_of "$d-trace") ]] \
    && ok "named inputs: with the tile back, resume gives the uninterrupted digest $(digest_of "$d")" \
    || bad "named inputs: resume with the original tile: exit $rc: ${err:0:500}"
fi
finish
