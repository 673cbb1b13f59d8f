# End-to-end: the micro engine's gallery (parameter-space exploration,
# [micro.explore], configs/micro/gallery.ini).
# - 6 candidates at np 1 and 2: identical run and candidate digests, the same
#   bytes in every candidate's .ini;
# - every candidate has mesh.ply, micro.h5, its .ini and a thumbnail PNG that
#   is not blank (background and lit pixels, several grey levels) and shows
#   both regions' colours;
# - every candidate's random distribution is realized: L1/n <= 0.05 between
#   its realized and target histograms, unassigned < 1% (issue 20);
# - round coasts: the cards' outline roughness (analysis/micro_outline.py
#   --gallery, coast over the coast opened at 1.5 units) averages
#   <= 1.10 (issue 20 item 3);
# - a candidate's .ini run alone reproduces that candidate's mesh digest;
# - the page in headless Chromium: a non-empty 1200x900 screenshot, exactly
#   6 candidate cards in the DOM, and all 6 thumbnails loaded (the page's own
#   script counts img.complete && naturalWidth > 0 into body data-loaded);
# - a gallery of a mesh file (spot.obj) at np 2;
# - bad input: a range with lo > hi, count 0, an unknown function, too many
#   range values, micro.instances != 1: exit 2 naming file:line and key.
# PNGs are read with PIL (python3-pil, pulled in by python3-matplotlib).
source "$GS_ROOT/tests/e2e/lib.bash"
GAL=$GS_ROOT/configs/micro/gallery.ini
MESHES=$DATA/meshes
N=6
SMALL=(--set micro.explore.count=$N --set "micro.explore.scale_units=5, 8"
       --set micro.explore.thumbnail=160)

# ---- determinism over rank counts ----
declare -A dg
for np in 1 2; do
  run_gs $np micro -c "$GAL" -o g$np "${SMALL[@]}"
  expect_rc 0 "gallery of $N at np=$np"
  dg[$np]=$(digest_of g$np 2>/dev/null)
done
if [[ -n "${dg[1]}" && "${dg[1]}" == "${dg[2]}" ]]; then
  ok "gallery digest identical at np 1 and 2 (${dg[1]})"
else
  bad "gallery digests differ: np1 ${dg[1]} np2 ${dg[2]}"
fi
same_ini=1
for i in $(seq -f %03g 0 $((N - 1))); do
  # the .ini names its own run directory (run.output); everything else is equal
  cmp -s <(grep -v '^output = ' g1/gallery/candidate-$i/candidate-$i.ini) \
         <(grep -v '^output = ' g2/gallery/candidate-$i/candidate-$i.ini) || same_ini=0
done
[[ $same_ini == 1 ]] && ok "candidate configs identical at np 1 and 2" || bad "candidate .ini files differ between np 1 and 2"

# ---- files, thumbnails, summary ----
/usr/bin/python3 - g1 g2 $N <<'EOF' && ok "$N candidates with mesh, micro.h5, .ini and non-blank thumbnails" || bad "gallery files (see above)"
import json, os, sys
from PIL import Image
run, other, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
bad = []
def check(cond, msg):
    if not cond: bad.append(msg)
summ = json.load(open(os.path.join(run, "summary.json")))
cand = json.load(open(os.path.join(run, "gallery", "candidates.json")))
cand2 = json.load(open(os.path.join(other, "gallery", "candidates.json")))
check(len(cand) == n, "%d candidates expected, got %d" % (n, len(cand)))
check([c["digest"] for c in cand] == [c["digest"] for c in cand2], "candidate digests differ np 1 / 2")
check(len(set(c["digest"] for c in cand)) == n, "candidates are not all different")
check(len(set(round(c["scale_units"], 9) for c in cand)) == n, "u was not drawn per candidate")
check(all(5 <= c["scale_units"] <= 8 for c in cand), "u outside the range 5, 8")
check(summ["metrics"]["candidates"] == n and summ["metrics"]["violations"] == 0,
      "summary metrics: %s" % summ["metrics"])
# Issue 20 item 2: every random distribution is realized: L1/n <= 0.05 between
# the realized and the target histograms (both in the card), unassigned < 1%.
for c in cand:
    t, r = c["target_count"], c["realized_count"]
    l1 = sum(abs(a - b) for a, b in zip(t, r)) / c["triangles"]
    check(abs(l1 - c["realized_l1"]) < 1e-9, "%s: realized_l1 is not the histograms' L1/n" % c["dir"])
    check(l1 <= 0.05 and c["unassigned_share"] < 0.01,
          "%s: realized L1/n %.4f (<= 0.05), unassigned %.4f (< 0.01)" % (c["dir"], l1, c["unassigned_share"]))
