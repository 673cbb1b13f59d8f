# End-to-end: the field engine's fibers are whole and keep their thickness
# (#19 item 3, whole objects), on configs/field/fibers.ini at 48^3 -> 96^3
# (fibers.ini's 64^3 -> 128^3 at three quarters of the size). The pieces'
# fibers meet misaligned by about a sample and the seams along the fibers
# slice them lengthwise, so the synthesized field's fibers are thinner than
# the source's; field.complete_objects (on in fibers.ini, not set here: the
# test fails with it off) rebuilds them as tracks of whole source fibers
# (src/field/fibers.c).
# From field.h5 and summary.json alone (the output's figures are
# src/field/report.c's; the synthesis' own field, /synthesis/levels, is
# measured here the same way: maxima of an exact Euclidean distance transform
# of the inside over their 26 neighbours, at least one sample from every
# face). Thresholds from the source:
# - the inscribed radii's distribution as the source's: two-sample
#   Kolmogorov-Smirnov distance at most its 5% critical value,
#   1.36 sqrt((n + m) / (n m)) for n and m sphere centres. (The radii take
#   the values 1, 1.41, 1.73, 2, ... (steps of 15-40%), so "p50 within 10%"
#   asked for the same value and flipped on a 1.5% shift where the source's
#   median sits at a cumulative share near 0.5: example seed 3, 0.515 at
#   1.41.);
# - share of sphere centres with a radius at least the source's p50: at
#   least 0.8 of the source's share (the thin side);
# - volume fraction within 10% of the source's;
# - the inside crossing slabs along the fibers (crossing_share): at least
#   0.8 of the source's;
# - inside components away from the faces (fibers' pieces that end inside
#   the box; the source has none): at most one per ten components that cross
#   the output along the fibers.
# The unrebuilt synthesis (/synthesis/levels) must fail the distribution
# check.
# Example seed 2: there the synthesis copies the thin source fibers most
# (the two thinnest long fibers 28 times their volume, the thickest 4), so
# tracks that follow its votes alone come out thin.
# Measured (source p50 1.73, share 0.522, volume fraction 0.124, crossing
# 0.973): synthesis KS 0.375 (critical 0.044), share 0.172; rebuilt KS 0.012
# (0.045), p50 1.73, share 0.512, volume fraction 0.131, crossing 0.957, 1
# interior component. Broken on purpose: field17's tracks (16582ba: new
# fibers and switches follow the votes) give KS 0.208, share 0.314 (fails
# the distribution and the share; at seed 1 they passed, KS 0.027); main's
# rebuild of 8708428 gives crossing 0.588, 53 interior components;
# field.complete_objects=no fails objects_rebuilt and the distribution. See
# the notes of #19.
source "$GS_ROOT/tests/e2e/lib.bash"
F=$GS_ROOT/configs/field/fibers.ini
run_gs 1 field -c "$F" -o fib --set example.size=48 --set example.seed=2 --set field.target=96 \
  --set output.geometry=none --set output.vdb=no --set output.preview=no
expect_rc 0 "fibers.ini 48^3 -> 96^3, example seed 2"

