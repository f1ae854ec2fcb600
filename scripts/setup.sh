#!/usr/bin/env bash
# Installs every Debian package lsdem needs to build, test and plot.
# Idempotent: when all packages are present it returns without touching apt.
set -euo pipefail

packages=(
  build-essential cmake ninja-build ccache pkg-config
  libeigen3-dev libcgal-dev libboost-dev libgmp-dev libmpfr-dev
  libassimp-dev libtomlplusplus-dev libcli11-dev zlib1g-dev libtiff-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  gnuplot-nox
  python3-dev pybind11-dev python3-numpy python3-pytest
)
# LSDEM_PARAVIEW=1: also ParaView with its Python and a virtual display
# (`lsdem paraview`, scripts/check_paraview.sh; about 800 MB).
if [[ ${LSDEM_PARAVIEW:-0} == 1 ]]; then packages+=(paraview python3-paraview xvfb xauth); fi
# LSDEM_MPI=1: also OpenMPI, for the distributed runs (docs/parallel.md).
if [[ ${LSDEM_MPI:-0} == 1 ]]; then packages+=(libopenmpi-dev openmpi-bin); fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if ((${#missing[@]} == 0)); then
  echo "setup: all ${#packages[@]} packages present"
  exit 0
fi

echo "setup: installing ${missing[*]}"
sudo_cmd=()
if [[ $(id -u) -ne 0 ]]; then sudo_cmd=(sudo); fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -q
"${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
