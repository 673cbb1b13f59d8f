# End-to-end: 3D tile sets (issue #22). MarkovJunior's Knots3D and Escher
# (fullSymmetry: 48 cube symmetries) and DeBroglie's castle (json adjacency,
# symmetry 8, ground / border / fixed tile), all in the repository's data/.
# Each runs from its config at np 1 and 2 (same digest); the assembled
# tiles.vox is checked from the file alone: MarkovJunior outputs by
# analysis/mj_tiles_check.py (MarkovJunior's own expansion re-derived in
# Python: every tile known, every neighbour pair allowed), the castle by
# analysis/tile_seams.py (faces between tiles continue voxel for voxel, as
# DeBroglie's autoAdjacency demands, except its listed exceptions: ground
# below, a turret on a corner), its ground, empty border and fixed turret
# top; stop + resume at another rank count keeps the digest. About 15 s.
source "$GS_ROOT/tests/e2e/lib.bash"
C=$GS_ROOT/configs/model
A=$GS_ROOT/analysis
MJ=vox/MarkovJunior-tilesets
DB=vox/DeBroglie-castle
metric() { /usr/bin/python3 -c 'import json,sys;print(json.load(open(sys.argv[1]+"/summary.json"))["metrics"][sys.argv[2]])' "$1" "$2"; }
has_output() { /usr/bin/python3 -c 'import json,sys;o=json.load(open(sys.argv[1]+"/summary.json"))["outputs"];sys.exit(0 if sys.argv[2] in json.dumps(o) else 1)' "$1" "$2"; }

need_data "3D tile sets" $MJ/Knots3D.xml $MJ/Escher.xml $DB/castle.json || finish

for cfg in tiles-knots3d tiles-escher tiles-castle tiles-castle-regions; do
  run_gs 0 model -c "$C/$cfg.ini" -o ${cfg}1
  expect_rc 0 "$cfg at np=1"
  run_gs 2 model -c "$C/$cfg.ini" -o ${cfg}2
  expect_rc 0 "$cfg at np=2"
  d1=$(digest_of ${cfg}1); d2=$(digest_of ${cfg}2)
  [[ -n $d1 && $d1 == "$d2" ]] && ok "$cfg: np 1 and 2 digest $d1" || bad "$cfg: digest $d1 != $d2"
  for m in violations rule_violations pins_unmet; do
    v=$(metric ${cfg}2 $m)
    [[ $v == 0 ]] && ok "$cfg: $m = 0" || bad "$cfg: $m = $v"
  done
  for f in tiles.vox mesh.ply preview.png lattice.vox lattice.xmf; do
    [[ -s ${cfg}2/$f ]] && ok "$cfg: $f written" || bad "$cfg: no $f"
  done
  has_output ${cfg}2 tiles.vox && ok "$cfg: summary.json lists tiles.vox" || bad "$cfg: tiles.vox not in summary.json outputs"
  # the picture: tiles (left) and output (right) both drawn, not blank
  /usr/bin/python3 -c 'import sys, matplotlib.image as im; a = im.imread(sys.argv[1]); l, r = a[:, :a.shape[1]//2 - 4, :3], a[:, a.shape[1]//2 + 4:, :3]; assert l.std() > 0.02 and r.std() > 0.05, (l.std(), r.std())' ${cfg}2/preview.png \
    && ok "$cfg: preview.png shows the tiles and the output" || bad "$cfg: preview.png blank"
done

# MarkovJunior: the output made of known oriented tiles, every neighbour pair
# allowed by MarkovJunior's own expansion; the tubes of Knots3D also join face
# to face (a tube reaching a face goes on in the next tile)
res=$(/usr/bin/python3 "$A/mj_tiles_check.py" "$GS_DATA_ROOT/$MJ/Knots3D.xml" Knots3D/Tubes tiles-knots3d2/tiles.vox 2>&1) \
  && ok "tiles-knots3d: MarkovJunior check: $res" || bad "tiles-knots3d: MarkovJunior check failed: $res"
res=$(/usr/bin/python3 "$A/mj_tiles_check.py" "$GS_DATA_ROOT/$MJ/Escher.xml" Escher tiles-escher2/tiles.vox 2>&1) \
  && ok "tiles-escher: MarkovJunior check: $res" || bad "tiles-escher: MarkovJunior check failed: $res"
/usr/bin/python3 - "$A" tiles-knots3d2/tiles.vox <<'PY' && ok "tiles-knots3d: every tile face joined (tubes continue)" || bad "tiles-knots3d: tubes broken at tile faces"
import sys; sys.path.insert(0, sys.argv[1])
from tile_seams import read_vox, seams
r = seams(read_vox(sys.argv[2]), [5, 5, 5])
assert all(r[a]["joined_share"] == 1.0 for a in "xyz"), r
# the outer tiles are Empty (model.border_tile): nothing touches the box
v = read_vox(sys.argv[2])
assert v.shape == (80, 80, 80) and v[:5].max() == 0 and v[-5:].max() == 0 and v[:, :, :5].max() == 0, v.shape
assert (v > 0).mean() > 0.1
PY

