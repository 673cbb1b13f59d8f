# End-to-end: the 3D overlapping model (model.overlap3d = N, issue #18 item 1) on the
# repository's copy of Merrell's parliament (DeBroglie's CSV), configs/model/parliament-overlap3d.ini
# (N = 3, whole grid, 30x30x10). Checks from lattice.h5 and the example alone
# (analysis/lattice_measures.py):
# - every 2x2x2 and 3x3x3 window of the output, empty ones included, is a window of the
#   example (share 1.000: the construction's promise);
# - completeness (share of the example's distinct non-empty k^3 windows met in the output) at
#   least what one half of the example meets of the other (the lower, k = 2 and 3);
# - label L1 at most 2 x the larger L1 between the example's halves;
# - the output's bottom 3x3x3 windows are windows of the example's bottom (model.fix_z_faces =
#   auto: the z = 0 patterns are those found at the example's z = 0). On parliament (and on
#   terrain7.txt, escheresque) this also holds with model.fix_z_faces = false, so it checks the
#   output, not the masks; the top mask is checked on the generated fortress at the end;
# - 0 violations (example adjacency of the decoded lattice) and 0 overlap disagreements
#   between neighbouring patterns (independent checker), 0 failed regions;
# - the golden digest at np 1 and 2; in 10x10 blocks (the region solver) the same digest at
#   np 1 and 2 and after a stop + resume, and still only example windows;
# - more than 8192 distinct windows is refused with a clear error.
# Broken on purpose: rules from plain adjacency (a pattern's +x neighbour need only agree on one
# cell, not the whole overlap) fails the window shares (2x2x2 0.9987, 3x3x3 0.727), label L1
# (0.571), the overlap checker (21,569 disagreements) and the golden digest.
# About 10 s.
source "$GS_ROOT/tests/e2e/lib.bash"
C=$GS_ROOT/configs/model/parliament-overlap3d.ini
EX=$GS_ROOT/data/model-synthesis/debroglie-samples-merrell/parliament.csv
want=$(golden model configs/model/parliament-overlap3d.ini)

for np in 0 2; do
  run_gs $np model -c "$C" -o w$np
  expect_rc 0 "parliament-overlap3d at np=${np/#0/1}"
done
d0=$(digest_of w0); d2=$(digest_of w2)
[[ -n $d0 && $d0 == "$d2" && $d0 == "$want" ]] \
  && ok "parliament-overlap3d: golden digest $d0 at np 1 and 2" || bad "parliament-overlap3d: digests $d0 $d2, golden $want"

check_windows() { # check_windows DIR WHAT QUALITY(0/1)
  /usr/bin/python3 - "$EX" "$1" "$3" <<'EOF'
import json, os, sys
sys.path.insert(0, os.environ["GS_ROOT"] + "/analysis")
import lattice_measures as lm

ex = lm.read_lattice(sys.argv[1])
out = lm.read_lattice(sys.argv[2] + "/lattice.h5")
m = json.load(open(sys.argv[2] + "/summary.json"))["metrics"]
f, h = lm.figures(ex, out, ks=(2, 3)), lm.half_figures(ex, ks=(2, 3))
chk = lm.Checks()
need = chk.need
for k in (2, 3):
    need(f["share_%d_with_empty" % k] == 1.0,
         "every %dx%dx%d output window is an example window: share %.4f" % (k, k, k, f["share_%d_with_empty" % k]))
def bottom_windows(a, k=3):  # the k^3 windows resting on z = 0, as bytes
    nz, ny, nx = a.shape
    return {a[0:k, y:y + k, x:x + k].tobytes() for y in range(ny - k + 1) for x in range(nx - k + 1)}
exb, outb = bottom_windows(ex.astype("uint16")), bottom_windows(out.astype("uint16"))
need(outb <= exb, "the output's bottom 3x3x3 windows are windows of the example's bottom "
     "(%d of %d not)" % (len(outb - exb), len(outb)))
if sys.argv[3] == "1":
    for k in (2, 3):
        need(f["completeness_%d" % k] >= h["completeness_%d" % k],
             "completeness %dx%dx%d %.3f >= example half vs half (the lower) %.3f"
             % (k, k, k, f["completeness_%d" % k], h["completeness_%d" % k]))
    need(f["label_l1"] <= 2 * h["label_l1"],
         "label L1 %.3f <= 2 x example half vs half %.3f" % (f["label_l1"], h["label_l1"]))
need(m["violations"] == 0 and m["rule_violations"] == 0 and m["failed_regions"] == 0,
     "0 violations (%d), 0 overlap disagreements (%d), 0 failed regions (%d)"
     % (m["violations"], m["rule_violations"], m["failed_regions"]))
chk.result()
EOF
}
res=$(check_windows w0 whole 1)
echo "$res" | sed 's/^/  whole: /'
grep -q "^RESULT pass" <<<"$res" && ok "parliament-overlap3d: only example windows, complete as the example's halves" \
  || bad "parliament-overlap3d: $(grep '^RESULT' <<<"$res")"

