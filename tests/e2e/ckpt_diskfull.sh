#!/usr/bin/env bash
# Disk full during a field checkpoint or output write (#25): the run stops with exit 3 and
# "No space left on device" at np 1, 2 and 3 -- before, np 2 and 3 spun in
# libhdf5's internal collectives (H5Dcreate / H5Fclose) until killed and np 1
# segfaulted at exit -- and the previous checkpoints stay intact: a resume
# from them on a disk with room ends with the uninterrupted digest.
# The full disk is a 1 MiB tmpfs; skipped when mount is not allowed here.
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
# Two fills of the same 1 MiB disk: with 100 KiB left the second checkpoint
# (63 KB compressed) does not fit, so the run stops inside a checkpoint
# write; with the whole MiB the checkpoints fit and the outputs (1.4 MB) do
# not, so it stops inside an output write. Either way: exit 3 naming the
# file and "No space left on device", no .tmp left behind, and a resume on a
# disk with room ends with the uninterrupted digest.
for np in 1 2 3; do
  for fill in ckpt output; do
    if [[ $fill == ckpt ]]; then what="np $np, disk full during a checkpoint write"
    else what="np $np, disk full during an output write"; fi
    rm -rf "$mnt/r" "$mnt/filler"
    [[ $fill == ckpt ]] && head -c $((1024 * 1024 - 100 * 1024)) /dev/zero >"$mnt/filler"
    timeout 60 mpirun -np $np "$GS_BIN" field -c "$GS_ROOT/$CFG" -o "$mnt/r" --set run.checkpoint_every=1 >out.$np 2>err.$np
    rc=$? err=$(cat err.$np)
    if [[ $rc -eq 124 ]]; then
      bad "$what: still running after 60 s (hang)"
      continue
    fi
    expect_no_crash "$what"
    file=$(grep -oE "^(\[rank [0-9]+\] )?error \(I/O\): [^:]*$mnt/r/[^:]*" <<<"$err" | head -1 | sed 's/.*: //')
    want=checkpoint.h5.tmp
    [[ $fill == output ]] && want="an output"
    if [[ $rc -eq 3 ]] && grep -q "No space left on device" <<<"$err" && [[ -n $file ]] &&
       { [[ $fill == output && $file != *checkpoint* ]] || [[ $fill == ckpt && $file == */checkpoint.h5.tmp ]]; }; then
      ok "$what: exit 3 naming ${file#$mnt/} and 'No space left on device'"
    else
      bad "$what: expected exit 3 naming $want and 'No space left on device', got $rc (${file:-no file}): ${err:0:500}"
    fi
    left=$(find "$mnt/r" -name '*.tmp' | head -3)
    [[ -z $left ]] && ok "$what: no unfinished .tmp file left" || bad "$what: left behind: $left"
    rm -rf "r$np"; cp -r "$mnt/r" "r$np"
    run_gs 2 resume "r$np"
    d=$(digest_of "r$np" 2>/dev/null)
    [[ $rc -eq 0 && $d == "$ref" ]] && ok "$what: what was written before is intact: resumed to $d" \
      || bad "$what: resume after the full disk: exit $rc, digest $d != $ref: ${err:0:400}"
  done
done
finish
