#!/usr/bin/env bash
# Sets up a fresh Debian 12 machine, builds lsdem and runs the unit tests.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
# LSDEM_MPI=1 (CI sets it): also the MPI domain decomposition and its tests,
# run on 1, 2 and 4 ranks (docs/parallel.md).
if [[ ${LSDEM_MPI:-0} == 1 ]]; then
  bash scripts/build.sh -DLSDEM_MPI=ON
else
  bash scripts/build.sh
fi
cd build
ctest --output-on-failure -j "$(nproc 2>/dev/null || echo 2)"