# the region solver (Merrell's modify-in-blocks) over patterns: rank count and stop/resume
B=(--set model.region=10x10x0)
run_gs 0 model -c "$C" "${B[@]}" -o b0
expect_rc 0 "parliament-overlap3d in 10x10 blocks at np=1"
run_gs 2 model -c "$C" "${B[@]}" -o b2
expect_rc 0 "parliament-overlap3d in 10x10 blocks at np=2"
GS_STOP_AFTER_UNITS=3 run_gs 2 model -c "$C" "${B[@]}" -o bs
expect_rc 9 "parliament-overlap3d in blocks: stopped after three regions at np 2"
run_gs 0 resume bs
expect_rc 0 "parliament-overlap3d in blocks: resumed at np 1"
b0=$(digest_of b0); b2=$(digest_of b2); bs=$(digest_of bs)
[[ -n $b0 && $b0 == "$b2" && $b0 == "$bs" ]] \
  && ok "parliament-overlap3d in blocks: digest $b0 at np 1, 2 and after stop + resume" \
  || bad "parliament-overlap3d in blocks: digests $b0 $b2 $bs"
res=$(check_windows b0 blocks 0)
echo "$res" | sed 's/^/  blocks: /'
grep -q "^RESULT pass" <<<"$res" && ok "parliament-overlap3d in blocks: only example windows" \
  || bad "parliament-overlap3d in blocks: $(grep '^RESULT' <<<"$res")"

# the cap: a random 40x40x10 lattice has about 11,500 distinct 3x3x3 windows
/usr/bin/python3 -c '
import numpy as np
a = np.random.default_rng(1).integers(1, 10, size=(10, 40, 40))
open("noise.csv", "w").write("\n\n".join("\n".join(",".join(map(str, r)) for r in l) for l in a) + "\n")'
run_gs 0 model -c "$C" --set model.example="$PWD/noise.csv" -o cap
expect_rc 2 "overlap3d on 40x40x10 noise is refused"
expect_err "more than 8192 distinct 3x3x3 windows (model.overlap3d = 3)" "overlap3d cap: the error names the cap and the key"
run_gs 0 model -c "$C" --set model.start_block=4 -o bad
expect_err "not supported with model.overlap3d" "overlap3d with start_block: a clear config error"
run_gs 0 model -c "$C" --set model.fix_z_faces=true -o keptfaces
expect_err "kept uniform faces would fix every layer" "overlap3d with fix_z_faces = true: refused (the output would be the start model)"

