# End-to-end: 4D model synthesis (Merrell Sec. 4.3): configs/model/city4d.ini, a city block
# whose cars drive one cell a frame (configs/model/city4d.txt, scripts/gen-city4d.py), into
# 8 frames. The same digest at np 1, 2, 3 and after a stop at np 2 resumed at np 1; judged
# from the output file and the example alone (analysis/model_time.py): every pair of
# consecutive frames holds only time transitions found between the example's frames (fails
# when synthesis ignores the time neighbours: cars then appear, vanish or stand still), the
# space pairs too, the cars move (the labels that change are the example's moving ones, at
# least half the example's share of changing cells), one .vox per frame, lattice.txt reads
# back as a 4D example (and so does lattice.h5), and ParaView plays lattice.xmf as 8 time steps equal to the
# frames of lattice.h5. About 5 s here; needs nothing fetched.
source "$GS_ROOT/tests/e2e/lib.bash"
C=$GS_ROOT/configs/model
for np in 0 2 3; do
  run_gs $np model -c "$C/city4d.ini" -o c$np
  expect_rc 0 "city4d at np=${np/#0/1}"
done
GS_STOP_AFTER_UNITS=1 run_gs 2 model -c "$C/city4d.ini" -o stop
expect_rc 9 "city4d: stopped after one region at np 2"
run_gs 0 resume stop
expect_rc 0 "city4d: resumed at np 1"
d0=$(digest_of c0); d2=$(digest_of c2); d3=$(digest_of c3); ds=$(digest_of stop)
[[ -n $d0 && $d0 == "$d2" && $d0 == "$d3" && $d0 == "$ds" ]] \
  && ok "city4d: digest $d0 at np 1, 2, 3 and stop + resume" || bad "city4d: digests $d0 $d2 $d3 $ds"

m=$(/usr/bin/python3 "$GS_ROOT/analysis/model_time.py" "$C/city4d.txt" c0 --json)
echo "$m"
/usr/bin/python3 - "$m" <<'PY' && ok "city4d: consistent along time and space, cars move like the example's" || bad "city4d: time measures $m"
import json, sys
m = json.loads(sys.argv[1])
fail = []
if m["frames"] != 8:
    fail.append("frames %d" % m["frames"])
if m["time_pairs_found"] != 1.0:
    fail.append("time pairs not in the example: %.4f found" % m["time_pairs_found"])
if m["space_pairs_found"] != 1.0:
    fail.append("space pairs not in the example: %.4f found" % m["space_pairs_found"])
if m["moving_labels"] != m["moving_labels_example"]:
    fail.append("moving labels %s, example %s" % (m["moving_labels"], m["moving_labels_example"]))
if m["moving_share"] < 0.5 * m["moving_share_example"]:
    fail.append("moving share %.4f < half the example's %.4f" % (m["moving_share"], m["moving_share_example"]))
print("\n".join(fail))
sys.exit(1 if fail else 0)
PY
grep -q '"violations":0' c0/summary.json && ok "city4d: 0 violations (independent checker, x y z t)" || bad "city4d: violations in summary.json"
n=$(ls c0/frame_*.vox 2>/dev/null | wc -l)
[[ $n -eq 8 ]] && ok "city4d: one .vox per frame ($n)" || bad "city4d: $n frame .vox files"
cp c0/lattice.txt back.txt
run_gs 0 model -c "$C/city4d.ini" --set model.example="$PWD/back.txt" --set model.passes=1 --set model.max_passes=1 -o back
expect_rc 0 "city4d: lattice.txt (X Y Z T) reads back as a 4D example"
run_gs 0 model -c "$C/city4d.ini" --set model.example="$PWD/c0/lattice.h5" --set model.passes=1 --set model.max_passes=1 -o backh5
expect_rc 0 "city4d: lattice.h5 ([t][z][y][x]) reads back as a 4D example"
expect_err "4D: 8 frames of 32x32x3 from the example's 8 frames of 32x32x3" "city4d: the .h5 example has its 8 frames"
grep -q 'GridType="Collection" CollectionType="Temporal"' c0/lattice.xmf && ok "lattice.xmf is a time series" || bad "lattice.xmf: no temporal collection"
if command -v pvpython >/dev/null; then
  cat >pv.py <<'EOF2'
import sys
from paraview.simple import XDMFReader
from paraview import servermanager as sm
from vtk.util.numpy_support import vtk_to_numpy
import h5py, numpy as np
r = XDMFReader(FileNames=[sys.argv[1] + "/lattice.xmf"])
r.UpdatePipelineInformation()
lab = h5py.File(sys.argv[1] + "/lattice.h5", "r")["/model/labels"][...]
same = []
for i, t in enumerate(r.TimestepValues):
    r.UpdatePipeline(t)
    v = vtk_to_numpy(sm.Fetch(r).GetCellData().GetArray("label"))
    same.append(bool(np.array_equal(v, lab[i].ravel())))
print("PV", len(r.TimestepValues), all(same))
EOF2
  pv=$(timeout 300 xvfb-run -a pvpython pv.py c0 2>&1 | grep '^PV')
  [[ $pv == "PV 8 True" ]] && ok "ParaView plays lattice.xmf: 8 time steps, each the frame of lattice.h5" \
    || bad "ParaView on the 4D lattice.xmf: $pv"
else
  echo "check skipped: ParaView time series check: pvpython is not installed (apt-get install python3-paraview)"
fi
finish
