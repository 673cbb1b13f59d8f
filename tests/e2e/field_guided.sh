# End-to-end: the field engine's synthesis does what the paper says (#19
# item 7), with thresholds from the source, on configs/field/quick.ini
# (GRID 32^3 -> 48x40x32, 2 iterations, about 1 s):
# - statistics: volume fraction and surface per volume within 10% of the
#   source's (the example's own figures, from the same run's summary);
# - coarse guidance: the samples copied in iteration 1 keep the sign of the
#   upsampled coarse result they replace (coarse_departure: sign flips over
#   2 v (1 - v), what two unrelated samples of the source would give: 1 =
#   the coarse result ignored) below 0.2, a fifth of unrelated.
# Broken on purpose, each fails here (watched, see notes of #19):
#   checkerboard instead of the trilinear upsampling (synth.c upsample2):
#     coarse_departure 1.84, volume fraction 0.354 vs 0.163;
#   the coarse term dropped (field.coarse_weight = 0, checked below too,
#     seeds 1-3): mean coarse_departure 0.25 (default seed 1 0.11).
source "$GS_ROOT/tests/e2e/lib.bash"
Q=$GS_ROOT/configs/field/quick.ini
metric() { /usr/bin/python3 -c 'import json,sys;print(json.load(open(sys.argv[1]+"/summary.json"))["metrics"][sys.argv[2]])' "$1" "$2"; }

quality() { /usr/bin/python3 - "$1/summary.json" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))["metrics"]
print({k: round(m[k], 4) for k in ("volume_fraction_out", "volume_fraction_src", "surface_per_volume_out",
                                    "surface_per_volume_src", "coarse_departure")})
bad = []
if abs(m["volume_fraction_out"] / m["volume_fraction_src"] - 1) >= 0.10: bad.append("volume fraction")
if abs(m["surface_per_volume_out"] / m["surface_per_volume_src"] - 1) >= 0.10: bad.append("surface/volume")
if not m["coarse_departure"] < 0.2: bad.append("coarse guidance")
print("failed: " + " ".join(bad))
PY
}

run_gs 1 field -c "$Q" -o guided --set output.geometry=none --set output.vdb=no
expect_rc 0 "quick.ini"
res=$(quality guided)
echo "$res" | head -1
[[ "$(echo "$res" | tail -1)" == "failed: " ]] && ok "quick.ini: statistics within 10% of the source's, coarse result followed" ||
  bad "quick.ini out of tolerance: $(echo "$res" | tail -1)"

# the measure sees a synthesis that ignores the coarse result, by the mean
# over seeds 1-3: since the seed picks the first block (#19), one seed's
# unguided output can follow the coarse result by chance (seed 1 0.174,
# seeds 2, 3 0.27, 0.31; guided 0.107, 0.091, 0.123)
deps=()
for s in 1 2 3; do
  run_gs 1 field -c "$Q" -o unguided$s --set run.seed=$s --set field.coarse_weight=0 \
    --set output.geometry=none --set output.vdb=no --set output.preview=no
  expect_rc 0 "quick.ini with field.coarse_weight = 0, seed $s"
  deps+=("$(metric unguided$s coarse_departure)")
done
mean=$(/usr/bin/python3 -c 'import sys; v=[float(x) for x in sys.argv[1:]]; print(sum(v)/len(v))' "${deps[@]}")
/usr/bin/python3 -c 'import sys; sys.exit(0 if float(sys.argv[1]) >= 0.2 else 1)' "$mean" &&
  ok "coarse result ignored: mean coarse_departure $mean over seeds 1-3 (${deps[*]}) flags it (>= 0.2)" ||
  bad "coarse_weight = 0 not flagged: mean coarse_departure $mean over seeds 1-3 (${deps[*]}) < 0.2"

# the paper's whole-block matching (field.mask_unsynthesized = no) keeps the
# source's volume fraction within 15%: with its random seeds at full weight
# they outweighed the overlap and every match drifted to the source's mean
# (outside): 0.067 vs 0.163 (watched it fail with GS_FIELD_PAPER_SEED_WEIGHT 256)
for seed in 1 2; do
  run_gs 1 field -c "$Q" -o "paper$seed" --set field.mask_unsynthesized=no --set run.seed=$seed \
    --set output.geometry=none --set output.vdb=no
  expect_rc 0 "quick.ini, whole-block matching, seed $seed"
  vo=$(metric "paper$seed" volume_fraction_out) vs=$(metric "paper$seed" volume_fraction_src)
  /usr/bin/python3 -c "import sys; sys.exit(0 if abs($vo / $vs - 1) < 0.15 else 1)" &&
    ok "whole-block matching, seed $seed: volume fraction $vo within 15% of the source's $vs" ||
    bad "whole-block matching collapses, seed $seed: volume fraction $vo vs source $vs"
done
finish
