# End-to-end: hostile input files never crash or hang geosynth (issue #25).
# Mutated meshes (PLY ascii/binary, OFF, STL, OBJ) and damaged .vdb examples
# go through the command line of the issue (`geosynth field -c quick.ini
# --set example.kind=file --set example.path=BAD --set example.sign=unsigned`);
# each run must end within 20 s with exit 0 or a clear error naming the file
# (exit 2..7), never a signal. A second SIGTERM ends a run at once (exit 143,
# one message). The mutations are seeded (tests/e2e/mutate.py): the same files
# on every run. HOSTILE_TRIALS=N sets the number of mutants (default 40).
source "$GS_ROOT/tests/e2e/lib.bash"
Q=$GS_ROOT/configs/field/quick.ini
N=${HOSTILE_TRIALS:-40}
PY=/usr/bin/python3

# --- seeds: a cube in every mesh format, and a valid .vdb -----------------------
$PY - <<'PYEOF'
import struct
V=[(0,0,0),(1,0,0),(1,1,0),(0,1,0),(0,0,1),(1,0,1),(1,1,1),(0,1,1)]
T=[(0,3,2),(0,2,1),(4,5,6),(4,6,7),(0,1,5),(0,5,4),(1,2,6),(1,6,5),(2,3,7),(2,7,6),(3,0,4),(3,4,7)]
h=lambda fmt: (f"ply\nformat {fmt} 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\nelement face 12\nproperty list uchar int vertex_indices\nend_header\n").encode()
open('seed_a.ply','wb').write(h('ascii')+b''.join(("%g %g %g\n"%v).encode() for v in V)+b''.join(("3 %d %d %d\n"%t).encode() for t in T))
open('seed_b.ply','wb').write(h('binary_little_endian')+b''.join(struct.pack('<3f',*v) for v in V)+b''.join(struct.pack('<B3i',3,*t) for t in T))
open('seed.off','wb').write(b"OFF\n8 12 0\n"+b''.join(("%g %g %g\n"%v).encode() for v in V)+b''.join(("3 %d %d %d\n"%t).encode() for t in T))
open('seed.obj','wb').write(b''.join(("v %g %g %g\n"%v).encode() for v in V)+b''.join(("f %d %d %d\n"%tuple(i+1 for i in t)).encode() for t in T))
open('seed.stl','wb').write(b'\0'*80+struct.pack('<I',len(T))+b''.join(struct.pack('<3f',0,0,0)+b''.join(struct.pack('<3f',*V[i]) for i in t)+b'\0\0' for t in T))
PYEOF

# the seeds themselves are read
for s in seed_a.ply seed_b.ply seed.off seed.obj seed.stl; do
  run_gs 0 field -c "$Q" -o "ok-$s" --set example.kind=file --set "example.path=$s" --set example.sign=unsigned --set output.geometry=none
  expect_rc 0 "seed mesh $s is read"
done

# one run per file: exit 0 or 2..7 with the file named, within 20 s
check_hostile() { # LABEL FILE...
  local label=$1 f rc signals=0 hung=0 unnamed=0 errors=0 read=0 worst=""; shift
  for f in "$@"; do
    timeout -s KILL 20 "$GS_BIN" field -c "$Q" -o "run-$(basename "$f")" --set example.kind=file \
      --set "example.path=$f" --set example.sign=unsigned --set output.geometry=none >out.log 2>err.log
    rc=$?
    if [[ $rc -eq 0 ]]; then read=$((read + 1))
    elif [[ $rc -ge 2 && $rc -le 7 ]]; then
      errors=$((errors + 1))
      grep -qF "$(basename "$f")" err.log || { unnamed=$((unnamed + 1)); worst="$f: $(head -c 300 err.log)"; }
    elif [[ $rc -eq 137 ]]; then hung=$((hung + 1)); worst="$f: still running after 20 s"
    else signals=$((signals + 1)); worst="$f: exit $rc: $(head -c 300 err.log)"
    fi
  done
  echo "$label: $# files: $read read, $errors clear errors, $signals signal exits, $hung hung, $unnamed errors without the file name"
  if [[ $signals -eq 0 && $hung -eq 0 && $unnamed -eq 0 ]]; then ok "$label: no crash, no hang, every error names the file"
  else bad "$label: $worst"; fi
}

