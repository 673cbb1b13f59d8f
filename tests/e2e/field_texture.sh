# End-to-end: configs/field/texture.ini (discs of EmbarkStudios' embark-5.png
# as a height field, 64x52x16 -> 128x128x16; fetched data, skipped without
# it) keeps the example's statistics on every seed (#19 item 2): per seed
# 1-6, surface per volume and volume fraction within 10% of the source's
# (summary.json, measured from the output and the source alone), largest
# verbatim copy at most a quarter of the source.
# Why it failed before (field19): a source block lies inside the example, so
# the discs in its middle were copied more often than its white border (disc
# cover 0.288 in the example, 0.30-0.44 in the outputs): surface/volume +8%
# to +20% on seeds 1-12. field.wrap = xy (the example as a tile) and
# field.keep_volume (exact ties toward the source's volume fraction): seeds
# 1-12 -9.1% to +5.1%.
# Broken on purpose, each fails here (field19, watched): field.wrap = none
# (seeds 1-4 +11.1% to +13.4%); field.keep_volume = no (seed 4 -11.0%);
# wrap_level in src/field/synth.c returning before it pads (seeds 1, 2 +11.1%,
# +13.1%). Env
# TEXTURE_SEEDS, TEXTURE_SET (extra --set): other seeds, or a setting to break
# it on purpose. About 7 s a seed on one core.
# Also (#19, field25): the layout of the discs in summary.json (layout_*,
# src/measure/layout.c) equals analysis/field_layout.py's on the first seed
# (fails when either changes alone); and field.keep_volume with target
# regions (region_blocks 4) gives one digest at 1 and 2 ranks (broken on
# purpose, region_volume in src/field/synth.c returning at once so a region
# reads the running count of whatever ran before it: seed 1 10f8eae667480fdc
# at 1 rank, 3aad04e5ff162ce0 at 2) with the statistics still within 10%.
# Also (#19, field29): the discs spaced as the example's. Over seeds 1-6
# (pooled), the share of discs with a neighbour nearer than any two in the
# example (its close share: 0) among the guarded discs (layout_guarded_*:
# centres at least the example's largest spacing plus its largest disc
# radius from every face, so no neighbour within the example's spacing is
# cut by the box) is at most one disc in the example's count of them
# (1/layout_objects_src: 0.1 for embark-5's 10). Before field.object_spacing
# 0.21 (close pairs in every seed, 0.10-0.42); with it 0.038. Broken on
# purpose (watched): TEXTURE_SET="--set field.object_spacing=0" fails it
# (0.21); object_exclusions in src/field/synth.c returning before it marks
# fails it too. field.object_spacing with region_blocks > 0 is refused by
# name (it reads the whole target's provenance).
# Also (#19 whole objects, field36): discs not cut into fragments. Over seeds
# 1-6 (pooled) the share of the measured discs (touching no face) smaller
# than 3/4 of the example's smallest (layout_fragment_share_out; the
# example's own: 0) is at most one disc in four examples' worth of discs
# (1/(4 layout_objects_src): 0.025 for embark-5's 10). With the 3D seam cut
# 9 of 233 (0.039): a column's lower samples from one piece and its upper
# ones from another cut discs; field.seam_columns (the cut keeps columns
# whole) 2 of 235 (0.009). Broken on purpose (watched):
# TEXTURE_SET="--set field.seam_columns=no" fails it (0.039); the column
# edges' capacity in src/field/seamcut.c left at the 3D cut's fails it too.
# Fresh seeds still showed fragments (13-24: 11 of 459, 25-36: 18 of 450):
# the bound held for these seeds, not for every six.
# Also (#19 whole objects, field40): discs neither cut nor merged (two glued,
# or one grown by a piece of another at a seam: layout_merged_share_out,
# reaching half a sample past the example's largest disc radius). Over seeds
# 1-6 the fragments plus merged discs, pooled, share + 2 standard errors at
# most 1/layout_objects_src (one disc in the example's count: 0.1). Before
# field.object_continue / object_same 0.1: 31 of 235 (0.132, upper 0.176);
# with them 7 of 255 (0.027, upper 0.048); fresh seeds 13-24 13 of 501.
# Broken on purpose (watched): TEXTURE_SET="--set field.object_same=0.25"
# fails it; TEXTURE_SET="--set field.object_continue=no" (same 0.1) passes
# it (10 of 227: object_same does most for merged discs) but fails the
# fragment check above (8 of 227, 0.035) and seed 2's surface/volume
# (-0.104). Fresh seeds 13-24 without object_continue: 12 fragments of 459,
# with it 2 of 501.
source "$GS_ROOT/tests/e2e/lib.bash"
X=$GS_ROOT/configs/field/texture.ini
if need_config "texture.ini statistics" "$X"; then
  for seed in ${TEXTURE_SEEDS:-1 2 3 4 5 6}; do
    run_gs 1 field -c "$X" -o "texture-$seed" --set run.seed=$seed --set output.geometry=none \
      --set output.vdb=no --set output.preview=no ${TEXTURE_SET:-}
    expect_rc 0 "texture.ini seed $seed"
    r=$(/usr/bin/python3 - "texture-$seed/summary.json" <<'EOF'
import json, sys
m = json.load(open(sys.argv[1]))["metrics"]
s = m["surface_per_volume_out"] / m["surface_per_volume_src"] - 1
v = m["volume_fraction_out"] / m["volume_fraction_src"] - 1
c = m["copy_largest_region_of_source"]
print(f"surface/volume {s:+.3f}, volume fraction {v:+.3f} of the source's, largest copy {c:.3f}",
      int(abs(s) <= 0.10 and abs(v) <= 0.10 and c <= 0.25))
EOF
)
    [[ ${r##* } == 1 ]] && ok "texture seed $seed: ${r% *}" ||
      bad "texture seed $seed: ${r% *} (each within 10%, copy at most 0.25)"
  done
  # pooled over the seeds: SHARE_KEY x COUNT_KEY of each run against the bound
  # 1/(DIV x the example's disc count)
  pooled() {
    /usr/bin/python3 - "$@" ${TEXTURE_SEEDS:-1 2 3 4 5 6} <<'EOF'
import json, sys
share_key, count_key, div, what = sys.argv[1:5]
hit = n = 0
for seed in sys.argv[5:]:
    m = json.load(open(f"texture-{seed}/summary.json"))["metrics"]
    k = m[count_key]
    hit += round(m[share_key] * k)
    n += k
    src = m["layout_objects_src"]
share, bound = hit / max(n, 1), 1.0 / (int(div) * src)
print(f"{hit} of {n} {what} ({share:.3f}, bound 1/({div} x {src}) = {bound:.3f})",
      int(n > 0 and share <= bound))
EOF
  }
  r=$(pooled layout_guarded_close_share_out layout_guarded_objects_out 1 \
    "guarded discs closer than any two in the example")
  [[ ${r##* } == 1 ]] && ok "texture disc spacing: ${r% *}" || bad "texture disc spacing: ${r% *}"
  r=$(pooled layout_fragment_share_out layout_objects_out 4 "discs cut into fragments")
  [[ ${r##* } == 1 ]] && ok "texture whole discs: ${r% *}" || bad "texture whole discs: ${r% *}"
  # fragments and merged discs together: the pooled share's upper limit (share
  # plus twice its binomial standard error) at most one disc in the example's
  # count of them, so the bound holds for the rate, not for these seeds' luck
  r=$(/usr/bin/python3 - ${TEXTURE_SEEDS:-1 2 3 4 5 6} <<'EOF'
import json, math, sys
hit = n = 0
for seed in sys.argv[1:]:
    m = json.load(open(f"texture-{seed}/summary.json"))["metrics"]
    k = m["layout_objects_out"]
    hit += round(m["layout_fragment_share_out"] * k) + round(m["layout_merged_share_out"] * k)
    n += k
    src = m["layout_objects_src"]
p = hit / max(n, 1)
top = p + 2 * math.sqrt(max(p * (1 - p), 1e-12) / max(n, 1))
bound = 1.0 / src
print(f"{hit} of {n} discs cut or merged ({p:.3f}, upper limit {top:.3f}, bound 1/{src} = {bound:.3f})",
      int(n > 0 and top <= bound))
EOF
)
  [[ ${r##* } == 1 ]] && ok "texture discs neither cut nor merged: ${r% *}" ||
    bad "texture discs neither cut nor merged: ${r% *}"
  first=${TEXTURE_SEEDS:-1}; first=${first%% *}
  r=$(/usr/bin/python3 "$GS_ROOT/analysis/field_layout.py" "texture-$first" --check 2>&1)
  [[ $r == *"layout check: ok"* ]] && ok "texture seed $first: layout_* = field_layout.py's (${r%%$'\n'*})" ||
    bad "texture seed $first: layout_* differ from field_layout.py's: $r"
  for np in 1 2; do
    run_gs $np field -c "$X" -o "regions-np$np" --set run.seed=$first --set field.region_blocks=4 \
      --set field.object_spacing=0 --set output.geometry=none --set output.vdb=no --set output.preview=no ${TEXTURE_SET:-}
    expect_rc 0 "texture.ini region_blocks 4 at $np ranks"
  done
  d1=$(digest_of regions-np1) d2=$(digest_of regions-np2)
  [[ -n $d1 && $d1 == "$d2" ]] && ok "keep_volume with target regions: np 1 = np 2 ($d1)" ||
    bad "keep_volume with target regions: np 1 $d1, np 2 $d2"
  run_gs 1 field -c "$X" -o regions-spacing --set field.region_blocks=4 --set output.geometry=none
  expect_rc 2 "field.object_spacing with target regions"
  expect_err "object_spacing = 1: needs field.region_blocks = 0, not 4" \
    "object_spacing with target regions: refused by name"
  r=$(/usr/bin/python3 - regions-np2/summary.json <<'EOF'
import json, sys
m = json.load(open(sys.argv[1]))["metrics"]
s = m["surface_per_volume_out"] / m["surface_per_volume_src"] - 1
v = m["volume_fraction_out"] / m["volume_fraction_src"] - 1
print(f"surface/volume {s:+.3f}, volume fraction {v:+.3f}", int(abs(s) <= 0.10 and abs(v) <= 0.10))
EOF
)
  [[ ${r##* } == 1 ]] && ok "texture region_blocks 4: ${r% *}" ||
    bad "texture region_blocks 4: ${r% *} (each within 10%)"
fi
finish
