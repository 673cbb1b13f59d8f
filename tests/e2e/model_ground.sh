# End-to-end: the overlapping model's `ground` (WFC samples.xml: Flowers,
# Skyline, Platformer): the output's bottom row takes the patterns of the
# sample's bottom row. configs/model/wfc-overlap-flowers-ground.ini runs at
# np 1 and 2 (same digest); its picture is checked against the sample alone:
# the bottom pixel row is the sample's bottom-row colours (soil), soil colours
# (those of the sample's bottom row absent from its top half) stay out of the
# picture's upper half, and the side columns are no more covered by plants
# than the sample is (no stems along the edges). The same run without ground
# must fail the soil check. About 5 s here; the sample is fetched by `make data`.
source "$GS_ROOT/tests/e2e/lib.bash"
C=$GS_ROOT/configs/model
S=wfc/mxgmn-WaveFunctionCollapse/samples/Flowers.png
need_data "overlapping model ground (Flowers)" $S || finish

run_gs 0 model -c "$C/wfc-overlap-flowers-ground.ini" -o g1
expect_rc 0 "flowers ground at np=1"
run_gs 2 model -c "$C/wfc-overlap-flowers-ground.ini" -o g2
expect_rc 0 "flowers ground at np=2"
d1=$(digest_of g1); d2=$(digest_of g2)
[[ -n $d1 && $d1 == "$d2" ]] && ok "flowers ground: np 1 and 2 digest $d1" || bad "flowers ground: digest $d1 != $d2"
# whole grid in one region: the bottom row is solved afresh (in regions it
# also keeps the start model's soil row), so the solver's ground mask acts alone
run_gs 2 model -c "$C/wfc-overlap-flowers-ground.ini" --set model.region=0 -o whole
expect_rc 0 "flowers ground, whole grid"
run_gs 2 model -c "$C/wfc-overlap-flowers-ground.ini" --set model.ground=false -o nog
expect_rc 0 "flowers without ground"

check() {
/usr/bin/python3 - "$DATA/$S" "$1/image.png" "${2:-all}" <<'PY'
import sys
import matplotlib.image as im
import numpy as np
def rgb(p):
    a = im.imread(p)
    a = (a[..., :3] * 255).round().astype(int)
    return a[..., 0] << 16 | a[..., 1] << 8 | a[..., 2]
E, O = rgb(sys.argv[1]), rgb(sys.argv[2])
H, W = O.shape
bottom = set(E[-1].tolist())
soil = bottom - set(E[: E.shape[0] // 2].ravel().tolist())
sky = np.bincount(np.unique(E[0], return_inverse=True)[1]).argmax()
sky = np.unique(E[0])[sky]
fail = []
if not set(O[-1].tolist()) <= bottom or not soil:
    fail.append("bottom row colours %s not all from the sample's bottom row %s" % (sorted(set(O[-1].tolist())), sorted(bottom)))
if not soil <= set(O[-1].tolist()):
    fail.append("no soil on the bottom row")
if np.isin(O[: H // 2], list(soil)).any():
    fail.append("soil colours in the upper half")
above = E[: E.shape[0] - 1]
plants = (above != sky).mean()
edge = (O[: H - 1, [0, W - 1]] != sky).mean()
print("soil colours %s; plant share: sample %.3f, side columns %.3f" % (sorted(soil), plants, edge))
if edge > plants and sys.argv[3] == "all":
    fail.append("side columns %.3f covered by plants, more than the sample's %.3f" % (edge, plants))
for f in fail:
    print(f)
sys.exit(1 if fail else 0)
PY
}
check g2 && ok "flowers ground: soil on the bottom row only, no stems along the sides" || bad "flowers ground: no soil row / stems on the edges"
check whole soil && ok "flowers ground, whole grid: soil on the bottom row only" || bad "flowers ground, whole grid: no soil row"
check nog >/dev/null && bad "flowers without ground passes the soil check (check too weak)" || ok "flowers without ground: the soil check fails"
finish