# DeBroglie's castle: seams, ground, border, fixed tile, from the voxels
for cfg in tiles-castle tiles-castle-regions; do
/usr/bin/python3 - "$A" ${cfg}2/tiles.vox "$GS_DATA_ROOT/$DB" $cfg <<'PY' && ok "$cfg: tiles join face to face (x, y all; z all but turrets on corners), ground below, empty border, fixed turret top" || bad "$cfg: castle check failed"
import sys; sys.path.insert(0, sys.argv[1])
import numpy as np
from tile_seams import read_vox, read_vox_palette, seams
v = read_vox(sys.argv[2]); pal = read_vox_palette(sys.argv[2])
rgb = lambda f: {tuple(read_vox_palette(f)[c][:3]) for c in set(read_vox(f).flatten()) - {0}}
ground = rgb(sys.argv[3] + "/ground.vox"); turret = rgb(sys.argv[3] + "/turret.vox")
col = lambda a: {tuple(pal[c][:3]) for c in set(a.flatten()) - {0}}
S = 5
r = seams(v, [S] * 3)
assert r["x"]["joined_share"] == 1.0 and r["y"]["joined_share"] == 1.0, r
# z faces above the ground layer: continuous unless a turret stands there
nx, ny, nz = (n // S for n in v.shape)
for k in range(2, nz):
    for x in range(nx):
        for y in range(ny):
            a = v[x*S:(x+1)*S, y*S:(y+1)*S, k*S-1] > 0; b = v[x*S:(x+1)*S, y*S:(y+1)*S, k*S] > 0
            if (a != b).any():
                assert col(v[x*S:(x+1)*S, y*S:(y+1)*S, k*S:(k+1)*S]) & turret, (x, y, k)
# the bottom tile layer is ground, nothing else is
assert col(v[:, :, :S]) == ground and (v[:, :, :S] > 0).all()
assert not (col(v[:, :, S:]) & ground)
# border tiles above the ground are empty (castle.json: border empty, excludeSides zmin)
assert v[:S, :, S:].max() == 0 and v[-S:, :, S:].max() == 0 and v[:, :S, S:].max() == 0 and v[:, -S:, S:].max() == 0
assert v[:, :, -S:].max() == 0
# fixedTile turret_top at tile (5, 4, 8)
assert col(v[5*S:6*S, 4*S:5*S, 8*S:9*S]) & turret
# and it is a castle: walls well above the ground
assert (v[:, :, 2*S:] > 0).mean() > 0.02, (v[:, :, 2*S:] > 0).mean()
PY
done

# stop + resume at another rank count keeps the digest
GS_STOP_AFTER_UNITS=4 run_gs 2 model -c "$C/tiles-castle-regions.ini" -o stop
expect_rc 9 "tiles-castle-regions: GS_STOP_AFTER_UNITS=4 stops with exit 9"
run_gs 0 resume stop
expect_rc 0 "tiles-castle-regions: resume at np=1"
[[ $(digest_of stop) == "$(digest_of tiles-castle-regions1)" ]] && ok "tiles-castle-regions: stop at np=2 + resume at np=1: same digest" \
  || bad "tiles-castle-regions: resume digest $(digest_of stop) != $(digest_of tiles-castle-regions1)"

# bad inputs: one clear message, non-zero exit
run_gs 0 model -c "$C/tiles-knots3d.ini" --set model.border_tile=Nope -o bad1
expect_rc 2 "border_tile naming no tile"
expect_err "model.border_tile = Nope: no such tile" "border_tile error names the key"
run_gs 0 model -c "$C/tiles-knots3d.ini" --set model.tile_folder=Knots3D/none -o bad2
[[ $rc -ne 0 ]] && ok "missing tile folder: exit $rc" || bad "missing tile folder accepted"
expect_err "Knots3D/none/Empty.vox" "missing tile names the .vox file"
run_gs 0 model -c "$C/tiles-castle.ini" --set model.size=4x4x10 -o bad3
expect_rc 2 "fixed tile outside the output"
expect_err "fixedTile turret_top 0 at (5, 4, 8) lies outside" "fixed tile error names the tile and point"
run_gs 0 model -c "$C/tiles-escher.ini" --set model.subset=A -o bad4
expect_rc 2 "subset on a MarkovJunior set"
expect_err "has no subsets" "subset error"
finish
