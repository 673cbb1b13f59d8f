# End-to-end: the warp (paper section 5.2) on the same patches. A run
# without the warp places the source patches the warped run chose
# (points.choices = its patches.csv), so the two outputs differ by the warp
# alone, not by the layout the search draws after the first patch. On
# chainmail.ini (8 x 8; the blend's hole fill off, so the fill does not
# close what the warp should: with it, seed 1, patch_seam_open 0.072 with
# the warp, 0.084 without; seam_open_segments 0.012, 0.119):
# - fewer points by a patch boundary find no surface of the other patch
#   across it (patch_seam_open, from points.ply's patch ids) with the warp
#   than without it; the warp disabled in the code gives the same patches
#   the same seams and fails this;
# - pooled over seeds 1-3 (one seed is a lottery): that share within 1.25 x
#   the example's (cut into cells: its chance level) up to its sampling
#   error, the gain on the same patches above twice its sampling error,
#   and fewer patch edges open across the seam than without the warp;
# - the seams are closer and their normals agree better with the warp
#   than without it on the same patches (patch_seam_dist, patch_seam_angle:
#   each point by a patch boundary against the other patch's surface): the
#   warp a patch takes (none, the pairs' spline or their normal parts'),
#   judged by the seams of the output with the patch pasted on trial
#   (points.warp_select_seams); with the spline the paper's way (judged by
#   the gap before the blend) the seams' angle came out worse (23.8 vs 22.2
#   degrees, chainmail 8 x 8 seed 1), and the warp disabled in the code
#   gives the same seams and fails these;
# - the warp lifts no point above the example's top beyond the ones the
#   same patches put there without it (points_above_example_max; the
#   spline's swing between pairs put ~130 per run there before
#   points.warp_height_bound), and the same run with the bound off puts
#   more there than with it;
# - with points.warp_fade = 1 the warp moves only the overlap strips of a
#   warped patch (its inside stays the example's own: no stretched rings);
#   whole objects (flowers.ini) still move by the spline at their centre,
#   unfaded: their heights stay as close to the example's as its halves
#   are (faded like the surface: KS 0.125 against the halves' 0.081);
# - in the default output (hole fill and strip resampling on), at the seams
#   by the patches the warp acted on, fewer points are broken (no surface
#   of the other patch across, or one farther off than 9 in 10 of the
#   example's inside fits: patch_far_dist) with the warp than without it on
#   the same patches, by more than the figure's sampling error.
source "$GS_ROOT/tests/e2e/lib.bash"
C=$GS_ROOT/configs/points/chainmail.ini
metric() { /usr/bin/python3 -c 'import json,sys;print(json.load(open(sys.argv[1]+"/summary.json"))["metrics"][sys.argv[2]])' "$1" "$2"; }
lt() { /usr/bin/python3 -c 'import sys; sys.exit(0 if float(sys.argv[1]) < float(sys.argv[2]) else 1)' "$@"; }
# The strip resampling is off too: its darts redraw the strips and take
# patch ids of their own, noise of the size of the warp's gain in
# patch_seam_angle (24.58 vs 24.58 degrees), and close open surfaces at the
# seams as well (seam_open_segments 0.083 -> 0.036 on seed 1).
small=(--set points.out_points=0 --set points.out_size=8,8 --set output.preview=false
       --set points.blend_fill=false --set output.patch_metrics=true
       --set points.strip_resample=false)

# warp_pair W S WHAT ARGS...: chainmail with the warp into W, then without
# it (no pairs: no spline) on W's patches into S
warp_pair() {
  local w=$1 s=$2 what=$3
  shift 3
  run_gs 2 points -c "$C" -o "$w" "$@"
  expect_rc 0 "chainmail ($what) with the warp"
  run_gs 2 points -c "$C" -o "$s" "$@" --set points.max_pair_dist=0.000001 \
    --set points.choices="$PWD/$w/patches.csv"
  expect_rc 0 "chainmail ($what) without the warp, on the warped run's patches"
}
warp_pair warp same "8 x 8" "${small[@]}"
for sd in 2 3; do
  warp_pair warp$sd same$sd "8 x 8, seed $sd" "${small[@]}" --set run.seed=$sd
done
run_gs 2 points -c "$C" -o unbound "${small[@]}" --set points.warp_height_bound=false \
  --set points.choices="$PWD/warp/patches.csv"
expect_rc 0 "chainmail (8 x 8) with the warp unbounded in height, on the same patches"
run_gs 2 points -c "$C" -o fade "${small[@]}" --set points.warp_fade=1 \
  --set points.choices="$PWD/warp/patches.csv"
expect_rc 0 "chainmail (8 x 8) with the warp faded across the strips, on the same patches"

