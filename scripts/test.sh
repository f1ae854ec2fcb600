#!/usr/bin/env bash
# Sets up a fresh Debian 12 machine, builds lsdem and runs the unit tests.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh
cd build
ctest --output-on-failure -j "$(nproc 2>/dev/null || echo 2)"
