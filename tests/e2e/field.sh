# End-to-end: the field engine (configs/field/quick.ini, GRID 32^3 -> 48x40x32):
# identical digests at np=1,2,3; stop/resume and kill -9/resume at another
# rank count give the uninterrupted digest; quality within tolerance.
# Outputs, inputs and errors: tests/e2e/field_io.sh.
source "$GS_ROOT/tests/e2e/lib.bash"
Q=$GS_ROOT/configs/field/quick.ini
metric() { /usr/bin/python3 -c 'import json,sys;print(json.load(open(sys.argv[1]+"/summary.json"))["metrics"][sys.argv[2]])' "$1" "$2"; }

# --- determinism over rank counts -------------------------------------------
declare -A dig
for np in 1 2 3; do
  run_gs "$np" field -c "$Q" -o "np$np"
  expect_rc 0 "quick.ini at np=$np"
  dig[$np]=$(digest_of "np$np" 2>/dev/null)
done
[[ -n "${dig[1]}" && "${dig[1]}" == "${dig[2]}" && "${dig[1]}" == "${dig[3]}" ]] &&
  ok "digest identical at np=1,2,3 (${dig[1]})" || bad "digests differ: np1=${dig[1]} np2=${dig[2]} np3=${dig[3]}"
ref=${dig[1]}
# The measures at np > 1 run on the last rank alone (its own exact matcher)
# while rank 0 writes the meshes: every figure as at np = 1 (the search work
# counters aside: each rank counts its own)
for np in 2 3; do
  d=$(/usr/bin/python3 - np1 "np$np" "$np" <<'PY'
import json, sys
a, b = (json.load(open(d + "/summary.json"))["metrics"] for d in sys.argv[1:3])
out = [l for l in open(sys.argv[2] + "/metrics.jsonl") if '"phase":"output"' in l]
skip = lambda k: k.startswith(("match_pops", "match_pushes"))
diff = sorted(k for k in set(a) | set(b) if not skip(k) and a.get(k) != b.get(k))
if json.loads(out[-1]).get("measures_rank") != int(sys.argv[3]) - 1:
    diff.append("measures_rank")
print(" ".join(diff) if diff else "same", len(a))
PY
)
  [[ "$d" == same* ]] && ok "np=$np: every measure as at np=1, on the last rank (${d#same } figures)" ||
    bad "np=$np figures differ from np=1: $d"
done
# The digest covers every output file, so a run written without meshes and
# .vdb (output.geometry=none, output.vdb=no, as the runs below that compare
# orderings and trees) is compared with a reference written the same way.
run_gs 1 field -c "$Q" -o np1lean --set output.geometry=none --set output.vdb=no
expect_rc 0 "quick.ini at np=1 without meshes and .vdb"
lean=$(digest_of np1lean 2>/dev/null)
[[ -n "$lean" && "$lean" != "$ref" ]] && ok "fewer output files, another digest ($lean)" ||
  bad "digest without meshes and .vdb '$lean' vs with them $ref"

