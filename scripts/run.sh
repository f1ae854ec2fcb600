#!/usr/bin/env bash
# Sets up a fresh Debian 12 machine, builds lsdem and runs the default job.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh
./build/apps/lsdem shape examples/shapes/random_grain_3d.toml
