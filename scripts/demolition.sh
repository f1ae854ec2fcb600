#!/usr/bin/env bash
# Runs the 3D demolition scene (paper Fig. 6): rebuilds its STL assets,
# runs it, and renders frames before, between and after the two crushes into
# docs/images/ with `lsdem render` (needs gnuplot). Uses the build in build/.
set -euo pipefail
cd "$(dirname "$0")/.."
lsdem=./build/apps/lsdem
[ -x "$lsdem" ] || bash scripts/build.sh
python3 scripts/make_demolition_assets.py
mkdir -p docs/images
"$lsdem" run apps/scenes/demolition/demolition.toml --out demolition-out
for frame in 0 25 40 last; do
  "$lsdem" render demolition-out --frame "$frame" --up y --view -70,20 --size 1000x750 \
    -o "docs/images/demolition_${frame}.png"
done
