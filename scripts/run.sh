#!/usr/bin/env bash
# Sets up a fresh Debian 12 machine, builds lsdem and runs the default job:
# the three-grains compression scene (paper Fig. 5) in 2D, with its plots.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
LSDEM_TARGETS=lsdem bash scripts/build.sh
./build/apps/lsdem run apps/scenes/three_grains/three_grains_2d.toml --out three_grains_2d-out --overwrite
./build/apps/lsdem plot three_grains_2d-out
