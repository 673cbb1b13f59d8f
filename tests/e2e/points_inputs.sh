# End-to-end: the points engine's inputs: a PLY example (with a mesh output),
# a mesh sampled uniformly (z up and y up), and bad inputs named with their
# file, line or key (PLY without normals, geometry not extending past the
# box, unknown key, wrong type, missing file, missing box).
source "$GS_ROOT/tests/e2e/lib.bash"
CFG=$GS_ROOT/configs/points/quick.ini

metric() { /usr/bin/python3 -c 'import json,sys;print(json.load(open(sys.argv[1]+"/summary.json"))["metrics"][sys.argv[2]])' "$1" "$2"; }

# The example PLY: the quick config's output (3 x 3, geometry everywhere).
run_gs 0 points -c "$CFG" -o run1
expect_rc 0 "quick.ini (makes the example PLY)"

# --- a PLY example (the quick run's output) and a sampled mesh --------------
cat >ply.ini <<EOF
[input]
kind = ply
path = run1/points.ply
box_lo = 0.9, 0.9, -1
box_hi = 2.1, 2.1, 1
spacing = 0
[points]
out_size = 2.5, 2.5
EOF
run_gs 2 points -c ply.ini -o plyrun --set output.mesh=true
expect_rc 0 "PLY example at np=2 with a mesh"
/usr/bin/python3 - plyrun/mesh.ply "$GS_ROOT" <<'EOF' && ok "mesh.ply re-reads (binary PLY, sizes consistent), every vertex used, edges manifold and oriented" || bad "mesh.ply invalid"
import sys
sys.path.insert(0, sys.argv[2] + "/analysis")
import mesh_validity
r = mesh_validity.file_validity(sys.argv[1])
print(r)
# trimmed to the points it is open, but no vertex is left loose (MeshLab and
# Blender show those as stray points) and no edge is shared by 3 faces
assert r["unreferenced_vertices"] == 0 and r["nonmanifold_edges"] == r["misoriented_edges"] == 0, r
raw = open(sys.argv[1], "rb").read()
end = raw.index(b"end_header\n") + 11
h = raw[:end].decode().split("\n")
nv = int([l for l in h if l.startswith("element vertex")][0].split()[2])
nf = int([l for l in h if l.startswith("element face")][0].split()[2])
assert nv > 1000 and nf > 1000, (nv, nf)
assert len(raw) == end + 12 * nv + 13 * nf, (len(raw), end, nv, nf)
EOF
run_gs 1 points -c ply.ini -o plyrun1 --set output.mesh=true
[[ "$(digest_of plyrun1 2>/dev/null)" == "$(digest_of plyrun 2>/dev/null)" ]] &&
  ok "PLY example: same digest at np 1 and 2" || bad "PLY example digests differ"

/usr/bin/python3 - <<'EOF'
import math
n = 60
with open("bumps.obj", "w") as f:
    for j in range(n + 1):
        for i in range(n + 1):
            x, y = 3.0 * i / n, 3.0 * j / n
            f.write("v %.6f %.6f %.6f\n" % (x, y, 0.15 * math.sin(4 * x) * math.cos(3 * y)))
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i + 1
            f.write("f %d %d %d\nf %d %d %d\n" % (a, a + 1, a + n + 2, a, a + n + 2, a + n + 1))
EOF
cat >mesh.ini <<EOF
[input]
kind = mesh
path = bumps.obj
spacing = 0.04
box_lo = 0.7, 0.7, -0.2
box_hi = 2.3, 2.3, 0.2
[points]
out_size = 3, 3
EOF
run_gs 2 points -c mesh.ini -o meshrun
expect_rc 0 "mesh example (sampled uniformly) at np=2"
ratio=$(metric meshrun density_ratio 2>/dev/null)
/usr/bin/python3 -c "import sys; r=float(sys.argv[1]); sys.exit(0 if abs(r-1) < 0.10 else 1)" "$ratio" &&
  ok "mesh example: output density within 10% of the example's (ratio $ratio)" ||
  bad "mesh example density ratio $ratio"

