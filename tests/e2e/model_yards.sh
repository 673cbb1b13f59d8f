# End-to-end: yards that close, in regions (#18, model16, model24). configs/model/fortress-yards.ini
# (the 3D overlapping model with model.fix_xy_faces on the generated fortress31.txt, 40x40x8 in
# 28x28 regions). Checks from lattice.h5 and the example alone (analysis/lattice_measures.py):
# - region synthesis ran and succeeded: more than one region, 0 failed regions, 0 violations,
#   every 3x3x3 output window, empty ones included, an example window;
# - yards of the example's scale: at least one walled-in yard of at least half the example's
#   largest, and none larger than 1.5x it (the example's 269 cells);
# - summary.json's enclosed_* equal the files' figures; the same digest at np 1 and 2 and after
#   a stop at np 2 resumed at np 1 (the start column past the sides is built again on resume);
# - the same checks on fortress seed 1 (scripts/gen-lattice.py), np 1.
# - the yard fittings measure (lattice_measures.py yard_fittings: labels at the edge of every
#   example yard) finds the example's yard complete and, with its gate walled up, incomplete;
#   the output's complete yards are reported, not checked (model28: gates and keeps are missing
#   from some outputs' yards). Broken on purpose (complete = touches any fitting): fails.
# Broken on purpose (model24), both parts of the fix removed (the start column back to the
# commonest layer-filling windows, the yard's ground inside the walls; the output's face cells
# back to the example's own face windows, solver.c's outside column unused): 24 of 26 regions
# fail at their setup (the start window lies on none of the faces), no yard: the first and
# third checks fail on both examples. The start column alone back (sides as the fix has them):
# 0 failed regions, but the output is the yard's ground with keeps and no wall (0 yards): the
# third check fails on both. The start column past the sides built only on a fresh start
# (engine_setup.c: outside_xy_faces inside `if (!resume)`): the resumed run's digest differs.
# About 6 s (castle-yards below 1 s more).
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
GS_STOP_AFTER_UNITS=1 run_gs 2 model -c "$C" -o stop --set model.mesh=none
expect_rc 9 "fortress-yards: stopped after one region at np 2"
run_gs 0 resume stop
expect_rc 0 "fortress-yards: resumed at np 1"
d0=$(digest_of y0); d2=$(digest_of y2); ds=$(digest_of stop)
[[ -n $d0 && $d0 == "$d2" && $d0 == "$ds" ]] && ok "fortress-yards: digest $d0 at np 1, 2 and stop + resume" \
  || bad "fortress-yards: digests np 1 $d0, np 2 $d2, stop + resume $ds"