print("  realized L1/n per candidate: %s" % ", ".join("%.3f" % c["realized_l1"] for c in cand))
bg = None
for c in cand:
    d = os.path.join(run, "gallery", c["dir"])
    for f in ("mesh.ply", "micro.h5", c["dir"] + ".ini", "thumb.png"):
        check(os.path.getsize(os.path.join(d, f)) > 0, "%s/%s missing or empty" % (d, f))
    im = Image.open(os.path.join(d, "thumb.png")).convert("RGB")
    check(im.size == (160, 160), "%s thumbnail size %s" % (c["dir"], im.size))
    px = list(im.getdata())
    corner = px[0]
    bgn = sum(1 for p in px if p == corner)
    lit = [p for p in px if p != corner]
    warm = sum(1 for p in lit if p[0] > p[2] + 30)
    cool = sum(1 for p in lit if p[2] > p[0] + 30)
    levels = len(set(p[1] for p in lit))
    check(0.2 * len(px) < bgn < 0.9 * len(px), "%s: %d of %d background pixels" % (c["dir"], bgn, len(px)))
    check(levels >= 20, "%s: only %d grey levels in the lit part (flat?)" % (c["dir"], levels))
    check(warm > 50 or cool > 50, "%s: no region colours (warm %d, cool %d)" % (c["dir"], warm, cool))
    print("  %s: u %.3f, %d triangles, %d background / %d lit pixels (warm %d, cool %d), %d levels, digest %s"
          % (c["dir"], c["scale_units"], c["triangles"], bgn, len(lit), warm, cool, levels, c["digest"]))
for b in bad: print("  " + b)
sys.exit(1 if bad else 0)
EOF

# ---- round coasts (issue 20 item 3) ----
# The cards' regions are unions of discs (a Boolean model), so their coasts
# must be round arcs, not staircases: analysis/micro_outline.py's roughness
# (coast length over the coast opened at 1.5 units) averaged over
# the cards within 10% of an ideal union of discs drawn on the same meshes
# (1.00-1.07); the correction started from the reconstruction's regions and
# run on to 0.02 gives 1.175 on gallery.ini.
rough=$(/usr/bin/python3 "$GS_ROOT/analysis/micro_outline.py" --gallery g1 --json 2>&1)
/usr/bin/python3 -c 'import json,sys;r=json.loads(sys.argv[1]);print("  roughness per card: %s; mean %.3f" % (", ".join("%.3f" % c["roughness"] for c in r["cards"]), r["roughness_mean"]));sys.exit(0 if r["roughness_mean"] <= 1.10 else 1)' "$rough" \
  && ok "card coasts are round (roughness mean <= 1.10)" || bad "card coasts are jagged (roughness mean > 1.10): ${rough:0:300}"
# The engine measures the same per card (src/measure/outline.c, in
# candidates.json): equal to analysis/micro_outline.py's to 1e-9.
/usr/bin/python3 -c 'import json,sys;r=json.loads(sys.argv[1]);c=json.load(open(sys.argv[2]));e=[x["outline_roughness"] for x in c];a=[x["roughness"] for x in r["cards"]];print("  engine per card: %s" % ", ".join("%.3f" % x for x in e));sys.exit(0 if len(e)==len(a) and all(abs(x-y)<=1e-9 for x,y in zip(e,a)) else 1)' "$rough" g1/gallery/candidates.json \
  && ok "engine's outline roughness per card equals analysis/micro_outline.py's" || bad "engine's outline roughness differs from analysis/micro_outline.py's"
# summary.json aggregates the cards as the instances' run does: all coasts
# over all smoothed coasts, and the worst card.
/usr/bin/python3 -c 'import json,sys;c=json.load(open(sys.argv[1]));m=json.load(open(sys.argv[2]))["metrics"];r=[x for x in c if x["outline_roughness"] is not None];L=sum(x["outline_length"] for x in r);S=sum(x["outline_length"]/x["outline_roughness"] for x in r);print("  summary %.6f / max %.6f, cards %.6f / %.6f" % (m["outline_roughness"], m["outline_roughness_max"], L/S, max(x["outline_roughness"] for x in r)));sys.exit(0 if abs(m["outline_roughness"]-L/S)<=1e-9 and m["outline_roughness_max"]==max(x["outline_roughness"] for x in r) else 1)' g1/gallery/candidates.json g1/summary.json \
  && ok "summary.json's outline_roughness aggregates the cards" || bad "summary.json's outline_roughness does not aggregate the cards"