# The same mesh with y as the reference-plane normal (file axes (x, y, z)
# -> (y, z, x)): the output lies in the x-z plane with heights along y and
# holds about as many points (sampling order differs, so not bit-equal).
/usr/bin/python3 - <<'EOF'
out = []
for line in open("bumps.obj"):
    if line.startswith("v "):
        _, x, y, z = line.split()
        out.append("v %s %s %s\n" % (y, z, x))
    else:
        out.append(line)
open("bumps_yup.obj", "w").write("".join(out))
EOF
sed -e 's/bumps.obj/bumps_yup.obj/' -e 's/^box_lo.*/box_lo = 0.7, -0.2, 0.7\nup = y/' \
    -e 's/^box_hi.*/box_hi = 2.3, 0.2, 2.3/' mesh.ini >mesh_yup.ini
run_gs 1 points -c mesh_yup.ini -o meshyup
expect_rc 0 "mesh example with input.up = y"
/usr/bin/python3 - meshrun/points.ply meshyup/points.ply <<'EOF' && ok "input.up = y: output in the x-z plane, heights along y, normals along y, same size" || bad "input.up = y output is not the permuted texture"
import struct, sys
def load(p):
    raw = open(p, "rb").read(); end = raw.index(b"end_header\n") + 11
    n = (len(raw) - end) // 28  # x y z nx ny nz (float), patch (int)
    return [struct.unpack_from("<6f", raw, end + 28 * i) for i in range(n)]
a, b = load(sys.argv[1]), load(sys.argv[2])
assert abs(len(b) / len(a) - 1) < 0.05, (len(a), len(b))
# y-up file coords are (y0, z0, x0) of the z-up texture: plane axes z and x
assert all(0 <= p[2] < 3 and 0 <= p[0] < 3 and abs(p[1]) < 0.25 for p in b)
assert sum(p[4] for p in b) / len(b) > 0.8   # normals point up along y
assert sum(p[5] for p in a) / len(a) > 0.8   # and along z for the z-up run
EOF

# --- bad inputs ------------------------------------------------------------
/usr/bin/python3 - <<'EOF'
with open("nonormals.ply", "w") as f:
    f.write("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
            "property float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n")
EOF
sed 's#run1/points.ply#nonormals.ply#' ply.ini >nonormals.ini
run_gs 0 points -c nonormals.ini -o bad1
expect_rc 4 "PLY without normals"
expect_err "nonormals.ply: line 3: element vertex has no normals" "PLY without normals: file and line named"

sed -e 's/^box_lo.*/box_lo = 0, 0.9, -1/' ply.ini >shortpad.ini
run_gs 2 points -c shortpad.ini -o bad2
expect_rc 2 "geometry not extending past the box (np=2)"
expect_err "geometry on side -x reaches" "short padding: the side is named"
expect_err "input.box_lo" "short padding: the box keys are named"
expect_no_crash "short padding at np=2"

printf '[points]\nwn = 3\n[input]\nkind = weave\n' >unknown.ini
run_gs 0 points -c unknown.ini -o bad3
expect_rc 2 "unknown key"
expect_err "unknown.ini:2: [points] wn = 3: unknown key; did you mean 'w_n'?" "unknown key: file, line and suggestion"

printf '[input]\ncells = many\n' >type.ini
run_gs 0 points -c type.ini -o bad4
expect_rc 2 "wrong type"
expect_err "type.ini:2: [input] cells = many" "wrong type: file, line and key named"

printf '[input]\nkind = ply\npath = missing.ply\nbox_lo = 0,0,0\nbox_hi = 1,1,1\n' >missing.ini
run_gs 0 points -c missing.ini -o bad5
expect_rc 3 "missing input file"
expect_err "missing.ply" "missing input file named"

printf '[input]\nkind = mesh\npath = bumps.obj\n' >nobox.ini
run_gs 0 points -c nobox.ini -o bad6
expect_rc 2 "mesh without a box"
expect_err "[input] box_lo" "mesh without a box: key named"

finish
