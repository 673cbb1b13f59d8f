#!/usr/bin/env bash
# Checkpoint checksums (#25): bytes flipped inside the data of a checkpoint
# (tests/e2e/ckpt_flip.py: dataset chunks and the stored config, never the
# HDF5 structure) are never resumed silently into another output.
#
# For every engine's quick config a run stopped by GS_STOP_AFTER_UNITS at
# np 2 leaves two checkpoints (checkpoint.h5 and checkpoint.prev.h5, kept by
# every commit). Each trial damages a copy and resumes it at np 1 or 3:
# - checkpoint.h5 damaged: `resume` says which dataset is damaged, falls back
#   to checkpoint.prev.h5 (warning) and ends with the uninterrupted digest
#   (tests/golden/digests.tsv), keeping the damaged file as .damaged;
# - both damaged: refused, exit 4, naming both files;
# - checkpoint.h5 damaged and no previous one: refused, exit 4.
# Never exit 0 with another digest, never exit 0 without the warning.
# TRIALS=N (default 3) trials of the first kind per engine.
source "$GS_ROOT/tests/e2e/lib.bash"
FLIP="/usr/bin/python3 $GS_ROOT/tests/e2e/ckpt_flip.py"
TRIALS=${TRIALS:-3}
seed=2025

# engine config stop-after (two checkpoints before the stop with checkpoint_every=1)
cases=(
  "field configs/field/quick.ini 17"
  "points configs/points/quick.ini 2"
  "micro configs/micro/quick.ini 7" # a round is 6 units: checkpoints at 6 and 12 (none at the start, #23)
  "model configs/model/demo.ini 10"
)
for c in "${cases[@]}"; do
  read -r eng cfg stop <<<"$c"
  ref=$(golden "$eng" "$cfg")
  [[ -n $ref ]] || { bad "$eng: no golden digest for $cfg"; continue; }
  GS_STOP_AFTER_UNITS=$stop run_gs 2 "$eng" -c "$GS_ROOT/$cfg" -o "base-$eng" --set run.checkpoint_every=1
  if [[ $rc -ne 9 || ! -f base-$eng/checkpoint.h5 || ! -f base-$eng/checkpoint.prev.h5 ]]; then
    bad "$eng: a stopped run leaves checkpoint.h5 and checkpoint.prev.h5 (exit $rc): ${err:0:400}"
    continue
  fi
  ok "$eng: a stopped run keeps the previous checkpoint as checkpoint.prev.h5"
  for ((t = 1; t <= TRIALS; t++)); do
    d=t-$eng-$t np=$((t % 2 ? 1 : 3))
    rm -rf "$d"; cp -r "base-$eng" "$d"
    what=$($FLIP "$d/checkpoint.h5" $seed 3 | head -1)
    seed=$((seed + 1))
    run_gs "$np" resume "$d"
    got=$(digest_of "$d" 2>/dev/null)
    if [[ $rc -eq 0 && $got != "$ref" ]]; then
      bad "$eng trial $t: damaged checkpoint resumed SILENTLY to digest $got != $ref ($what)"
    elif [[ $rc -eq 0 ]] && grep -q "is damaged" <<<"$err" && grep -q "resuming from the previous checkpoint" <<<"$err" \
         && [[ -f $d/checkpoint.h5.damaged ]]; then
      ok "$eng trial $t (np $np): damage found, fell back to checkpoint.prev.h5, digest $got = uninterrupted"
    elif [[ $rc -eq 4 ]] && grep -q "is damaged" <<<"$err"; then
      ok "$eng trial $t (np $np): damaged checkpoint refused (exit 4)"
    else
      bad "$eng trial $t: expected a fallback or exit 4 naming the damage, got exit $rc ($what): ${err:0:600}"
    fi
  done
  # Both checkpoints damaged: nothing to fall back to.
  d=t-$eng-both; rm -rf "$d"; cp -r "base-$eng" "$d"
  $FLIP "$d/checkpoint.h5" $((seed++)) 3 >/dev/null
  $FLIP "$d/checkpoint.prev.h5" $((seed++)) 3 >/dev/null
  run_gs 2 resume "$d"
  if [[ $rc -eq 4 ]] && grep -q "no usable checkpoint" <<<"$err" && grep -q "checkpoint.prev.h5 is damaged" <<<"$err"; then
    ok "$eng: both checkpoints damaged: refused (exit 4) naming both"
  else
    bad "$eng: both damaged: expected exit 4 naming both, got $rc: ${err:0:600}"
  fi
  # The stored config damaged, no previous checkpoint.
  d=t-$eng-config; rm -rf "$d"; cp -r "base-$eng" "$d"; rm "$d/checkpoint.prev.h5"
  /usr/bin/python3 - "$d/checkpoint.h5" <<'PY'
import h5py, sys
with h5py.File(sys.argv[1], "r") as f:
    off = f["geosynth/config"].id.get_offset()
with open(sys.argv[1], "r+b") as f:
    f.seek(off + 10); b = f.read(1)[0]; f.seek(off + 10); f.write(bytes([b ^ 0x20]))
PY
  run_gs 1 resume "$d"
  if [[ $rc -eq 4 ]] && grep -q "stored config (/geosynth/config) has digest" <<<"$err"; then
    ok "$eng: a damaged stored config is refused (exit 4)"
  else
    bad "$eng: damaged config: expected exit 4, got $rc: ${err:0:600}"
  fi
done
finish
