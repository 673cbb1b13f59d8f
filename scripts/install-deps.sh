#!/usr/bin/env bash
# Installs the Debian 12 packages geosynth needs to build, test and run.
# Idempotent: installs only what is missing, runs apt-get update only then.
set -euo pipefail

packages=(
  build-essential pkg-config make
  openmpi-bin libopenmpi-dev libhdf5-openmpi-dev hdf5-tools
  libopenvdb-dev libboost-dev libtbb-dev
  libstb-dev librandom123-dev libinih-dev libxxhash-dev
  liblapacke-dev liblapack-dev libblas-dev libpng-dev zlib1g-dev
  libcmocka-dev valgrind clang libclang-rt-14-dev
  libfftw3-dev
  libosmesa6-dev chromium xvfb    # headless thumbnails (OSMesa), page tests (Chromium), VTK under xvfb-run
  python3-numpy python3-h5py python3-matplotlib python3-openvdb
  slurm-wlm munge
  # the tools users open outputs with, which the output tests run (tests/e2e/outputs_glb.sh,
  # outputs_h5.sh, points.sh, model.sh): Blender, ParaView's pvpython, MeshLab's meshlabserver;
  # node runs the glTF validator and three.js' loader (tests/gltf, npm below)
  blender python3-paraview meshlab xauth nodejs
  curl ca-certificates            # make data (scripts/fetch-data.sh)
)

command -v npm >/dev/null || packages+=(npm) # nodesource's nodejs brings its own

missing=()
for p in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)
  [[ "$status" == "install ok installed" ]] || missing+=("$p")
done

# tests/gltf's node packages (pinned by its package-lock.json) into build/gltf
gltf_packages() {
  local root dir
  root=$(cd "$(dirname "$0")/.." && pwd)
  dir=$root/build/gltf
  if cmp -s "$root/tests/gltf/package-lock.json" "$dir/package-lock.json" && [[ -d $dir/node_modules ]]; then
    cp "$root/tests/gltf/check.mjs" "$dir/"
    return 0
  fi
  mkdir -p "$dir"
  cp "$root/tests/gltf/package.json" "$root/tests/gltf/package-lock.json" "$root/tests/gltf/check.mjs" "$dir/"
  echo "deps: npm ci in build/gltf (glTF validator, three.js)"
  (cd "$dir" && npm ci --no-audit --no-fund --silent) \
    || echo "deps: npm ci in build/gltf failed: the glTF reader checks will report skipped" >&2
}

if [[ ${#missing[@]} -eq 0 ]]; then
  echo "deps: all ${#packages[@]} packages present"
  gltf_packages
  exit 0
fi

echo "deps: installing ${missing[*]}"
sudo=""
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo >/dev/null || { echo "deps: need root or sudo to install: ${missing[*]}" >&2; exit 1; }
  sudo="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
gltf_packages
echo "deps: done"
