#!/usr/bin/env bash
# Runs the three-grains compression scenes (paper Fig. 5) in 2D and 3D and
# renders their first, middle and last frames into docs/images/ with
# `lsdem render` (needs gnuplot). Uses the build in build/ (scripts/build.sh).
# Usage: bash scripts/three_grains.sh [2d|3d|both]   (default both)
set -euo pipefail
cd "$(dirname "$0")/.."
which="${1:-both}"
lsdem=./build/apps/lsdem
[ -x "$lsdem" ] || bash scripts/build.sh
mkdir -p docs/images

if [ "$which" = 2d ] || [ "$which" = both ]; then
  "$lsdem" run apps/scenes/three_grains/three_grains_2d.toml --out three_grains_2d-out
  for frame in 0 40 60 last; do
    "$lsdem" render three_grains_2d-out --frame "$frame" --size 480x800 \
      -o "docs/images/three_grains_2d_${frame}.png"
  done
fi

if [ "$which" = 3d ] || [ "$which" = both ]; then
  "$lsdem" run apps/scenes/three_grains/three_grains_3d.toml --out three_grains_3d-out
  for frame in 0 60 last; do
    "$lsdem" render three_grains_3d-out --frame "$frame" --view -60,20 --up z --size 700x900 \
      -o "docs/images/three_grains_3d_${frame}.png"
  done
fi
