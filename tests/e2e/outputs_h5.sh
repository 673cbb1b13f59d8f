# End-to-end: HDF5 outputs that explain themselves and a label table users'
# tools show (#23 items 3, 5). Read with h5py as users read them: every
# dataset of field.h5 (written by 2 ranks), lattice.h5 and micro.h5 chunked and
# deflate-compressed; every string attribute comes back as text (str), not
# bytes; the main arrays carry index_order and units, the groups up_axis;
# lattice.h5's label table lists exactly the labels of the lattice with the
# colours lattice.vox gives them, /model/colour is every cell's label colour,
# tile names for a tile set; ParaView (pvpython, when installed) opens
# lattice.xmf with the label and the 3-component colour per cell.
source "$GS_ROOT/tests/e2e/lib.bash"

run_gs 2 field -c "$GS_ROOT/configs/field/quick.ini" -o field
expect_rc 0 "field quick.ini at np 2"
run_gs 0 micro -c "$GS_ROOT/configs/micro/quick.ini" -o micro
expect_rc 0 "micro quick.ini"
run_gs 0 model -c "$GS_ROOT/configs/model/demo.ini" -o model
expect_rc 0 "model demo.ini"
run_gs 0 model -c "$GS_ROOT/configs/model/tiles-knots3d.ini" -o tiles
expect_rc 0 "model tiles-knots3d.ini"

/usr/bin/python3 - field/field.h5 model/lattice.h5 tiles/lattice.h5 micro/instance-0000/micro.h5 <<'EOF' \
  && ok "every dataset chunked + deflate, every string attribute str (h5py)" || bad "HDF5 layout or string type"
import sys, h5py
bad = []
for path in sys.argv[1:]:
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            for k, v in obj.attrs.items():
                if isinstance(v, bytes) or getattr(v, "dtype", None) is not None and v.dtype.kind == "S":
                    bad.append(f"{path}:/{name}@{k} reads as bytes")
            if isinstance(obj, h5py.Dataset) and obj.size > 0 and name != "geosynth/config":
                if obj.chunks is None or obj.compression != "gzip":
                    bad.append(f"{path}:/{name}: chunks {obj.chunks}, compression {obj.compression}")
        visit("", f)
        f.visititems(visit)
for b in bad:
    print(b)
sys.exit(1 if bad else 0)
EOF

/usr/bin/python3 - field/field.h5 model/lattice.h5 <<'EOF' && ok "index_order, units and up_axis recorded" || bad "index_order/units/up_axis missing"
import sys, h5py
f, m = h5py.File(sys.argv[1], "r"), h5py.File(sys.argv[2], "r")
for ds in (f["/field/distance"], f["/field/levels"], f["/source/levels"], m["/model/labels"], m["/model/colour"]):
    assert isinstance(ds.attrs["index_order"], str) and "x fastest" in ds.attrs["index_order"], ds.name
for ds in (f["/field/distance"], f["/field/levels"], m["/model/labels"]):
    assert isinstance(ds.attrs["units"], str) and ds.attrs["units"], ds.name
assert f["/field"].attrs["up_axis"] == "z" and m["/model"].attrs["up_axis"] == "z"
assert m["/model"].attrs["voxel_size"] > 0 and "voxel_size" in m["/model"].attrs["units"]
EOF

label_table() { # label_table RUN what [names-pattern]
  /usr/bin/python3 - "$GS_ROOT" "$1" "${3:-}" <<'EOF' && ok "$2" || bad "$2"
import re, sys, h5py, numpy as np
sys.path.insert(0, sys.argv[1] + "/analysis")
import tile_seams
run, pat = sys.argv[2], sys.argv[3]
f = h5py.File(f"{run}/lattice.h5", "r")
lab = f["/model/labels"][...]
t = f["/model/label_table"]
ids, rgb = t["id"][...], t["rgb"][...]
names = t.attrs["names"].split("\n")
used = np.unique(lab[lab != 0])
assert np.array_equal(ids, used), (ids, used)
assert len(names) == len(ids) == t.attrs["labels"], (len(names), len(ids))
assert len(set(names)) == len(names), "names repeat"
if pat:
    assert all(re.fullmatch(pat, n) for n in names), names[:5]
pal = tile_seams.read_vox_palette(f"{run}/lattice.vox")
assert (pal[ids, :3] == rgb).all(), "label table colours != lattice.vox palette"
col = f["/model/colour"][...]
lut = np.full((65536, 3), 255, np.uint8)
lut[ids] = rgb
assert col.shape == lab.shape + (3,) and (col == lut[lab]).all(), "per-cell colour != its label's"
print(len(ids), "labels:", names[:3], "...")
EOF
}
label_table model "label table of the demo: labels, lattice.vox colours, per-cell colour" 'label [0-9]+'
label_table tiles "label table of a tile set: the tiles' names" '[A-Za-z]+ [0-9]+'

if command -v pvpython >/dev/null; then
  cat >pv.py <<'EOF'
import sys
from paraview.simple import XDMFReader
r = XDMFReader(FileNames=[sys.argv[1]])
r.UpdatePipeline()
cd = r.GetCellDataInformation()
arrays = {cd.GetArray(i).GetName(): cd.GetArray(i).GetNumberOfComponents() for i in range(cd.GetNumberOfArrays())}
print("PV", r.GetDataInformation().GetNumberOfCells(), arrays, cd.GetArray("colour").GetRange(0))
EOF
  pv=$(timeout 300 xvfb-run -a pvpython pv.py model/lattice.xmf 2>&1 | grep '^PV')
  [[ $pv == *" 64000 "* && $pv == *"'label': 1"* && $pv == *"'colour': 3"* ]] && ok "ParaView opens lattice.xmf: 64000 cells, label + RGB colour ($pv)" \
    || bad "ParaView on lattice.xmf: $pv"
else
  echo "check skipped: ParaView lattice.xmf check: pvpython is not installed (apt-get install python3-paraview)"
fi
finish