# No floating structure where the example has none: on the generated village
# (scripts/gen-lattice.py village 7, 24x24x8: houses with walls, doors, windows and roofs,
# trees, roads), N = 3 with uniform weights (model.resemblance = 0) put one roof layer over the
# whole output in seeds 1 and 2 (every 3x3x3 window of it is the eave of an example roof;
# unsupported share 0.33 and 0.50). A region try leaving a non-empty cell without a 6-connected
# path of non-empty cells to the ground is now a failed try (the example has none). Checks
# from lattice.h5 and the example alone (scipy components): unsupported share <= the
# example's; every 3x3x3 window an example window; completeness >= 0.5 x the example's half vs
# half. Broken on purpose: params.support_empty left NULL fails the unsupported check in both
# seeds (0.327, 0.500) and completeness in seed 2 (0.044).
/usr/bin/python3 "$GS_ROOT/scripts/gen-lattice.py" village 7 village7.txt
printf '[model]\nexample = village7.txt\nsize = 32x32x8\noverlap3d = 3\nresemblance = 0\n' > village.ini
for s in 1 2; do
  run_gs 0 model -c village.ini --set run.seed=$s --set model.mesh=none -o village$s
  expect_rc 0 "village overlap3d N 3, uniform, seed $s"
  res=$(/usr/bin/python3 - village7.txt village$s <<'EOF'
import os, sys
import numpy as np
from scipy import ndimage
sys.path.insert(0, os.environ["GS_ROOT"] + "/analysis")
import lattice_measures as lm
ex = lm.read_lattice(sys.argv[1])
out = lm.read_lattice(sys.argv[2] + "/lattice.h5")
def unsupported(a):  # non-empty cells with no 6-connected non-empty path to z = 0
    lab, n = ndimage.label(a != 0)
    grounded = np.isin(lab, np.unique(lab[0]))
    return float(((a != 0) & ~grounded).sum()) / max(1, int((a != 0).sum()))
f, h = lm.figures(ex, out, ks=(3,)), lm.half_figures(ex, ks=(3,))
chk = lm.Checks()
need = chk.need
need(unsupported(out) <= unsupported(ex), "unsupported share %.3f <= the example's %.3f" % (unsupported(out), unsupported(ex)))
need(f["share_3_with_empty"] == 1.0, "every 3x3x3 window an example window: %.4f" % f["share_3_with_empty"])
need(f["completeness_3"] >= 0.5 * h["completeness_3"], "completeness %.3f >= 0.5 x example half vs half %.3f" % (f["completeness_3"], h["completeness_3"]))
chk.result()
EOF
)
  echo "$res" | sed "s/^/  village$s: /"
  grep -q "^RESULT pass" <<<"$res" && ok "village$s: no floating structure, example windows only" \
    || bad "village$s: $(grep '^RESULT' <<<"$res")"
done

# No floating structure in blocks either. A region's try checks support through the region to
# the non-empty cells next to it, which need not reach the ground themselves once the region
# replaced what held them up: on a grove (20x20x7: trunks two cells high under 5x5 and 3x3
# canopies, nothing floating), N = 2 in 10x10 blocks left 4.6-8.3% of the non-empty cells
# floating (seeds 1-3, before the top decode; canopies whose trunk a region removed). After the
# passes every floating
# piece is now resynthesized with the whole-lattice check (engine_regions.c support_repair).
# Checks from lattice.h5 and the example (scipy components): unsupported share 0 (the
# example's), every 2x2x2 window an example window, the same digest at np 1 and 2 and after a
# stop + resume.
# Broken on purpose: support_repair a no-op fails the unsupported check (seed 1: 0.0136).
/usr/bin/python3 - <<'EOF2'
import numpy as np
a = np.zeros((7, 20, 20), dtype=int)
a[0] = 1
for (x, y) in [(4, 4), (14, 5), (6, 14), (15, 15)]:
    a[1:3, y, x] = 2
    a[3, y - 2:y + 3, x - 2:x + 3] = 3
    a[4, y - 1:y + 2, x - 1:x + 2] = 3
open("grove.csv", "w").write("\n\n".join("\n".join(",".join(map(str, r)) for r in l) for l in a) + "\n")
EOF2
printf '[model]\nexample = grove.csv\nsize = 32x32x7\noverlap3d = 2\nresemblance = 0\nregion = 10x10x0\n' > grove.ini
run_gs 0 model -c grove.ini --set model.mesh=none --set model.preview=false -o grove1
expect_rc 0 "grove overlap3d N 2 in 10x10 blocks at np 1"
run_gs 2 model -c grove.ini --set model.mesh=none --set model.preview=false -o grove2
expect_rc 0 "grove overlap3d N 2 in 10x10 blocks at np 2"
GS_STOP_AFTER_UNITS=3 run_gs 2 model -c grove.ini --set model.mesh=none --set model.preview=false -o grovestop
expect_rc 9 "grove in blocks: stopped after three regions at np 2"
run_gs 0 resume grovestop
expect_rc 0 "grove in blocks: resumed at np 1 (the repair runs after the resumed passes)"
g1=$(digest_of grove1); g2=$(digest_of grove2); gs=$(digest_of grovestop)
[[ -n $g1 && $g1 == "$g2" && $g1 == "$gs" ]] && ok "grove in blocks: digest $g1 at np 1, 2 and after stop + resume" \
  || bad "grove in blocks: digests $g1 $g2 $gs"
