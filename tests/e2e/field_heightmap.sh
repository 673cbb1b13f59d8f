# End-to-end: height-map examples write heightmap.png (the paper's Figure 7c),
# a 16-bit grey PNG listed in summary.json (kind image, role heightmap). Read
# back (Pillow) it must give the surface heights of field.h5 computed here
# independently (numpy: each column's highest inside-to-outside crossing,
# mapped as the example was read: (z - base) / example.height, base =
# (example.depth - example.height) / 2) within one 16-bit level, and look like
# a terrain: its spread is at least half the source image's.
# configs/field/terrain.ini (redistributable SRTM-free raylib height map) and
# texture.ini (fetched data, skipped without it), smaller than the configs.
source "$GS_ROOT/tests/e2e/lib.bash"
PY=/usr/bin/python3

check_png() { # NAME RUN SOURCE_IMAGE DEPTH HEIGHT
  local r
  r=$($PY - "$@" 2>&1 <<'EOF'
import json, sys
import h5py, numpy as np
from PIL import Image
name, run, src, depth, height = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4]), float(sys.argv[5])
s = json.load(open(run + "/summary.json"))
outs = [o for o in s["outputs"] if o["role"] == "heightmap"]
assert len(outs) == 1 and outs[0]["kind"] == "image" and outs[0]["path"] == "heightmap.png", outs
im = Image.open(run + "/heightmap.png")
a = np.asarray(im).astype(np.int64)
assert im.mode.startswith("I") and a.max() > 255, (im.mode, a.max())  # 16 bits, not 8
d = np.asarray(h5py.File(run + "/field.h5")["/field/distance"])  # [nz, ny, nx]
nz, ny, nx = d.shape
assert a.shape == (ny, nx), (a.shape, d.shape)
z = np.zeros((ny, nx))
found = np.zeros((ny, nx), bool)
for k in range(nz - 2, -1, -1):
    lo, hi = d[k], d[k + 1]
    hit = (lo < 0) & (hi >= 0) & ~found
    z[hit] = k + lo[hit] / (lo[hit] - hi[hit])
    found |= hit
z[~found & (d[nz - 1] < 0)] = nz - 1
base = (depth - height) / 2
want = np.clip(np.rint((z - base) / height * 65535), 0, 65535)[::-1]  # row 0 = largest y
err = np.abs(want - a).max()
g = np.asarray(Image.open(src).convert("F")) / (65535.0 if Image.open(src).mode.startswith("I") else 255.0)
print(f"{name}: {nx}x{ny} 16-bit, max difference {err:.0f} levels; spread {a.std() / 65535:.3f} (source image {g.std():.3f})")
assert err <= 1, err
assert a.std() / 65535 > 0.5 * g.std(), (a.std() / 65535, g.std())
EOF
)
  local rc=$?
  echo "$r" | tail -3
  [[ $rc == 0 ]] && ok "$1: heightmap.png = the field's surface heights" || bad "$1: heightmap.png: $r"
}

run_gs 0 field -c "$GS_ROOT/configs/field/terrain.ini" -o terrain --set example.size=32 --set field.target=64x64x16
expect_rc 0 "terrain.ini"
check_png terrain.ini terrain "$DATA/heightmaps/raylib-heightmap.png" 16 10
if need_config "texture.ini height map" "$GS_ROOT/configs/field/texture.ini"; then
  run_gs 0 field -c "$GS_ROOT/configs/field/texture.ini" -o texture --set example.size=32 --set field.target=64x64x16
  expect_rc 0 "texture.ini"
  check_png texture.ini texture "$DATA/textures/embark-5.png" 16 8
  # output.geometry = contour: the preview still shows the source on the left
  # (it was empty: the source mesh was built only for copied.ply)
  lr=$(/usr/bin/python3 - texture/preview.png <<'PY'
import sys, matplotlib.image as mi
im = mi.imread(sys.argv[1])[..., :3]
w = im.shape[1]
bg = im[0, 0]
share = lambda a: float((abs(a - bg).sum(-1) > 0.05).mean())
print("%.2f %.2f" % (share(im[:, : w // 2 - 4]), share(im[:, w // 2 + 4 :])))
PY
)
  /usr/bin/python3 -c "import sys; l, r = map(float, '$lr'.split()); sys.exit(0 if l > 0.05 and r > 0.05 else 1)" &&
    ok "texture.ini preview: source and output drawn (shares $lr)" || bad "texture.ini preview: a panel is empty (shares $lr)"
fi
# no height map for other examples
run_gs 0 field -c "$GS_ROOT/configs/field/quick.ini" -o quick --set output.preview=no
[[ ! -e quick/heightmap.png ]] && ok "no heightmap.png for a non-height-map example" || bad "heightmap.png written for quick.ini"
finish
