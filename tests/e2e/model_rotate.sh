# End-to-end: 90-degree rotational symmetry (Merrell Sec. 4.1, Figure 12):
# configs/model/castle-rotate.ini at np 1 and 2 (same digest), judged from lattice.txt and the
# example alone: turned by 90 degrees about the centre the output is itself with its labels
# mapped (the label at R(p) is one function of the label at p, a bijection), that map moves
# labels (a wall facing +x becomes one facing +y: with the identity as the label rotation
# the walls cannot turn and the castle pieces go), castle pieces (structure labels, as
# analysis/model_structure.py finds them in the example) make at least half the example's share
# of non-empty cells, and no adjacent pair is missing from the example. About 5 s here.
source "$GS_ROOT/tests/e2e/lib.bash"
C=$GS_ROOT/configs/model
need_config "rotation-symmetric castle" "$C/castle-rotate.ini" || finish
run_gs 0 model -c "$C/castle-rotate.ini" -o r1
expect_rc 0 "castle-rotate at np=1"
run_gs 2 model -c "$C/castle-rotate.ini" -o r2
expect_rc 0 "castle-rotate at np=2"
d1=$(digest_of r1); d2=$(digest_of r2)
[[ -n $d1 && $d1 == "$d2" ]] && ok "castle-rotate: np 1 and 2 digest $d1" || bad "castle-rotate: digest $d1 != $d2"
grep -q '"violations":0' r1/summary.json && ok "castle-rotate: 0 violations" || bad "castle-rotate: violations"
/usr/bin/python3 - "$DATA/model-synthesis/merrell42-model-synthesis/samples/castle.txt" r1/lattice.txt "$GS_ROOT/analysis" <<'PY' \
  && ok "castle-rotate: turned by 90 degrees the castle is itself, labels mapped; castle pieces kept" || bad "castle-rotate: rotation measures"
import sys
sys.path.insert(0, sys.argv[3])
import numpy as np
import model_structure as ms
E, O = ms.read_txt(sys.argv[1]), ms.read_txt(sys.argv[2])
N = O.shape[0]
# R(x, y) = (N-1-y, x): the label found at R(p) for the label at p
turned = np.empty_like(O)
for x in range(N):
    for y in range(N):
        turned[N - 1 - y, x] = O[x, y]
f, clash = {}, 0
for a, b in zip(O.ravel().tolist(), turned.ravel().tolist()):
    if f.setdefault(b, a) != a:
        clash += 1
empty, struct = ms.structure_labels(E)
moved = sum(1 for k, v in f.items() if k != v)
share = lambda A: np.isin(A, list(struct)).sum() / max(1, (A != empty).sum())
fail = []
if clash:
    fail.append("%d cells break the rotation (label at R(p) not a function of the label at p)" % clash)
if len(set(f.values())) != len(f):
    fail.append("the label map is not a bijection")
if moved == 0:
    fail.append("the rotation maps every label to itself")
if share(O) < 0.5 * share(E):
    fail.append("castle pieces %.3f of non-empty cells, example %.3f" % (share(O), share(E)))
print("labels moved by the turn %d of %d; castle pieces %.3f of non-empty cells (example %.3f)"
      % (moved, len(f), share(O), share(E)))
print("\n".join(fail))
sys.exit(1 if fail else 0)
PY
finish
