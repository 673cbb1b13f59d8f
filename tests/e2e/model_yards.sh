# End-to-end: yards that close (#18, model16). configs/model/fortress-yards.ini (the 3D
# overlapping model with model.fix_xy_faces on the generated fortress31.txt, whole grid,
# 40x40x8). Checks from lattice.h5 and the example alone (analysis/lattice_measures.py):
# - the layer above the ground holds yards of the example's scale (walled in, each at least half
#   the example's yard): their share of the layer at least half the example's (0.467);
# - every 3x3x3 output window, empty ones included, is an example window; 0 violations, 0
#   failed regions;
# - summary.json's enclosed_* equal the files' figures; the same digest at np 1 and 2.
# Broken on purpose: the face masks dropped in the solver (solver.c, model.fix_xy_faces a
# no-op) leave the walls running out through the output's sides: no yard of the example's
# scale (share 0.000), the first check fails. About 3 s.
source "$GS_ROOT/tests/e2e/lib.bash"
C=$GS_ROOT/configs/model/fortress-yards.ini
EX=$GS_ROOT/configs/model/fortress31.txt
verdict() { # verdict NAME WHAT OUTPUT: OUTPUT's lines indented, one check from its RESULT line
  echo "$3" | sed "s/^/  $1: /"
  if grep -q "^RESULT pass" <<<"$3"; then ok "$1 $2"; else bad "$1: $(grep '^RESULT' <<<"$3")"; fi
}
for np in 0 2; do
  run_gs $np model -c "$C" -o y$np --set model.mesh=none
  expect_rc 0 "fortress-yards at np=${np/#0/1}"
done
d0=$(digest_of y0); d2=$(digest_of y2)
[[ -n $d0 && $d0 == "$d2" ]] && ok "fortress-yards: digest $d0 at np 1 and 2" \
  || bad "fortress-yards: digests np 1 $d0, np 2 $d2"
res=$(/usr/bin/python3 - "$EX" y0 <<'EOF'
import json, os, sys
sys.path.insert(0, os.environ["GS_ROOT"] + "/analysis")
import lattice_measures as lm
ex = lm.read_lattice(sys.argv[1])
out = lm.read_lattice(sys.argv[2] + "/lattice.h5")
m = json.load(open(sys.argv[2] + "/summary.json"))["metrics"]
e = lm.enclosure_figures(ex, out)
chk = lm.Checks()
need = chk.need
need(e["enclosed_large_share"] >= 0.5 * e["enclosed_large_share_example"] > 0,
     "yards of the example's scale: %.3f of the layer above the ground >= half the example's %.3f "
     "(%d yards, largest %d cells; the example's %d cells)" % (
         e["enclosed_large_share"], e["enclosed_large_share_example"], e["enclosed_yards"],
         e["enclosed_yard_max"], e["enclosed_yard_max_example"]))
need(lm.share(ex, out, 3, nonempty=False) == 1.0, "every 3x3x3 output window is an example window")
need(m["violations"] == 0 and m["failed_regions"] == 0, "0 violations, 0 failed regions")
need(all(abs(e[k] - m[k]) < 1e-12 for k in e), "summary.json's enclosed_* = the files' figures")
chk.result()
EOF
)
verdict fortress-yards "walls its yards in like its example" "$res"
finish