res=$(/usr/bin/python3 - grove.csv grove1 <<'EOF2'
import os, sys
import numpy as np
from scipy import ndimage
sys.path.insert(0, os.environ["GS_ROOT"] + "/analysis")
import lattice_measures as lm
ex = lm.read_lattice(sys.argv[1])
out = lm.read_lattice(sys.argv[2] + "/lattice.h5")
def unsupported(a):  # non-empty cells with no 6-connected non-empty path to z = 0
    lab, n = ndimage.label(a != 0)
    grounded = np.isin(lab, np.unique(lab[0][lab[0] > 0]))
    return float(((a != 0) & ~grounded).sum()) / max(1, int((a != 0).sum()))
f = lm.figures(ex, out, ks=(2,))
chk = lm.Checks()
chk.need(unsupported(ex) == 0, "the example has no floating structure")
chk.need(unsupported(out) == 0, "unsupported share %.4f = the example's 0" % unsupported(out))
chk.need(f["share_2_with_empty"] == 1.0, "every 2x2x2 window an example window: %.4f" % f["share_2_with_empty"])
chk.need(f["completeness_2"] >= 0.5, "completeness 2x2x2 %.3f >= 0.5" % f["completeness_2"])
chk.result()
EOF2
)
echo "$res" | sed "s/^/  grove: /"
grep -q "^RESULT pass" <<<"$res" && ok "grove in blocks: no floating structure" || bad "grove in blocks: $(grep '^RESULT' <<<"$res")"

# The top (model.fix_z_faces = auto), on a built-in example: the generated fortress
# (scripts/gen-lattice.py fortress 7, 24x24x8: towers and walls up to z = 5, empty above).
# The lattice of patterns is N - 1 layers lower than the output; its top layer takes the
# windows whose top slice is the example's top layer, and the output's top N - 1 layers are
# those patterns' upper slices (gs_model_patterns3d_decode), as the example's top N layers are
# one window. Before, every output layer held a pattern origin: the example's 6 origin layers
# had to fill 8 output layers, so the structure was stretched up by a layer (highest
# non-empty layer 6, the example's 5, in seeds 1-3 at N = 3). Checks from lattice.h5 and the
# example: the output's top layer holds only labels of the example's top layer, and its
# highest non-empty layer is the example's; (a) N = 3, default settings, (b) N = 2, frequency
# weights, no resemblance (castle-overlap3d.ini's settings). Broken on purpose: decoding
# origins only over a full-height lattice of patterns (the old way) fails (a) (layer 6);
# without the top mask (b) fails (layer 7).
/usr/bin/python3 "$GS_ROOT/scripts/gen-lattice.py" fortress 7 fortress7.txt
printf '[model]\nexample = fortress7.txt\nsize = 32x32x8\noverlap3d = 3\n' > fortress.ini
run_gs 0 model -c fortress.ini --set model.mesh=none -o forta
expect_rc 0 "fortress overlap3d N 3, default settings"
run_gs 0 model -c fortress.ini --set model.overlap3d=2 --set model.weights=frequency --set model.resemblance=0 --set model.mesh=none -o fortb
expect_rc 0 "fortress overlap3d N 2, frequency weights, resemblance 0"
for d in forta fortb; do
  res=$(/usr/bin/python3 - fortress7.txt $d <<'EOF'
import os, sys
import numpy as np
sys.path.insert(0, os.environ["GS_ROOT"] + "/analysis")
import lattice_measures as lm
ex = lm.read_lattice(sys.argv[1])
out = lm.read_lattice(sys.argv[2] + "/lattice.h5")
top = lambda a: max([z for z in range(a.shape[0]) if a[z].any()] or [-1])
extra = set(np.unique(out[-1]).tolist()) - set(np.unique(ex[-1]).tolist())
chk = lm.Checks()
chk.need(not extra, "top layer holds only the example's top-layer labels (extra: %s)" % sorted(extra))
chk.need(top(out) == top(ex), "highest non-empty layer %d is the example's %d" % (top(out), top(ex)))
chk.result()
EOF
)
  echo "$res" | sed "s/^/  $d: /"
  grep -q "^RESULT pass" <<<"$res" && ok "$d: the top shows what the example's top shows" \
    || bad "$d: $(grep '^RESULT' <<<"$res")"
done
finish
