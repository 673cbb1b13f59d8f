# End-to-end: a small real campaign (jobs/campaign.sh --local: field quick,
# micro quick, model demo at np 1 and 2) turned into a report by
# analysis/report.py, opened in headless Chromium: every figure must load
# (the page marks each <img> with data-loaded, the body with data-images)
# and the run table must have one row per run. The matcher figure comes from
# tests/e2e/data/bench_field.json (bench_field --sizes 32/8 output).
source "$GS_ROOT/tests/e2e/lib.bash"
PY=/usr/bin/python3
export GEOSYNTH=$GS_BIN
cout=$("$GS_ROOT/jobs/campaign.sh" "$GS_ROOT/jobs/campaigns/small.campaign" --local --out camp 2>&1)
rc=$?
[[ $rc -eq 0 ]] && ok "campaign small (6 runs, local mpirun) finished" || bad "campaign.sh --local (rc=$rc): $(tail -c 800 <<<"$cout")"
n=$(ls camp/*/summary.json 2>/dev/null | wc -l)
[[ $n -eq 6 ]] && ok "6 runs wrote summary.json into one campaign folder" || bad "$n summary.json files"
again=$("$GS_ROOT/jobs/campaign.sh" "$GS_ROOT/jobs/campaigns/small.campaign" --local --out camp 2>&1)
[[ $(grep -c "done already" <<<"$again") -eq 6 ]] && ok "a second campaign.sh skips the finished runs" || bad "rerun: $again"

rout=$($PY "$GS_ROOT/analysis/report.py" camp --bench "$GS_ROOT/tests/e2e/data/bench_field.json" 2>&1)
rc=$?
[[ $rc -eq 0 && -f camp/report/index.html ]] && ok "report.py wrote camp/report/index.html" || bad "report.py (rc=$rc): $rout"
nfig=$(ls camp/report/*.png 2>/dev/null | wc -l)
# scaling, phases, matchers, micro histograms, field slices, lattice slices, 3 mesh renders
[[ $nfig -eq 9 ]] && ok "9 figures written" || bad "$nfig figures: $(ls camp/report)"
# every mesh figure draws the whole mesh (#23: 20,000 random faces of the model
# demo's 31,752 showed a plate with towers missing): its caption's drawn count
# equals the face count of the mesh file's PLY header
if $PY - camp/report/index.html camp <<'PY'
import glob, re, sys
page = open(sys.argv[1]).read()
caps = sorted(set(re.findall(r"output mesh \(([^)]*)\), (\d+) of (\d+) faces drawn", page)))
assert len(caps) == 3, caps
for d, drawn, total in caps:
    ply = sorted(glob.glob(sys.argv[2] + "/" + d + "/**/*.ply", recursive=True))[0]
    head = open(ply, "rb").read(2000).split(b"end_header")[0].decode()
    faces = int(re.search(r"element face (\d+)", head).group(1))
    assert int(drawn) == int(total) == faces, (d, drawn, total, faces)
    print(d, faces, "faces drawn")
PY
then ok "mesh figures draw every face of the mesh file (captions = PLY face counts)"
else bad "a mesh figure drops faces: $(grep -o 'output mesh[^.]*' camp/report/index.html)"; fi
# and looks like the whole mesh: the model demo's figure against a render of
# its full mesh.ply by the same built-in renderer (dropping 1/3 of the faces
# opens holes in the walls and changes ~10% of the object's pixels)
d=$(ls -d camp/model-demo-np1-* | head -1)
"$GS_BIN" -q preview --out full.png --size 512 "$d/mesh.ply" >/dev/null 2>&1
if $PY - full.png "camp/report/mesh_$(basename "$d").png" <<'PY'
import sys, numpy as np, matplotlib.image as mi
a, b = (mi.imread(p)[..., :3] for p in sys.argv[1:3])
assert a.shape == b.shape, (a.shape, b.shape)
obj = np.abs(a - a[0, 0]).sum(axis=2) > 0.05   # not background
diff = (np.abs(a - b).sum(axis=2) > 0.05) & obj
print("object pixels", obj.sum(), "differing", diff.sum())
sys.exit(0 if diff.sum() <= 0.01 * obj.sum() else 1)
PY
then ok "the model mesh figure matches a render of the full mesh.ply"
else bad "the model mesh figure differs from a render of the full mesh.ply"; fi
for f in scaling phases matchers; do
  [[ -s camp/report/$f.png ]] && ok "figure $f.png" || bad "no $f.png"
done
ls camp/report/micro_*.png camp/report/field_*.png camp/report/lattice_*.png >/dev/null 2>&1 \
  && ok "micro histogram, field slice and lattice slice figures" || bad "data figures missing: $(ls camp/report)"

chromium=(/usr/bin/chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run
  --disable-background-networking --disable-component-update --disable-sync
  --user-data-dir="$(mktemp -d)" --virtual-time-budget=3000)
page=file://$PWD/camp/report/index.html
dom=$(timeout 120 "${chromium[@]}" --dump-dom "$page" 2>/dev/null)
[[ -n "$dom" ]] && ok "headless Chromium rendered the page" || bad "chromium --dump-dom gave nothing"
grep -q "data-images=\"$nfig/$nfig\"" <<<"$dom" && ok "Chromium: all $nfig figures loaded" \
  || bad "figures not all loaded: $(grep -o 'data-images="[^"]*"' <<<"$dom")"
nno=$(grep -o 'data-loaded="no"' <<<"$dom" | wc -l)
[[ $nno -eq 0 ]] && ok "no image marked not loaded" || bad "$nno images did not load"
rows=$(grep -o '<tr class="run">' <<<"$dom" | wc -l)
[[ $rows -eq 6 ]] && ok "run table has 6 rows" || bad "run table has $rows rows"
agree=$(grep -o 'class="l good">yes' <<<"$dom" | wc -l)
[[ $agree -eq 6 ]] && ok "every run's digest agrees with its other rank count" || bad "$agree of 6 runs agree"
timeout 120 "${chromium[@]}" --window-size=1280,2400 --screenshot="$PWD/report.png" "$page" >/dev/null 2>&1
[[ -s report.png ]] && ok "screenshot of the report ($(stat -c %s report.png) bytes)" || bad "no screenshot"
[[ -n "${GS_KEEP_REPORT:-}" ]] && cp -r camp/report report.png "$GS_KEEP_REPORT"/ 2>/dev/null

# A differing digest shows in the table and fails the report.
/usr/bin/python3 -c 'import json,sys; p=sys.argv[1]; s=json.load(open(p)); s["digest"]="f"+s["digest"][1:] if s["digest"][0]!="f" else "e"+s["digest"][1:]; json.dump(s,open(p,"w"))' camp/model-demo-np2-s1/summary.json  # the run digest (outputs carry digests too)
$PY "$GS_ROOT/analysis/report.py" camp >/dev/null 2>&1
rc=$?
[[ $rc -eq 1 ]] && grep -q 'class="l bad">NO' camp/report/index.html && ok "a differing digest is flagged (exit 1)" \
  || bad "tampered digest not flagged (rc=$rc)"
finish
