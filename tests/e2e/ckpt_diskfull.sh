#!/usr/bin/env bash
# Disk full during a field checkpoint (#25): the run stops with exit 3 and
# "No space left on device" at np 1, 2 and 3 -- before, np 2 and 3 spun in
# libhdf5's internal collectives (H5Dcreate / H5Fclose) until killed and np 1
# segfaulted at exit -- and the previous checkpoints stay intact: a resume
# from them on a disk with room ends with the uninterrupted digest.
# The full disk is a 1 MiB tmpfs (room for two checkpoints of quick.ini);
# skipped when mount is not allowed here.
source "$GS_ROOT/tests/e2e/lib.bash"
CFG=configs/field/quick.ini
ref=$(awk -F'\t' -v c="$CFG" '$1 == "field" && $2 == c { print $5; exit }' "$GS_ROOT/tests/golden/digests.tsv")
mnt=$PWD/full
mkdir -p "$mnt"
if ! mount -t tmpfs -o size=1m tmpfs "$mnt" 2>mount.err; then
  skipped "disk full: cannot mount a small tmpfs here ($(head -c 200 mount.err))"
  finish
fi
trap 'umount "$mnt" 2>/dev/null' EXIT
for np in 1 2 3; do
  rm -rf "$mnt/r"
  timeout 60 mpirun -np $np "$GS_BIN" field -c "$GS_ROOT/$CFG" -o "$mnt/r" --set run.checkpoint_every=1 >out.$np 2>err.$np
  rc=$? err=$(cat err.$np)
  if [[ $rc -eq 124 ]]; then
    bad "np $np: disk full: still running after 60 s (hang)"
    continue
  fi
  expect_no_crash "np $np: disk full"
  [[ $rc -eq 3 ]] && grep -q "No space left on device" <<<"$err" && grep -q "checkpoint.h5.tmp" <<<"$err" \
    && ok "np $np: disk full during a checkpoint: exit 3 naming the file and the reason" \
    || bad "np $np: disk full: expected exit 3 with 'No space left on device', got $rc: ${err:0:500}"
  [[ ! -e $mnt/r/checkpoint.h5.tmp ]] && ok "np $np: the unfinished checkpoint.h5.tmp is removed" \
    || bad "np $np: checkpoint.h5.tmp left behind"
  rm -rf "r$np"; cp -r "$mnt/r" "r$np"
  run_gs 2 resume "r$np"
  d=$(digest_of "r$np" 2>/dev/null)
  [[ $rc -eq 0 && $d == "$ref" ]] && ok "np $np: the last checkpoint before the full disk is intact: resumed to $d" \
    || bad "np $np: resume of the checkpoint left by a full disk: exit $rc, digest $d != $ref: ${err:0:400}"
done
finish
