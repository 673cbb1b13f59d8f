# End-to-end: the copied mesh (paper section 5.3, copied.ply) is a valid mesh,
# measured from the file by analysis/mesh_validity.py (the shared measure):
# a welded closed 2-manifold (no boundary edges, so no cracks; no
# non-manifold or misoriented edges or vertices; no degenerate, duplicate or
# coincident faces; no coincident vertices) and no doubled walls (along rays
# parallel to the axes the crossings alternate in and out). Every count must
# be 0, as for the contour of a field: a valid mesh has none.
# configs/field/grid.ini (the paper's GRID, 128^3) and configs/field/balls.ini
# (at 64^3 here, for time), and spot.obj (a mesh source: its own triangles).
# The copy must copy: most vertices sit on the copied source surface.
source "$GS_ROOT/tests/e2e/lib.bash"
PY=/usr/bin/python3
V=$GS_ROOT/analysis/mesh_validity.py

check_mesh() { # NAME RUN
  $PY - "$2" "$V" <<'EOF' && ok "$1: copied.ply is a valid mesh" || bad "$1: copied.ply is not a valid mesh"
import os, sys
sys.path.insert(0, os.path.dirname(sys.argv[2]))
import mesh_validity as mv
f = sys.argv[1] + "/copied.ply"
r = mv.file_validity(f)
r.update(mv.file_rays(f))
bad = {k: r[k] for k in ("unreferenced_vertices", "degenerate_faces", "zero_area_faces",
                         "duplicate_faces", "coincident_faces", "boundary_edges",
                         "nonmanifold_edges", "misoriented_edges", "nonmanifold_vertices",
                         "coincident_vertices", "ray_violations") if r[k]}
if bad or not r["manifold"]:
    print("invalid:", bad, "at", r["ray_violations_at"][:3], file=sys.stderr)
    sys.exit(1)
EOF
  $PY - "$2" <<'EOF' && ok "$1: most vertices copied from the source surface" || bad "$1: the copy did not copy"
import json, sys
m = json.load(open(sys.argv[1] + "/summary.json"))["metrics"]
print("copied vertex share %.3f, seam vertices %d, mean shift %.3f samples" %
      (m["copied_vertex_share"], m["copied_seam_vertices"], m["copied_mean_shift"]), file=sys.stderr)
assert m["copied_vertex_share"] > 0.5
assert m["copied_triangles"] > 1000
EOF
}

run_gs 2 field -c "$GS_ROOT/configs/field/grid.ini" -o grid --set output.preview=no
expect_rc 0 "grid.ini"
check_mesh grid.ini grid
run_gs 2 field -c "$GS_ROOT/configs/field/balls.ini" -o balls --set field.target=64 --set output.preview=no
expect_rc 0 "balls.ini at 64^3"
check_mesh "balls.ini at 64^3" balls
run_gs 1 field -c "$GS_ROOT/configs/field/quick.ini" -o spot --set example.kind=file \
  --set example.path="$DATA/meshes/spot.obj" --set example.size=32 --set field.target=48 \
  --set output.geometry=copy
expect_rc 0 "spot.obj copied"
check_mesh "spot.obj (mesh source)" spot
finish
