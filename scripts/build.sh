#!/usr/bin/env bash
# Configures and builds lsdem (Release) in ./build. Extra arguments go to cmake.
# LSDEM_WERROR=ON turns warnings into errors (CI does); LSDEM_TARGETS builds
# only those targets (scripts/run.sh: the command line alone).
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc 2>/dev/null || echo 2)
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DLSDEM_WERROR="${LSDEM_WERROR:-OFF}" "$@" >/dev/null
if [[ -n "${LSDEM_TARGETS:-}" ]]; then
  # shellcheck disable=SC2086 # a list of target names
  cmake --build build -j "$jobs" --target ${LSDEM_TARGETS}
else
  cmake --build build -j "$jobs"
fi