fig=$(/usr/bin/python3 - fib <<'PY'
import json, sys
import h5py
import numpy as np
from scipy import ndimage
run = sys.argv[1]
m = json.load(open(run + "/summary.json"))["metrics"]

def radii(name):
    with h5py.File(run + "/field.h5", "r") as f:
        d = f[name]
        lo, hi = float(d.attrs["lo"]), float(d.attrs["hi"])
        ins = lo + d[()].astype(np.float64) * (hi - lo) / 255.0 < 0
    e2 = np.round(ndimage.distance_transform_edt(ins) ** 2)
    top = ins & (e2 >= ndimage.maximum_filter(e2, size=3, mode="constant", cval=0))
    top[0] = top[-1] = top[:, 0] = top[:, -1] = top[:, :, 0] = top[:, :, -1] = False
    return np.sort(np.sqrt(e2[top]))

def crossing_components():  # inside components reaching both faces along the fibers (x)
    with h5py.File(run + "/field.h5", "r") as f:
        d = f["field/levels"]
        lo, hi = float(d.attrs["lo"]), float(d.attrs["hi"])
        ins = lo + d[()].astype(np.float64) * (hi - lo) / 255.0 < 0
    lab, n = ndimage.label(ins)
    return len((set(np.unique(lab[:, :, 0])) & set(np.unique(lab[:, :, -1]))) - {0})

def p50(r):  # src/field/report.c quantile()
    return float(r[int(0.5 * (len(r) - 1) + 0.5)])

def ks(a, b):  # src/measure/stats.c gs_measure_ks
    v = np.union1d(a, b)
    return float(np.max(np.abs(np.searchsorted(a, v, side="right") / len(a) -
                               np.searchsorted(b, v, side="right") / len(b))))

def ks_crit(a, b):  # the 5% critical value of the two-sample test
    return 1.36 * float(np.sqrt((len(a) + len(b)) / (len(a) * len(b))))

with h5py.File(run + "/field.h5", "r") as f:
    rebuilt = "synthesis" in f  # absent when nothing was rebuilt: the output is the synthesis'
src, out = radii("source/levels"), radii("field/levels")
syn = radii("synthesis/levels") if rebuilt else out
ps = p50(src)
print(json.dumps({
    "rebuilt": m["objects_rebuilt"],
    "p50_out": m["inscribed_p50_out"], "p50_src": m["inscribed_p50_src"],
    "p50_py_out": p50(out), "p50_py_src": ps, "p50_syn": p50(syn),
    "ks_out": m["inscribed_ks"], "ks_py_out": ks(out, src), "ks_crit_out": ks_crit(out, src),
    "ks_syn": ks(syn, src), "ks_crit_syn": ks_crit(syn, src),
    "share_out": float(np.mean(out >= ps - 1e-9)), "share_src": float(np.mean(src >= ps - 1e-9)),
    "share_syn": float(np.mean(syn >= ps - 1e-9)),
    "vf_out": m["volume_fraction_out"], "vf_src": m["volume_fraction_src"],
    "cross_out": m["crossing_share_out"], "cross_src": m["crossing_share_src"],
    "interior_out": m["components_out"], "interior_src": m["components_src"],
    "crossing_components": crossing_components()}))
PY
)
echo "fibers: $fig"
get() { /usr/bin/python3 -c 'import json,sys;print(json.loads(sys.argv[1])[sys.argv[2]])' "$fig" "$1"; }
t() { /usr/bin/python3 -c "import sys; sys.exit(0 if $1 else 1)"; }

[ "$(get rebuilt)" = 1 ] && ok "fibers.ini: objects_rebuilt 1" || bad "fibers.ini: objects_rebuilt $(get rebuilt)"
t "abs($(get p50_py_src) - $(get p50_src)) < 1e-6 and abs($(get p50_py_out) - $(get p50_out)) < 1e-6" &&
  ok "inscribed p50 as report.c's: output $(get p50_out), source $(get p50_src)" ||
  bad "inscribed p50 here $(get p50_py_out)/$(get p50_py_src), report.c's $(get p50_out)/$(get p50_src)"
t "abs($(get ks_py_out) - $(get ks_out)) < 1e-6" &&
  ok "inscribed radii KS as report.c's: $(get ks_out)" ||
  bad "inscribed radii KS here $(get ks_py_out), report.c's $(get ks_out)"
t "$(get ks_out) <= $(get ks_crit_out)" &&
  ok "inscribed radii as the source's: KS $(get ks_out) <= $(get ks_crit_out) (p50 $(get p50_out), source $(get p50_src))" ||
  bad "inscribed radii unlike the source's: KS $(get ks_out) > $(get ks_crit_out) (p50 $(get p50_out), source $(get p50_src))"
t "$(get share_out) >= 0.8 * $(get share_src)" &&
  ok "centres with radius >= the source's p50: $(get share_out) (source $(get share_src))" ||
  bad "centres with radius >= the source's p50: $(get share_out), under 0.8 of the source's $(get share_src)"
t "abs($(get vf_out) - $(get vf_src)) <= 0.1 * $(get vf_src)" &&
  ok "volume fraction $(get vf_out) within 10% of the source's $(get vf_src)" ||
  bad "volume fraction $(get vf_out), not within 10% of the source's $(get vf_src)"
t "$(get cross_out) >= 0.8 * $(get cross_src)" &&
  ok "crossing share $(get cross_out) (source $(get cross_src))" ||
  bad "crossing share $(get cross_out), under 0.8 of the source's $(get cross_src)"
t "$(get interior_src) == 0 and 10 * $(get interior_out) <= $(get crossing_components)" &&
  ok "interior components $(get interior_out) for $(get crossing_components) crossing (source $(get interior_src))" ||
  bad "interior components $(get interior_out) for $(get crossing_components) crossing: over one in ten (source $(get interior_src))"
t "$(get ks_syn) <= $(get ks_crit_syn)" &&
  bad "thin synthesized fibers not flagged: /synthesis/levels KS $(get ks_syn) <= $(get ks_crit_syn)" ||
  ok "thin synthesized fibers flagged: /synthesis/levels KS $(get ks_syn) > $(get ks_crit_syn), p50 $(get p50_syn), share $(get share_syn)"
finish
