# End-to-end: model outputs look like their example. Runs the engine with its
# default settings (seed 1, one rank) on the repository's two Merrell lattices
# (DeBroglie's CSV copies of escheresque and parliament) and checks the output
# against figures of the EXAMPLE itself, computed here from lattice.h5 and the
# CSV alone (numpy; nothing from the engine's bookkeeping but cross-checks):
# - resemblance: the share of the output's non-empty 3x3x3 windows found in the
#   example is at least the share one half of the example reaches against the
#   other half (the better of the x and y splits): a piece synthesized from the
#   example resembles it at least as well as an unseen piece of the example;
# - completeness: the share of the example's distinct non-empty 3x3x3 windows
#   met in the output is at least the lower share one half of the example
#   meets of the other's;
# - label mix: labels used >= 0.8 x the example's; label L1 to the example at
#   most 2 x the larger L1 between the example's halves;
# - empty share within 20% of the example's;
# - height profile: mean |fill(z) - example fill(z)| at most half the example's
#   mean fill (the old default hung walls from the fixed empty top: 0.24-0.41);
# - no unsupported (floating) cells where the example has none.
# Broken on purpose (notes/model.md): region synthesis replaced by a no-op
# fails labels and completeness (parliament also empty share and profile); resemblance removed fails the
# window share, L1, empty share and profile. About 5 s.
source "$GS_ROOT/tests/e2e/lib.bash"
M=$DATA/model-synthesis/debroglie-samples-merrell

for name in escheresque parliament; do
  cat > $name.ini <<EOF
[model]
example = $M/$name.csv
size = 30x30x10
region = 10x10x0
EOF
  run_gs 0 model -c $name.ini -o $name
  expect_rc 0 "$name 30x30x10 in 10x10 regions, default settings"
  [[ $rc -eq 0 ]] || continue
  /usr/bin/python3 -c 'import sys, matplotlib.image as im; a = im.imread(sys.argv[1]); assert a.shape[:2] == (512, 1028), a.shape; l, r = a[:, :512, :3], a[:, 516:, :3]; assert l.std() > 0.05 and r.std() > 0.05' "$name/preview.png" \
    && ok "$name: preview.png, example | output, 2 x 512 px, both panels drawn" || bad "$name: preview.png missing or blank"
  res=$(/usr/bin/python3 - "$M/$name.csv" "$name" <<'EOF'
import json, os, sys
sys.path.insert(0, os.environ["GS_ROOT"] + "/analysis")
import lattice_measures as lm

ex = lm.read_lattice(sys.argv[1])
out = lm.read_lattice(sys.argv[2] + "/lattice.h5")
m = json.load(open(sys.argv[2] + "/summary.json"))["metrics"]
f, h = lm.figures(ex, out, ks=(3,)), lm.half_figures(ex, ks=(3,))
half_share, half_l1, half_cmp = h["share_3"], h["label_l1"], h["completeness_3"]
r3, cmp3, L1 = f["share_3"], f["completeness_3"], f["label_l1"]
used, ex_used = f["labels_used"], f["labels_example"]
empty, ex_empty = f["empty_share"], f["empty_share_example"]
prof, fe_mean = f["height_fill_mean_abs"], f["height_fill_example_mean"]
fails = []
def need(cond, what):
    print(("ok   " if cond else "FAIL ") + what)
    if not cond:
        fails.append(what)
need(r3 >= half_share, "non-empty 3x3x3 share %.3f >= example half vs half %.3f" % (r3, half_share))
need(abs(r3 - m["resemblance_3x3x3"]) < 1e-9, "summary.json resemblance_3x3x3 %.3f = independent %.3f" % (m["resemblance_3x3x3"], r3))
need(cmp3 >= half_cmp, "completeness %.3f >= example half vs half (the lower) %.3f" % (cmp3, half_cmp))
need(used >= 0.8 * ex_used, "labels used %d >= 0.8 x example's %d" % (used, ex_used))
need(L1 <= 2 * half_l1, "label L1 %.3f <= %.3f = 2 x example half vs half %.3f" % (L1, 2 * half_l1, half_l1))
need(abs(empty - ex_empty) <= 0.2 * ex_empty, "empty share %.3f within 20%% of example's %.3f" % (empty, ex_empty))
need(prof <= 0.5 * fe_mean, "height profile mean |diff| %.3f <= half the example's mean fill %.3f" % (prof, 0.5 * fe_mean))
need(m["unsupported_share_example"] > 0 or m["unsupported_share"] == 0,
     "unsupported share %.4f where the example has %.4f" % (m["unsupported_share"], m["unsupported_share_example"]))
need(m["violations"] == 0 and m["failed_regions"] == 0, "0 violations, 0 failed regions")
print("RESULT", "pass" if not fails else "fail: " + "; ".join(fails))
EOF
)
  echo "$res" | sed "s/^/  $name: /"
  if grep -q "^RESULT pass" <<<"$res"; then ok "$name output resembles its example (figures from the example)"
  else bad "$name: $(grep '^RESULT' <<<"$res")"; fi
done
