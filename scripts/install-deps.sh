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
  curl ca-certificates            # make data (scripts/fetch-data.sh)
)

missing=()
for p in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)
  [[ "$status" == "install ok installed" ]] || missing+=("$p")
done

if [[ ${#missing[@]} -eq 0 ]]; then
  echo "deps: all ${#packages[@]} packages present"
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
echo "deps: done"