# --- preview.png: source and output contours side by side, listed in summary ---
# (every run has one: with output.geometry = copy or none too)
preview_check() { # DIR LABEL
  local out
  out=$(/usr/bin/python3 - "$1" <<'EOF2'
import json, sys, matplotlib.image as mi
d = sys.argv[1]
outs = [o for o in json.load(open(d + "/summary.json"))["outputs"] if o["kind"] == "preview"]
im = mi.imread(d + "/preview.png")[..., :3]
h, w = im.shape[:2]
bg = im[0, 0]
def share(a):  # pixels not of the background colour
    return float((abs(a - bg).sum(-1) > 0.05).mean())
l, r = share(im[:, : w // 2 - 4]), share(im[:, w // 2 + 4 :])
print("%dx%d, listed %d, drawn share left %.2f right %.2f" % (w, h, len(outs), l, r))
sys.exit(0 if len(outs) == 1 and outs[0]["path"] == "preview.png" and w == 2 * h + 4
         and l > 0.05 and r > 0.05 else 1)
EOF2
)
  [[ $? -eq 0 ]] && ok "preview.png ($2): source | output, both drawn, listed ($out)" || bad "preview.png ($2): $out"
}
preview_check np1 "output.geometry = contour"
for g in copy none; do
  run_gs 1 field -c "$GS_ROOT/configs/field/quick.ini" -o "geom-$g" --set output.geometry=$g
  [[ $rc -eq 0 ]] && preview_check "geom-$g" "output.geometry = $g" || bad "output.geometry = $g: exit $rc: ${err:0:300}"
done

# --- target regions: parallel at np>1, and the paper's raster-order result ---
# quick.ini (default field.region_blocks = 4): per iteration 3x2x2 regions in 5
# wavefront colors of 1, 3, 4, 3, 1 regions; at np=2 the 3 colors with >= 2
# regions run region-parallel (6 over both iterations), the rest in order.
phase_field() { /usr/bin/python3 -c '
import json, sys
for line in open(sys.argv[1] + "/metrics.jsonl"):
    r = json.loads(line)
    if r.get("phase") == "synthesis" and sys.argv[2] in r: print(r[sys.argv[2]])' "$1" "$2" | tail -1; }
cr=$(phase_field np2 colors_in_regions) co=$(phase_field np2 colors_in_order)
[[ "$cr" == 6 && "$co" == 4 ]] && ok "np=2: 6 colors ran region-parallel, 4 in order" ||
  bad "np=2: colors in regions '$cr' (expected 6), in order '$co' (expected 4)"
cr=$(phase_field np1 colors_in_regions)
[[ "$cr" == 0 ]] && ok "np=1: no region exchange" || bad "np=1: colors in regions '$cr'"
run_gs 2 field -c "$Q" -o raster --set field.region_blocks=0 --set output.geometry=none --set output.vdb=no
expect_rc 0 "quick.ini with one region (raster order) at np=2"
[[ "$(digest_of raster)" == "$lean" ]] && ok "regions give the raster order's digest" ||
  bad "raster digest $(digest_of raster) != regions $lean"
run_gs 3 field -c "$Q" -o r1 --set field.region_blocks=1 --set output.geometry=none --set output.vdb=no
expect_rc 0 "quick.ini with one-position regions at np=3"
[[ "$(digest_of r1)" == "$lean" ]] && ok "one-position regions at np=3: the same digest" ||
  bad "region_blocks=1 digest $(digest_of r1) != $lean"

# --- sharded tree (field.tree = sharded): each rank holds a z-slab of every
# iteration's tree and pyramid, every match is searched by all ranks with the
# bound shared; the same output and quality, less tree memory per rank
for np in 2 3; do
  run_gs "$np" field -c "$Q" -o "sh$np" --set field.tree=sharded --set output.geometry=none --set output.vdb=no
  expect_rc 0 "quick.ini with field.tree=sharded at np=$np"
  [[ "$(digest_of "sh$np")" == "$lean" ]] && ok "sharded tree at np=$np: the same digest" ||
    bad "sharded np=$np digest $(digest_of "sh$np") != $lean"
done
tb1=$(phase_field np1 tree_bytes_rank_max) tb2=$(phase_field sh2 tree_bytes_rank_max) tb3=$(phase_field sh3 tree_bytes_rank_max)
[[ -n "$tb1" && -n "$tb2" && -n "$tb3" && "$tb2" -lt $((tb1 * 3 / 4)) && "$tb3" -lt $((tb2 * 9 / 10)) ]] &&
  ok "tree + pyramid bytes on the largest rank fall with the rank count ($tb1 > $tb2 > $tb3)" ||
  bad "tree bytes per rank: np1 '$tb1' np2 sharded '$tb2' np3 sharded '$tb3'"
for k in coherence verbatim_share volume_fraction_out; do
  [[ "$(metric sh3 $k)" == "$(metric np1 $k)" ]] && ok "sharded np=3: quality $k as np=1" ||
    bad "sharded np=3 $k $(metric sh3 $k) != np=1 $(metric np1 $k)"
done
GS_STOP_AFTER_UNITS=300 run_gs 3 field -c "$Q" -o shstop --set field.tree=sharded --set output.geometry=none --set output.vdb=no
expect_rc 9 "sharded run stops after 300 blocks"
run_gs 2 resume shstop
expect_rc 0 "sharded run resumed at np=2"
[[ "$(digest_of shstop)" == "$lean" ]] && ok "sharded stop at np=3 + resume at np=2 = uninterrupted digest" ||
  bad "sharded resumed digest $(digest_of shstop) != $lean"

# --- quality: GRID statistics of the output within tolerance of the source --
# Masked matching (the default, see configs/field/grid.ini). Tolerances:
# volume fraction and surface per volume within 25% of the source's. No
# bound on the coherence (mean nearest-source-block distance): it rewards
# copying (a tiled copy of the source scores 0, #19). Its old bound, 40, was
# one run's figure: quick.ini seeds 1-12 measured 0.3-85 with ties to the
# lowest source index, and seed 1 went 31.7 -> 49.5 when exact ties were
# broken by a seeded hash (more of the source used: copy completeness 0.80
# -> 0.88); the paper's whole-block mode now measures 56, not ~700. The
# copying checks below (largest region of one offset) take its place.
/usr/bin/python3 - np1/summary.json <<'EOF' && ok "quality within tolerance" || bad "quality out of tolerance"
import json, sys
m = json.load(open(sys.argv[1]))["metrics"]
print(json.dumps({k: round(v, 4) for k, v in m.items() if isinstance(v, float)}))
vf = abs(m["volume_fraction_out"] - m["volume_fraction_src"]) / m["volume_fraction_src"]
sv = abs(m["surface_per_volume_out"] - m["surface_per_volume_src"]) / m["surface_per_volume_src"]
assert vf < 0.25, vf
assert sv < 0.25, sv
# (no bound on match_mean: it was one run's figure; tests/e2e/field_guided.sh
# checks the statistics and the coarse guidance against the source)
assert m["coherence_blocks"] == 6 * 5 * 4
# copying: no region of one source offset larger than a quarter of the source
# (broken on purpose, #19: a matcher returning a verbatim tiling, block
# position p mod (source - block + 1), gives 0.84; before repeated windows
# joined through consistent offsets the measure saw only 0.073 of it)
assert m["copy_largest_region_of_source"] < 0.25, m["copy_largest_region_of_source"]
# a distance field after redistancing: neighbour steps within the source's
assert m["step_violations_redistanced"] <= m["step_violations_src"] + 1e-3, m["step_violations_redistanced"]
EOF
# the literal paper mode runs and is not the masked result (its statistics:
# e2e/field_guided)
run_gs 1 field -c "$Q" -o paper --set field.mask_unsynthesized=no --set output.geometry=none --set output.vdb=no
expect_rc 0 "paper's whole-block matching runs"
[[ -n "$(digest_of paper)" && "$(digest_of paper)" != "$lean" ]] && ok "whole-block matching differs from masked" ||
  bad "whole-block digest $(digest_of paper) vs masked $lean"

# --- queue pruning (field.upper_bound, default yes): the same digest as
# without it, and fewer queue entries and pops after iteration 0 (quick.ini:
# pushes 181,330 -> 160,249, pops 46,485 -> 42,220; watched it fail with
# candidate_bound returning 0: counts equal; with half the candidate's
# distance as the bound the search finds no block and the run exits 8)
run_gs 1 field -c "$Q" -o noub --set field.upper_bound=no --set output.geometry=none --set output.vdb=no
expect_rc 0 "quick.ini without the upper bound"
pu=$(metric np1 match_pushes_it1) pn=$(metric noub match_pushes_it1)
ou=$(metric np1 match_pops_it1) on=$(metric noub match_pops_it1)
[[ "$(digest_of noub)" == "$lean" && "$pu" -lt "$pn" && "$ou" -le "$on" ]] &&
  ok "upper bound: same digest, iteration 1 pushes $pn -> $pu, pops $on -> $ou" ||
  bad "upper bound: digest $(digest_of noub) vs $lean, pushes $pn -> $pu, pops $on -> $ou"

# --- weighted seeds (field.seed_weight) and random-block seeding: exact and
# deterministic too (the weighted distance is searched with weighted bounds,
# cheap queries run on every rank, expensive ones spread)
for np in 1 2; do
  run_gs "$np" field -c "$Q" -o "w$np" --set field.seed_weight=0.25 --set field.seed_blocks=yes \
    --set output.geometry=none --set output.vdb=no
  expect_rc 0 "quick.ini with seed_weight 0.25 at np=$np"
done
[[ -n "$(digest_of w1)" && "$(digest_of w1)" == "$(digest_of w2)" && "$(digest_of w1)" != "$lean" ]] &&
  ok "weighted matching: digest identical at np=1,2 and differs from masked" ||
  bad "weighted digests np1=$(digest_of w1) np2=$(digest_of w2) masked=$lean"

# --- small chain mail: two seeds give different outputs with the source's statistics ------
D=$GS_ROOT/configs/field/chainmail-small.ini
for s in 1 2; do
  run_gs 1 field -c "$D" -o "demo$s" --set run.seed=$s --set output.geometry=none --set output.vdb=no
  expect_rc 0 "chainmail-small.ini with run.seed=$s"
done
[[ -n "$(digest_of demo1)" && "$(digest_of demo1)" != "$(digest_of demo2)" ]] &&
  ok "demo: seeds 1 and 2 give different outputs" || bad "demo: seeds 1 and 2 give the same output"
# Volume fraction: the chain mail is exactly periodic (24 samples along each
# axis) and its honest output a tiling, whose vf depends on where the output
# box cuts the tiling: over every 64^3 window of the source's periodic
# extension it spans 0.148-0.178, the 32^3 source box itself 0.174, one whole
# period 0.162. So the reference is that span (from the source's levels
# alone), widened by 10%; a source that is not periodic along an axis is
# measured as its box. (Against the box alone, the random first block's
# tiling phases give -0.115..+0.015 over seeds 1-6; seed 2 -0.108.)
/usr/bin/python3 - demo1 demo2 <<'EOF2' && ok "demo: both seeds within 10% of the source's volume fraction (over the output-size windows of its periods) and surface/volume" || bad "demo statistics out of tolerance"
import json, sys
import h5py, numpy as np
def inside(run, name):
    d = h5py.File(run + "/field.h5", "r")[name]
    lo, hi = float(d.attrs["lo"]), float(d.attrs["hi"])
    return (lo + d[...].astype(np.float64) * (hi - lo) / 255) < 0
def period(a, ax):  # smallest exact period along ax leaving an overlap of 8
    n = a.shape[ax]
    for p in range(1, n - 7):
        if np.array_equal(a.take(range(p, n), ax), a.take(range(0, n - p), ax)):
            return p
    return n
def window_span(src, shape):  # vf of every window of `shape` of the periodic extension
    ps = [period(src, ax) for ax in range(3)]
    if any(p == n for p, n in zip(ps, src.shape)):
        return src.mean(), src.mean()
    t = src[:ps[0], :ps[1], :ps[2]].astype(np.float64)
    w = []  # weight of each tile offset in a window starting at 0
    for p, L in zip(ps, shape):
        c = np.full(p, L // p, np.float64); c[:L % p] += 1; w.append(c)
    k = w[0][:, None, None] * w[1][None, :, None] * w[2][None, None, :]
    s = np.real(np.fft.ifftn(np.fft.fftn(t) * np.conj(np.fft.fftn(k))))  # sum over window at shift
    v = s / np.prod(shape)
    return v.min(), v.max()
for run in sys.argv[1:]:
    f = run + "/summary.json"
    m = json.load(open(f))["metrics"]
    lo, hi = window_span(inside(run, "/source/levels"), inside(run, "/field/levels").shape)
    vf = m["volume_fraction_out"]
    print(run, "vf", round(vf, 4), "source windows", round(lo, 4), round(hi, 4), "box", round(m["volume_fraction_src"], 4))
    assert 0.9 * lo <= vf <= 1.1 * hi, (f, vf, lo, hi)
    assert abs(m["surface_per_volume_out"] / m["surface_per_volume_src"] - 1) < 0.10, (f, m)
    assert 0 <= m["verbatim_share"] <= 1 and m["verbatim_run"] >= 0, (f, m)
    # verbatim share 1 exactly when every output block exists in the source
    assert (m["verbatim_share"] == 1) == (m["coherence"] == 0), (f, m)
    # the copy measure sees the chain mail's periods (4: face-centred, 17.0
    # samples) and a tiling of it as copied: a region larger than the source
    # (it was blind: no unique window, matched share 0; seed 1: 0.744, region
    # 6.9 x the source)
    assert m["copy_source_periods"] >= 1, (f, m)
    assert m["verbatim_share"] < 1 or m["copy_largest_region_of_source"] > 1, (f, m)
EOF2

# --- the GRID default itself (configs/field/grid.ini: 64^3 -> 128^3, three ---
# iterations): the statistics the issue asks to hold for it. Stated
# tolerances: volume fraction within 5% and surface per volume within 10% of
# the source's, coherence (mean nearest-source-block distance, squared levels
# per sample) below 45 (measured 30.8), every iteration's mean match distance
# reported and finite.
run_gs 2 field -c "$GS_ROOT/configs/field/grid.ini" -o grid --set output.geometry=none --set output.vdb=no
expect_rc 0 "grid.ini (the GRID default) at np=2"
/usr/bin/python3 - grid/summary.json <<'EOF3' && ok "GRID default: statistics within the stated tolerances" || bad "GRID default statistics out of tolerance"
import json, math, sys
m = json.load(open(sys.argv[1]))["metrics"]
print({k: round(v, 4) for k, v in m.items() if isinstance(v, float)})
assert abs(m["volume_fraction_out"] / m["volume_fraction_src"] - 1) < 0.05, m["volume_fraction_out"]
assert abs(m["surface_per_volume_out"] / m["surface_per_volume_src"] - 1) < 0.10, m["surface_per_volume_out"]
assert m["coherence"] < 45, m["coherence"]
for it in range(3):
    assert m[f"match_blocks_it{it}"] > 0 and math.isfinite(m[f"match_mean_it{it}"]), it
EOF3

# --- stop after N blocks at np=1, resume at np=2 ------------------------------
GS_STOP_AFTER_UNITS=300 run_gs 1 field -c "$Q" -o stop
expect_rc 9 "GS_STOP_AFTER_UNITS stops with exit 9"
expect_err "geosynth resume" "stop message says how to resume"
run_gs 2 resume stop
expect_rc 0 "resume at np=2"
[[ "$(digest_of stop)" == "$ref" ]] && ok "stop at 300 + resume at np=2 = uninterrupted digest" || bad "resumed digest $(digest_of stop) != $ref"

# --- kill -9 of a 2-rank run at a random moment, resume at np=1 ----------------
# The run ends about 0.3 s after its first checkpoint here (quiet machine):
# the kill comes 0 to 0.15 s after it is seen (polled every 20 ms); a run that
# still finishes first is retried (up to 5 times).
RANDOM=$$
killed=0
for attempt in 1 2 3 4 5; do
  rm -rf kill
  mpirun -np 2 "$GS_BIN" field -c "$Q" -o kill --set run.checkpoint_every=40 >/dev/null 2>&1 &
  pid=$!
  for _ in $(seq 500); do [[ -s kill/checkpoint.h5 ]] && break; sleep 0.02; done
  sleep "0.$(printf %02d $((RANDOM % 16)))"
  kids=$(pgrep -P $pid)  # the ranks, killed together with mpirun (by pid)
  kill -9 $pid $kids 2>/dev/null
  wait $pid 2>/dev/null
  [[ -s kill/summary.json ]] && continue
  killed=1
  run_gs 1 resume kill
  expect_rc 0 "resume after kill -9 at np=1 (attempt $attempt)"
  [[ "$(digest_of kill)" == "$ref" ]] && ok "kill -9 (np=2) + resume at np=1 = uninterrupted digest" || bad "kill/resume digest $(digest_of kill) != $ref"
  break
done
[[ $killed == 1 ]] || bad "every run finished before its kill -9: nothing resumed"

finish
