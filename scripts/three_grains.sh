#!/usr/bin/env bash
# Runs the three-grains compression scenes (paper Fig. 5) in 2D and 3D, draws
# the plots of their CSV histories (<out>/plots/: stress-strain, PSD,
# breakages, energies) with `lsdem plot`, and renders frames before, during
# and after the crushing into docs/images/three_grains_{2d,3d}_*.png with
# `lsdem render` (both need gnuplot). Uses the build in build/
# (scripts/build.sh).
# Usage: bash scripts/three_grains.sh [2d|3d|both]   (default both)
# Environment: LSDEM = the lsdem executable (default build/apps/lsdem, built
# when missing); LSDEM_OUT = folder for the output folders (default: the
# repository root, giving three_grains_2d-out/ and three_grains_3d-out/).
set -euo pipefail
cd "$(dirname "$0")/.."
which="${1:-both}"
case "$which" in
  2d|3d|both) ;;
  *) echo "usage: bash scripts/three_grains.sh [2d|3d|both]" >&2; exit 2 ;;
esac
lsdem="${LSDEM:-./build/apps/lsdem}"
[ -x "$lsdem" ] || bash scripts/build.sh
root="${LSDEM_OUT:-.}"
mkdir -p docs/images "$root"

if [ "$which" = 2d ] || [ "$which" = both ]; then
  "$lsdem" run apps/scenes/three_grains/three_grains_2d.toml --out "$root/three_grains_2d-out" --overwrite
  "$lsdem" plot "$root/three_grains_2d-out"
  for frame in 0 40 60 last; do
    "$lsdem" render "$root/three_grains_2d-out" --frame "$frame" --size 480x800 \
      -o "docs/images/three_grains_2d_${frame}.png"
  done
fi

if [ "$which" = 3d ] || [ "$which" = both ]; then
  "$lsdem" run apps/scenes/three_grains/three_grains_3d.toml --out "$root/three_grains_3d-out" --overwrite
  "$lsdem" plot "$root/three_grains_3d-out"
  # 80 frames over 0.045 s: 0 the stack as placed, 50 (0.028 s) just after
  # the bottom grain's first splits, last (0.045 s) the end.
  for frame in 0 50 last; do
    "$lsdem" render "$root/three_grains_3d-out" --frame "$frame" --view -60,20 --up z --size 600x780 \
      -o "docs/images/three_grains_3d_${frame}.png"
  done
fi