# ---- one candidate alone reproduces its mesh ----
run_gs 1 micro -c g2/gallery/candidate-003/candidate-003.ini -o solo
expect_rc 0 "candidate-003.ini run alone"
want=$(/usr/bin/python3 -c 'import json,sys;print(json.load(open(sys.argv[1]))[3]["digest"])' g1/gallery/candidates.json)
got=$(/usr/bin/python3 -c 'import json,sys;print(json.load(open(sys.argv[1]))[0]["digest"])' solo/instances.json 2>/dev/null)
[[ -n "$want" && "$want" == "$got" ]] && ok "candidate-003.ini reproduces the candidate's mesh digest ($got)" \
  || bad "candidate-003 digest: gallery $want, alone $got"
cmp -s g1/gallery/candidate-003/mesh.ply solo/instance-0000/mesh.ply && ok "reproduced mesh.ply is byte-identical" \
  || bad "reproduced mesh.ply differs"

# ---- the page in headless Chromium ----
chrome() {
  local profile
  profile=$(mktemp -d)
  timeout 120 /usr/bin/chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
    --disable-background-networking --disable-component-update --disable-sync \
    --user-data-dir="$profile" --virtual-time-budget=3000 "$@" 2>chrome.err
  local r=$?
  rm -rf "$profile"
  return $r
}
page="file://$PWD/g1/gallery/index.html"
chrome --screenshot="$PWD/shot.png" --window-size=1200,900 "$page" >/dev/null
/usr/bin/python3 - shot.png <<'EOF' && ok "Chromium screenshot of the gallery: 1200x900, not blank" || bad "screenshot (chrome.err: $(tail -c 300 chrome.err))"
import sys
from PIL import Image
im = Image.open(sys.argv[1]).convert("RGB")
colours = len(set(im.getdata()))
print("  screenshot %dx%d, %d colours" % (im.size[0], im.size[1], colours))
sys.exit(0 if im.size == (1200, 900) and colours > 500 else 1)
EOF
chrome --dump-dom "$page" >dom.html
cards=$(grep -o 'class="card"' dom.html | wc -l)
[[ $cards == "$N" ]] && ok "the page lists exactly $N candidate cards" || bad "page has $cards cards, expected $N"
body=$(grep -o '<body[^>]*>' dom.html)
grep -q "data-loaded=\"$N\"" <<<"$body" && grep -q 'data-failed="0"' <<<"$body" \
  && ok "all $N thumbnails loaded in Chromium ($body)" || bad "thumbnails did not load: $body"
grep -q 'candidate-003.ini' dom.html && grep -q 'micro.explore' dom.html \
  && ok "cards carry the config text and the .ini link" || bad "config text or .ini link missing from the page"

# ---- a mesh file ----
cat > spot.ini <<EOF
[micro]
shape = file
mesh = $MESHES/spot.obj
scale_units = 5
dist = random
[micro.explore]
enable = yes
count = 2
thumbnail = 96
EOF
run_gs 2 micro -c spot.ini -o spot
expect_rc 0 "gallery of spot.obj at np=2"
[[ -s spot/gallery/candidate-001/thumb.png && -s spot/gallery/index.html ]] && ok "spot.obj gallery written" \
  || bad "spot.obj gallery files missing"

# ---- bad inputs ----
printf '[micro]\n[micro.explore]\nenable = yes\npos_scale = 0.05, 0.01\n' > b1.ini
run_gs 1 micro -c b1.ini -o b1
expect_rc 2 "range with lo > hi"
expect_err "b1.ini:4: [micro.explore] pos_scale = 0.05, 0.01: range 'lo, hi' has lo = 0.05 > hi = 0.01" \
  "lo > hi names file, line and key"

printf '[micro]\n[micro.explore]\nenable = yes\ncount = 0\n' > b2.ini
run_gs 2 micro -c b2.ini -o b2
expect_rc 2 "count 0"
expect_err "b2.ini:4: [micro.explore] count = 0" "count 0 names file, line and key"
expect_no_crash "count 0"

printf '[micro]\n[micro.explore]\nenable = yes\nneg_func = sqrt, cubic\n' > b3.ini
run_gs 1 micro -c b3.ini -o b3
expect_rc 2 "unknown function"
expect_err "b3.ini:4: [micro.explore] neg_func = sqrt, cubic: unknown choice 'cubic'" "unknown function named"

printf '[micro]\ninstances = 3\n[micro.explore]\nenable = yes\nscale_units = 4, 5, 6\n' > b4.ini
run_gs 1 micro -c b4.ini -o b4
expect_rc 2 "three range values and instances = 3"
expect_err "b4.ini:5: [micro.explore] scale_units = 4, 5, 6: expected a range 'lo, hi' or one fixed value" \
  "too many range values named"
expect_err "b4.ini:2: [micro] instances = 3: must be 1 with micro.explore.enable = yes" \
  "instances with a gallery explained (all problems at once)"

finish