$PY "$GS_ROOT/tests/e2e/mutate.py" 25 "$N" mut seed_a.ply seed_b.ply seed.off seed.obj seed.stl
check_hostile "mutated meshes" mut/*

# .vdb: truncated and byte-flipped copies of a field written by geosynth
run_gs 0 field -c "$Q" -o vdbsrc --set output.geometry=none
expect_rc 0 "a .vdb to damage"
$PY "$GS_ROOT/tests/e2e/mutate.py" 26 $(( N / 2 )) vmut vdbsrc/field.vdb
head -c 3000 vdbsrc/field.vdb > vmut/first3000.vdb
check_hostile "damaged .vdb examples" vmut/*

# --- outputs never follow symlinks planted in the run directory ---------------
mkdir -p planted
echo precious > precious.txt
for f in summary.json.tmp field.h5.tmp field.xmf.tmp contour.ply.tmp metrics.jsonl; do
  ln -sf "$PWD/precious.txt" "planted/$f"
done
run_gs 0 field -c "$Q" -o planted
expect_rc 3 "a symlink as metrics.jsonl is refused"
expect_err "metrics.jsonl: Too many levels of symbolic links" "the refusal names the file"
rm planted/metrics.jsonl
run_gs 0 field -c "$Q" -o planted
expect_rc 0 "symlinks planted as temporary files are replaced, not followed"
[[ "$(cat precious.txt)" == precious ]] && ok "the symlinks' target is untouched" || bad "an output was written through a planted symlink"

# --- a run directory path too long for Open MPI's HDF5 I/O: refused up front --------
long=$PWD; while [[ ${#long} -lt 4058 ]]; do long=$long/$(printf 'd%.0s' {1..200}); done
run_gs 0 field -c "$Q" -o "${long:0:4058}"
expect_rc 2 "a 4058-character run directory is refused before the synthesis"
expect_err "at most 192 are supported" "the refusal says the limit"

# --- one run per directory -------------------------------------------------------
"$GS_BIN" field -c "$Q" -o locked --set field.target=160x128x128 --set output.geometry=none >lock.out 2>lock.err &
pid=$!
sleep 1.5
run_gs 0 field -c "$Q" -o locked
expect_rc 2 "a second run into a directory in use is refused"
expect_err "is in use by another geosynth run (process $pid" "the refusal names the directory and the process"
kill -TERM $pid; wait $pid; rc=$?
[[ $rc -eq 9 ]] && ok "the first run stopped with a checkpoint (exit 9)" || bad "first run: exit $rc"
run_gs 0 resume locked
expect_rc 0 "the lock is gone with its process: resume runs"

# --- a second SIGTERM ends the run at once -------------------------------------
"$GS_BIN" field -c "$Q" -o sigterm --set field.target=160x128x128 --set output.geometry=none >term.out 2>term.err &
pid=$!
sleep 1.5
kill -TERM $pid; sleep 0.05; kill -TERM $pid
t0=$(date +%s.%N)
wait $pid; rc=$?
t1=$(date +%s.%N)
if [[ $rc -eq 143 ]] && grep -q "second SIGTERM: stopping at once" term.err; then
  ok "second SIGTERM: exit 143 with a message"
else bad "second SIGTERM: exit $rc, stderr: $(tail -c 300 term.err)"; fi
[[ $(grep -c "second SIGTERM" term.err) -eq 1 ]] && ok "second SIGTERM reported once" || bad "second SIGTERM message count: $(grep -c 'second SIGTERM' term.err)"
$PY -c "import sys; sys.exit(0 if float('$t1') - float('$t0') < 2 else 1)" && ok "second SIGTERM ends it within 2 s" || bad "second SIGTERM took $(echo "$t1 - $t0" | bc) s"
finish
