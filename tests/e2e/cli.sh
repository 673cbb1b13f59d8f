# End-to-end: command line behaviour that does not need an engine.
source "$GS_ROOT/tests/e2e/lib.bash"

run_gs 0 --help
expect_rc 0 "--help"
expect_out "usage: [mpirun -np N] geosynth" "--help prints usage"
expect_out "exit codes:" "--help documents exit codes"
for cmd in resume inspect version help; do
  grep -q "^  $cmd " <<<"$out" && ok "--help documents $cmd" || bad "--help lacks $cmd"
done

run_gs 0
expect_rc 1 "no command"

run_gs 0 version
expect_rc 0 "version"
expect_out "geosynth 0." "version names the program version"
expect_out "OpenVDB" "version names the OpenVDB version"
expect_out "HDF5" "version names the HDF5 version"

run_gs 0 resmue x
expect_rc 1 "misspelt command"
expect_err "did you mean 'resume'" "misspelt command gets a suggestion"

run_gs 0 inspect --bogus
expect_rc 1 "unknown option"
expect_err "unknown option '--bogus'" "unknown option is named"

run_gs 0 inspect
expect_rc 1 "inspect without a file"

run_gs 0 inspect /nonexistent/file.h5
expect_rc 3 "inspect missing file"
expect_err "/nonexistent/file.h5" "inspect missing file names the path"

printf 'not an hdf5 file\n' > text.h5
run_gs 0 inspect text.h5
expect_rc 4 "inspect a text file"
expect_err "text.h5" "inspect text file names the path"
expect_no_crash "inspect a text file"

: > empty.h5
run_gs 0 inspect empty.h5
expect_rc 4 "inspect an empty file"
expect_no_crash "inspect an empty file"

run_gs 0 resume /nonexistent/run
expect_rc 3 "resume a missing run directory"
expect_err "/nonexistent/run/checkpoint.h5" "resume names the missing checkpoint"

mkdir -p run1 && cp text.h5 run1/checkpoint.h5
run_gs 2 resume run1
expect_rc 4 "resume a damaged checkpoint at np=2 (collective failure, no hang)"
expect_no_crash "resume a damaged checkpoint"

run_gs 0 resume run1 --set field.block=4
expect_rc 1 "resume may not change non-run keys"
expect_err "only run.checkpoint_seconds, run.checkpoint_every" "resume explains which keys may change"
run_gs 0 resume run1 --set run.seed=5
expect_rc 1 "resume may not change run.seed (it was accepted, ignored by the output, yet recorded in summary.json)"

# --- preview: meshes side by side in one PNG (make demo's pictures) ---------------
run_gs 0 example balls --out pballs.obj --size 24
run_gs 0 example grid --out pgrid.obj --size 24
run_gs 0 preview --out p.png --size 64 pballs.obj "$DATA/meshes/spot.obj" pgrid.obj
expect_rc 0 "preview of three meshes"
/usr/bin/python3 - p.png <<'PY' && ok "preview: 3 panels of 64 px (+ 2 gutters of 4), each with lit pixels" || bad "preview picture wrong"
import sys
from PIL import Image
im = Image.open(sys.argv[1]).convert("L")
assert im.size == (3 * 64 + 2 * 4, 64), im.size
bg = im.getpixel((0, 0))
for k in range(3):
    px = [im.getpixel((k * 68 + x, y)) for x in range(64) for y in range(64)]
    assert sum(abs(p - bg) > 20 for p in px) > 100, k
PY
run_gs 0 preview p.png pballs.obj
expect_rc 1 "preview without --out"
expect_err "preview needs --out" "preview explains its usage"
run_gs 0 preview --out q.png nosuch.obj
expect_rc 3 "preview of a missing mesh"
expect_err "nosuch.obj" "names the missing mesh"
[[ ! -e q.png ]] && ok "no picture written on error" || bad "q.png written"
run_gs 0 preview --out r.png --seed 2 pballs.obj
expect_rc 1 "--seed is not a preview option"

finish