# a second fortress, seed 1: its walls lie within 2 cells of its x = 0 and y = 0 sides, so no
# window of open ground lies on all four of its faces
/usr/bin/python3 "$GS_ROOT/scripts/gen-lattice.py" fortress 1 f1.txt >/dev/null
run_gs 0 model -c "$C" -o f1 --set model.mesh=none --set model.example="$PWD/f1.txt"
expect_rc 0 "fortress-yards on fortress seed 1"
check_yards() { # check_yards EXAMPLE RUN_DIR
/usr/bin/python3 - "$1" "$2" <<'PY'
import json, os, sys
sys.path.insert(0, os.environ["GS_ROOT"] + "/analysis")
import lattice_measures as lm
ex = lm.read_lattice(sys.argv[1])
out = lm.read_lattice(sys.argv[2] + "/lattice.h5")
m = json.load(open(sys.argv[2] + "/summary.json"))["metrics"]
e = lm.enclosure_figures(ex, out)
chk = lm.Checks()
need = chk.need
need(m["regions"] > 1 and m["failed_regions"] == 0 and m["violations"] == 0,
     "region synthesis: %d regions, %d failed, %d violations (0 failed, 0 violations)" % (
         m["regions"], m["failed_regions"], m["violations"]))
need(lm.share(ex, out, 3, nonempty=False) == 1.0, "every 3x3x3 output window is an example window")
ymax, exmax = e["enclosed_yard_max"], e["enclosed_yard_max_example"]
need(exmax > 0 and 0.5 * exmax <= ymax <= 1.5 * exmax,
     "yards of the example's scale: largest %d cells within 0.5-1.5x the example's %d "
     "(%d yards, %.3f of the layer above the ground in yards >= half the example's; the "
     "example's %.3f)" % (ymax, exmax, e["enclosed_yards"], e["enclosed_large_share"],
                          e["enclosed_large_share_example"]))
need(all(abs(e[k] - m[k]) < 1e-12 for k in e), "summary.json's enclosed_* = the files' figures")
# yard fittings (model28): the measure finds the example's own yard complete and one whose
# gate is walled up incomplete; the output's figure is reported (gates and keeps are missing
# from some yards: configs/model/DEFAULTS.md "What the yards lack")
fx = lm.yard_fittings(ex, ex)
walled = ex.copy()
gate = [l for l in fx["yard_fittings"] if (ex == l).sum() == min((ex == k).sum() for k in fx["yard_fittings"])][0]
walled[walled == gate] = fx["yard_fittings"][0]
fw, fo = lm.yard_fittings(ex, walled), lm.yard_fittings(ex, out)
need(len(fx["yard_fittings"]) >= 3 and fx["yard_fittings_complete"] == fx["yard_fittings_yards"] == 1
     and fw["yard_fittings_complete"] == 0,
     "yard fittings: labels %s at the example's yard, its yard complete, walled-up gate (label %d) "
     "incomplete; output: %d of %d yards of the example's scale complete, per label %s" % (
         fx["yard_fittings"], gate, fo["yard_fittings_complete"], fo["yard_fittings_yards"],
         fo["yard_fittings_per_label"]))
chk.result()
PY
}
verdict fortress-yards "walls its yards in like its example, in regions" "$(check_yards "$EX" y0)"
verdict fortress1 "walls its yards in like its example, in regions" "$(check_yards f1.txt f1)"
# castle-yards.ini (Merrell's castle.txt, fetched; #18, model38): castle.ini with the output's
# x/y faces pinned to the example's face column, so walls turn inside and rings close. Seeds 1
# and 2, np 1, from lattice.h5, the example and summary.json: the share of the layer above the
# grass in yards (enclosed_share) at least half the example's; the issue's target (the author's
# best: non-empty 3x3x3 share >= 0.59, label L1 <= 0.15); 0 violations, 0 failed regions and no
# new try (model.backjump and model.rewinds: closing rings needs undoing far back).
# Broken on purpose: without model.border (border =) enclosed 0.001 and 0.025 < 0.078, both
# fail; model.rewinds = 0: seed 1 takes 4 new tries (and its 3x3x3 share is 0.576), it fails.
CASTLE=model-synthesis/merrell42-model-synthesis/samples/castle.txt
if need_data "castle-yards: yards on castle.txt" $CASTLE; then
  for s in 1 2; do
    run_gs 0 model -c "$GS_ROOT/configs/model/castle-yards.ini" --set run.seed=$s --set model.mesh=none -o cy$s
    expect_rc 0 "castle-yards.ini seed $s"
    res=$(/usr/bin/python3 - "$DATA/$CASTLE" cy$s <<'PY'
import os, sys
sys.path.insert(0, os.environ["GS_ROOT"] + "/analysis")
import lattice_measures as lm
ex, out, m = lm.read_run(sys.argv[1], sys.argv[2])
e, f = lm.enclosure_figures(ex, out), lm.figures(ex, out, ks=(3,))
chk = lm.Checks()
need = chk.need
need(e["enclosed_share"] >= 0.5 * e["enclosed_share_example"],
     "enclosed share %.3f >= half the example's %.3f (%d yards)" % (
         e["enclosed_share"], e["enclosed_share_example"], e["enclosed_yards"]))
need(f["share_3"] >= 0.59 and f["label_l1"] <= 0.15,
     "non-empty 3x3x3 share %.3f >= 0.59, label L1 %.4f <= 0.15 (the author's best)" % (
         f["share_3"], f["label_l1"]))
need(m["violations"] == 0 and m["failed_regions"] == 0 and m["retries"] == 0,
     "0 violations, 0 failed regions, 0 retries (%d, %d, %d; %d undone)" % (
         m["violations"], m["failed_regions"], m["retries"], m["backtracks"]))
chk.result()
PY
)
    verdict castle-yards$s "closes walled yards within the issue's target" "$res"
  done
fi
finish
