#!/usr/bin/env bash
# `make demo`: every engine once on 2 MPI ranks, on built-in examples or the
# repository's data/ (nothing fetched, nothing outside the repository), each
# into runs/demo-ENGINE (replaced on every demo):
#   field   configs/field/grid.ini       the paper's GRID: a built-in perturbed cylinder grid
#                                        with balls, 64^3 -> 128^3 in three iterations
#   points  configs/points/chainmail.ini the paper's chain mail with small bumps (its
#                                        figure 5): a generated point set, patches warped and
#                                        blended into a larger one
#   micro   configs/micro/stone.ini      chiselled stone (the paper's Fig. 1 arrowhead
#                                        parameters) on data/meshes/spot.obj
#   model   configs/model/demo.ini       Merrell's parliament (data/, DeBroglie's CSV copy)
#                                        -> an 80x80x10 lattice
# then renders preview pictures (example | output, `geosynth preview`) and
# ends with the list of files to open. About a minute on 2 cores.
set -eu
cd "$(dirname "$0")/.."
export OMPI_ALLOW_RUN_AS_ROOT=${OMPI_ALLOW_RUN_AS_ROOT:-1} OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=${OMPI_ALLOW_RUN_AS_ROOT_CONFIRM:-1}
# One machine: shared-memory transport, no probing of cluster networks (as tests/run.sh).
export OMPI_MCA_pml=${OMPI_MCA_pml:-ob1} OMPI_MCA_btl=${OMPI_MCA_btl:-self,vader,tcp}
GS=bin/geosynth
demos=(
  "field configs/field/grid.ini"
  "points configs/points/chainmail.ini"
  "micro configs/micro/stone.ini"
  "model configs/model/demo.ini"
)
t_all=$SECONDS
for d in "${demos[@]}"; do
  read -r engine ini <<<"$d"
  dir=runs/demo-$engine
  rm -rf "$dir"
  echo "== demo: mpirun -np 2 $GS $engine -c $ini -o $dir"
  t0=$SECONDS
  mpirun -np 2 "$GS" -q "$engine" -c "$ini" -o "$dir"
  echo "   done in $((SECONDS - t0)) s: $(/usr/bin/python3 -c 'import json,sys; s=json.load(open(sys.argv[1])); print("digest", s["digest"])' "$dir/summary.json" 2>/dev/null || echo "see $dir/summary.json")"
done

echo "== previews (geosynth preview: example | output)"
preview() { # preview OUT MESH...
  if "$GS" -q preview --out "$@" 2>/tmp/gs-demo-preview.$$; then echo "   $1"
  else echo "   (no preview $1: $(tail -1 /tmp/gs-demo-preview.$$))"; fi
  rm -f /tmp/gs-demo-preview.$$
}
"$GS" -q example grid --size 64 --out runs/demo-field/example-grid.obj
preview runs/demo-field/demo-preview.png runs/demo-field/example-grid.obj runs/demo-field/contour.ply
preview runs/demo-micro/demo-preview.png data/meshes/spot.obj runs/demo-micro/instance-0000/mesh.ply
preview runs/demo-model/demo-preview.png runs/demo-model/mesh.ply

echo
echo "demo finished in $((SECONDS - t_all)) s. To open:"
for d in "${demos[@]}"; do
  read -r engine ini <<<"$d"
  dir=runs/demo-$engine
  echo "  $dir/"
  find "$dir" -type f \( -name '*.png' -o -name '*.ply' -o -name '*.obj' -o -name '*.vox' \
       -o -name '*.xmf' -o -name '*.vdb' -o -name 'index.html' -o -name 'summary.json' \) | sort |
  while IFS= read -r f; do
    case $f in
      *.png) what="picture" ;;
      *points.ply) what="point set with normals (MeshLab, ParaView)" ;;
      *.ply|*.obj) what="mesh (MeshLab, Blender, ParaView)" ;;
      *.vox) what="voxel model (MagicaVoxel)" ;;
      *.xmf) what="HDF5 data for ParaView (File > Open, XDMF reader)" ;;
      *.vdb) what="OpenVDB grid (Blender, Houdini)" ;;
      *index.html) what="web page" ;;
      *summary.json) what="timings, quality metrics, digest" ;;
    esac
    printf '    %-44s %s\n' "${f#$dir/}" "$what"
  done
done
