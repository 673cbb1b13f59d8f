# End-to-end: the second sweep with its keep test, the default with synthesized z faces
# (model.passes = -1 = auto, model.sweep_keep = auto: mix,support,windows; #18 terrain ridges, model32,
# configs/model/DEFAULTS.md `passes = -1` (auto)). Examples nobody tuned for (scripts/gen-lattice.py),
# 40x40x8 in 20x20 regions, default settings, the untuned benchmark's target from the example
# alone (tests/bench/model_untuned.sh): non-empty 3x3x3 share >= 0.5, top layer within 1 of the
# example's, no floating cells where the example has none, 0 violations, 0 failed regions.
# The cases are the ones a second sweep without the keep test lost (model30, model32's break):
# village 138 at synthesis seed 2 (support repair left 2 floating cells: 1 failed region),
# terrain 188 and 195 at seed 1 (their tall hill rebuilt away: top layer 3 of the example's 5).
# Terrain 159 at seed 1 (the ridges along the first sweep's last-decided lines): its label L1
# at most 1/2 of the first sweep's alone (--set model.passes=1), checked from lattice.h5 and the
# example (0.315 one sweep; 0.026 now; 0.077 without the keep test, still passes: the check is
# of the second sweep, the three above of the keep test). The same digest at np 1 and 2 and after
# a stop inside the second sweep (after 12 of 9 + 16 regions) at np 2 resumed at np 1.
# Broken on purpose (engine_regions.c sweep_keep_worse never worse): village 138 1 failed
# region, terrain 188 and 195 top layer 3 of 5: three checks fail. model.passes = auto back
# to one sweep: terrain 159 L1 0.315 > 0.158: fails. Terrains 144 and 152 at seed 1: land share
# within 1/4 of the example's (model.sweep_keep = auto's land test, model35; the land test never
# passing: 0.423 of 0.602 and 0.158 of 0.312, both fail). Village 267 at synthesis seed 2: one
# leaves cell alone on the y = 0 face that no repair box up to the whole grid keeps supported; the
# repair's last resort empties it (engine_regions.c carve_floating; without it 1 failed region:
# fails). About 20 s.
source "$GS_ROOT/tests/e2e/lib.bash"
verdict() { # verdict NAME WHAT OUTPUT: OUTPUT's lines indented, one check from its RESULT line
  echo "$3" | sed "s/^/  $1: /"
  if grep -q "^RESULT pass" <<<"$3"; then ok "$1 $2"; else bad "$1: $(grep '^RESULT' <<<"$3")"; fi
}
figures() { # figures EXAMPLE RUN_DIR: the untuned target's checks (lattice_measures.py), "L1 x"
  /usr/bin/python3 - "$1" "$2" <<'EOF'
import os, sys
sys.path.insert(0, os.environ["GS_ROOT"] + "/analysis")
import lattice_measures as lm
lm.untuned_checks(sys.argv[1], sys.argv[2])
EOF
}
for ex in village:138:2 village:267:2 terrain:188:1 terrain:195:1 terrain:159:1; do
  IFS=: read -r kind s seed <<<"$ex"
  /usr/bin/python3 "$GS_ROOT/scripts/gen-lattice.py" $kind $s $kind$s.txt
  printf '[model]\nexample = %s\nsize = 40x40x8\nregion = 20x20x0\nmesh = none\n' $kind$s.txt >$kind$s.ini
  run_gs 0 model -c $kind$s.ini -o $kind$s --set run.seed=$seed
  expect_rc 0 "$kind $s seed $seed, default settings"
  [[ $rc -eq 0 ]] || continue
  expect_err "z faces synthesized: 2 sweeps (model.passes = auto), later sweeps keep a rebuilt region only if no further from the example by: mix,support,windows" "$kind $s: the log names the sweeps and keep tests auto chose"
  res=$(figures $kind$s.txt $kind$s)
  verdict "$kind$s seed $seed" "resembles its example" "$res"
  [[ $kind$s != village267 ]] || expect_err "support repair: 1 floating cells emptied" "village 267: the repair's last resort emptied the floating cell"
done
# terrain 159: the second sweep takes the ridges away
run_gs 0 model -c terrain159.ini -o terrain159_one --set run.seed=1 --set model.passes=1
expect_rc 0 "terrain 159, one sweep"
l2=$(figures terrain159.txt terrain159 | sed -n 's/^L1 //p')
l1=$(figures terrain159.txt terrain159_one | sed -n 's/^L1 //p')
echo "  terrain 159 label L1: one sweep $l1, default $l2"
/usr/bin/python3 -c "import sys; sys.exit(0 if float('$l2') <= 0.5 * float('$l1') else 1)" \
  && ok "terrain 159: label L1 $l2 <= 1/2 of one sweep's $l1" \
  || bad "terrain 159: label L1 $l2 > 1/2 of one sweep's $l1"
# the land test (model.sweep_keep = auto adds land for the terrains' broad domes): terrains 144
# and 152 at seed 1 lost land to the windows test (water's windows are always found); their land
# share (columns above the example's lowest column, analysis/lattice_measures.py land_figures)
# within 1/4 of the example's
for s in 144 152; do
  /usr/bin/python3 "$GS_ROOT/scripts/gen-lattice.py" terrain $s terrain$s.txt
  printf '[model]\nexample = %s\nsize = 40x40x8\nregion = 20x20x0\nmesh = none\n' terrain$s.txt >terrain$s.ini
  run_gs 0 model -c terrain$s.ini -o terrain$s --set run.seed=1
  expect_rc 0 "terrain $s seed 1, default settings"
  expect_err "model.sweep_keep = auto adds land" "terrain $s: the log says auto added the land test"
  res=$(/usr/bin/python3 - terrain$s.txt terrain$s <<'EOF'
import os, sys
sys.path.insert(0, os.environ["GS_ROOT"] + "/analysis")
import lattice_measures as lm
f = lm.land_figures(lm.read_lattice(sys.argv[1]), lm.read_lattice(sys.argv[2] + "/lattice.h5"))
o, e = f["land_share"], f["land_share_example"]
print("land share %.3f, example's %.3f" % (o, e))
print("RESULT", "pass" if abs(o - e) <= e / 4 else "fail: land share %.3f not within 1/4 of %.3f" % (o, e))
EOF
)
  verdict "terrain$s seed 1" "land share within 1/4 of the example's" "$res"
done
# determinism: np 2, and a stop inside the second sweep resumed at np 1
run_gs 2 model -c terrain159.ini -o t159np2 --set run.seed=1
expect_rc 0 "terrain 159 at np 2"
GS_STOP_AFTER_UNITS=12 run_gs 2 model -c terrain159.ini -o t159stop --set run.seed=1
expect_rc 9 "terrain 159: stopped after 12 regions (in the second sweep) at np 2"
run_gs 0 resume t159stop
expect_rc 0 "terrain 159: resumed at np 1"
d1=$(digest_of terrain159)
[[ -n $d1 && $(digest_of t159np2) == "$d1" && $(digest_of t159stop) == "$d1" ]] \
  && ok "terrain 159: digest $d1 at np 1, np 2 and stop + resume" || bad "terrain 159: digests differ across np or resume"
finish