w=$(metric warp patches_warped)
[[ $w -gt 0 ]] && ok "$w patches warped" || bad "no patch warped"
o1=$(metric warp patch_seam_open) o0=$(metric same patch_seam_open)
lt "$o1" "$o0" && ok "warp: points at patch boundaries with no surface across $o1 with the warp, $o0 without (same patches)" ||
  bad "warp: points at patch boundaries with no surface across $o1 with the warp, $o0 without on the same patches (expected fewer with)"
for k in patch_seam_dist patch_seam_angle; do
  w1=$(metric warp $k) w0=$(metric same $k)
  # lower by more than rounding: the trial pastes put the output's points
  # back in another order, so the sums differ in the last digits
  lt "$w1" "$(/usr/bin/python3 -c 'import sys; print(float(sys.argv[1]) * (1 - 1e-9))' "$w0")" && ok "warp: $k $w1 with the warp, $w0 without (same patches)" ||
    bad "warp: $k $w1 with the warp, $w0 without on the same patches (expected lower with)"
done
# Pooled over seeds 1-3: one seed is a lottery (chainmail 8 x 8, seeds
# 1-8: the share of seam points with no surface across 0.057-0.122 with
# the warp, 0.067-0.130 on the same patches without it; the warp's gain on
# the same patches 0.0026-0.0117, lower on all 8):
# - the share of points by a patch boundary with no surface of the other
#   patch across (patch_seam_open, points.ply's patch ids), the three runs'
#   seam points together, is within 1.25 x what the same measure gives on
#   the example cut into cells as far apart (example_patch_seam_open: no
#   seam there, its chance level; 0.0767, so 0.0959), less two sampling
#   errors of the mean (the seeds' standard deviation over sqrt(3));
#   measured 0.0738 (seeds 1-8 pooled 0.0854; seeds 4-6 alone 0.1069, over
#   the bound by 1.2 errors);
# - without the warp on the same patches more are open: the mean per-seed
#   difference is above two sampling errors of it (measured: 0.0805
#   pooled; differences 0.0065 0.0096 0.0050, 5.2 errors; seeds 4-6 3.0,
#   6-8 3.2). A warp pasted unwarped or no spline passed gives the same
#   points on both sides: difference 0, this fails;
# - the share of patch edges where the surface is more often open across
#   the seam than on 9 in 10 edges inside the patches (seam_open_segments,
#   0.1 when the seams are like the inside) is lower with the warp than
#   without, in the mean (0.131 vs 0.171; lower on each of seeds 1-8). Not
#   met on every seed: twice the inside's, 0.2 (seeds 1-8 mean 0.246 with
#   the warp, 0.296 without; seeds 5 and 6 0.56 and 0.49: seams along rows
#   of rings), so that bound is not checked.
out=$(/usr/bin/python3 - warp,same warp2,same2 warp3,same3 <<'PY'
import json, math, sys
def m(d):
    return json.load(open(d + "/summary.json"))["metrics"]
runs = [[m(d) for d in a.split(",")] for a in sys.argv[1:]]
k = len(runs)
def pooled(i):
    n = sum(r[i]["patch_seam_points"] for r in runs)
    return sum(r[i]["patch_seam_open"] * r[i]["patch_seam_points"] for r in runs) / n
def err(v):
    mv = sum(v) / len(v)
    return math.sqrt(sum((x - mv) ** 2 for x in v) / (len(v) - 1) / len(v))
pw, p0 = pooled(0), pooled(1)
ew = err([r[0]["patch_seam_open"] for r in runs])
bound = 1.25 * runs[0][0]["example_patch_seam_open"]
d = [r[1]["patch_seam_open"] - r[0]["patch_seam_open"] for r in runs]
md, ed = sum(d) / k, err(d)
sw = sum(r[0]["seam_open_segments"] for r in runs) / k
s0 = sum(r[1]["seam_open_segments"] for r in runs) / k
print("open seam points pooled %.4f with the warp (error %.4f; bound 1.25 x the example's %.4f), "
      "%.4f without on the same patches, per-seed differences %s (mean %.4f, error %.4f); "
      "open patch edges %.3f with, %.3f without"
      % (pw, ew, bound / 1.25, p0, " ".join("%.4f" % x for x in d), md, ed, sw, s0))
sys.exit(0 if pw - 2 * ew < bound and md > 2 * ed and sw < s0 else 1)
PY
)
[[ $? -eq 0 ]] && ok "warp, seeds 1-3: $out" || bad "warp, seeds 1-3: $out"
a1=$(metric warp points_above_example_max) a0=$(metric same points_above_example_max)
au=$(metric unbound points_above_example_max)
[[ $a1 -le $a0 ]] && ok "warp: $a1 points above the example's top with the warp, $a0 without (same patches)" ||
  bad "warp: $a1 points above the example's top with the warp, $a0 without on the same patches (expected no more)"
[[ $au -gt $a1 ]] && ok "height bound: $au points above the example's top without it, $a1 with it" ||
  bad "height bound: $au points above the example's top without it, $a1 with it (expected more without)"
# With points.warp_fade = 1 the warp stays in the overlap strips: a warped
# patch's points past its strips' inner edge are the example's own, the
# same as on the same patches unwarped. The strips cover 1 - (1 - 4/12)^2
# = 0.56 of a patch's visible area here (overlap 4 of a 12-cell step;
# 0.53-0.59 moved on the layouts tried); with the spline left everywhere
# (warp_fade = 0, or the fade broken) every point of a warped patch moves
# (1.00) and the rings past the strips stretch.
moved=$(/usr/bin/python3 - "$GS_ROOT/analysis" fade same <<'PY'
import csv, sys
import numpy as np
from scipy.spatial import cKDTree
sys.path.insert(0, sys.argv[1])
from point_seams import read_points
va, pa = read_points(sys.argv[2] + "/points.ply")
vb, _ = read_points(sys.argv[3] + "/points.ply")
warped = [int(r["patch"]) for r in csv.DictReader(open(sys.argv[2] + "/patches.csv"))
          if int(r["warp"]) > 0]
m = np.isin(pa, warped)
d, _ = cKDTree(vb[:, :3]).query(va[m, :3])
print("%.3f" % ((d > 1e-5).mean() if m.any() else 1))
PY
)
lt "$moved" 0.75 && ok "warp fade: $moved of the warped patches' points moved by the warp (the strips: ~0.56 of a patch)" ||
  bad "warp fade: $moved of the warped patches' points moved by the warp (expected < 0.75: only the strips, ~0.56 of a patch)"
# Whole objects are not faded: one translation each, nothing to strain.
run_gs 2 points -c "$GS_ROOT/configs/points/flowers.ini" -o flfade --set points.warp_fade=1 \
  --set output.preview=false
expect_rc 0 "flowers.ini with points.warp_fade = 1"
ks=$(metric flfade height_ks) ksh=$(metric flfade example_height_ks_halves)
lt "$ks" "$ksh" && ok "warp fade: whole flowers' heights KS $ks (the example's halves $ksh)" ||
  bad "warp fade: whole flowers' heights KS $ks, the example's halves $ksh (expected below: objects move by the unfaded spline)"

# The default output: the hole fill and the strip resampling on. The
# resampling's darts are drawn in one seeded order over the whole output, so
# the two runs differ at seams the warp never touched too (22% of the points
# outside the warped patches move, 9.5% with the resampling off), and the
# warp acts on few patches (5 of 48 here: points.warp_select_seams keeps a
# warp only where its trial seams are no worse): the whole output's means
# drown its gain (patch_seam_angle 24.58 vs 24.58 with the hole fill off,
# 22.84 vs 22.72 with it). Measured where
# the warp acted (analysis/point_seams.py --patches: seam points by a patch
# the warped run warped, in both runs) and as the broken share (open points
# count: the mean distance leaves them out, and on seed 1 the warp closes
# 0.120 -> 0.079 of them, which raises the mean over the rest).
dflt=(--set points.out_points=0 --set points.out_size=8,8 --set output.preview=false
      --set output.patch_metrics=true)
warp_pair dwarp dsame "8 x 8, default output" "${dflt[@]}"
read -r b1 b0 se n1 n0 < <(/usr/bin/python3 - "$GS_ROOT/analysis" dwarp dsame <<'PY'
import json, math, subprocess, sys
r = [json.loads(subprocess.run([sys.executable, sys.argv[1] + "/point_seams.py", d, "--patches",
                                "dwarp/patches.csv"], capture_output=True, text=True,
                               check=True).stdout) for d in sys.argv[2:4]]
b0, n0 = r[1]["patch_seam_broken"], r[1]["patch_seam_points"]
print("%.4f %.4f %.4f %d %d" % (r[0]["patch_seam_broken"], b0,
                                math.sqrt(b0 * (1 - b0) / n0) if n0 else 0, r[0]["patch_seam_points"], n0))
PY
)
[[ ${n1:-0} -gt 0 ]] && ok "default output: $n1 seam points by warped patches" ||
  bad "default output: no seam point by a warped patch"
lt "$b1" "$(/usr/bin/python3 -c 'import sys; print(float(sys.argv[1]) - float(sys.argv[2]))' "$b0" "$se")" &&
  ok "default output: broken seam points by the warped patches $b1 with the warp, $b0 without (same patches; sampling error $se)" ||
  bad "default output: broken seam points by the warped patches $b1 with the warp, $b0 without on the same patches (expected lower by more than the sampling error $se)"
finish
