#!/usr/bin/env bash
# Runs the 3D demolition scene (paper Fig. 6): rebuilds its STL assets, runs
# it, draws the plots of its CSV histories (demolition-out/plots/: fragment
# count, PSD, bucket forces) and renders frames before, during and after the
# two crushes into docs/images/demolition_*.png with `lsdem render` (needs
# gnuplot). Uses the build in build/ (scripts/build.sh).
# Usage: bash scripts/demolition.sh [OUTDIR]   (default demolition-out)
# Environment: LSDEM = the lsdem executable (default build/apps/lsdem, built
# when missing).
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-demolition-out}"
lsdem="${LSDEM:-./build/apps/lsdem}"
[ -x "$lsdem" ] || bash scripts/build.sh
python3 scripts/make_demolition_assets.py
mkdir -p docs/images
"$lsdem" run apps/scenes/demolition/demolition.toml --out "$out" --overwrite
"$lsdem" plot "$out"
# The bucket forces (history.csv columns <tool>_force_*_N: the force of the
# wall pieces on each bucket) against time: $out/plots/bucket_forces.png.
terminal=png
if [[ $(gnuplot -e 'set terminal' 2>&1) == *pngcairo* ]]; then terminal=pngcairo; fi
gnuplot <<GNUPLOT
set terminal $terminal size 900,560
set output '$out/plots/bucket_forces.png'
set datafile separator ','
set title 'Bucket forces: force of the wall pieces on each bucket'
set xlabel 'time (s)'
set ylabel 'force (kN)'
set grid
plot '$out/history.csv' using (column('time_s')):(column('bucket_a_force_y_N')/1000) with lines lw 2 title 'bucket_a, y (vertical)' noenhanced, \
     '' using (column('time_s')):(column('bucket_a_force_x_N')/1000) with lines title 'bucket_a, x' noenhanced, \
     '' using (column('time_s')):(column('bucket_b_force_y_N')/1000) with lines lw 2 title 'bucket_b, y (vertical)' noenhanced, \
     '' using (column('time_s')):(column('bucket_b_force_x_N')/1000) with lines title 'bucket_b, x' noenhanced
GNUPLOT
echo "wrote $out/plots/bucket_forces.png"
# 65 frames over 1.3 s, one every 0.02 s: 0 the wall as built, 15 (0.30 s)
# bucket_a biting, 36 (0.72 s) bucket_a lifted away, 55 (1.10 s) bucket_b
# biting, last (1.30 s) the end. The view looks at the wall's face (+z side)
# from a little to its right and above.
for frame in 0 15 36 55 last; do
  "$lsdem" render "$out" --frame "$frame" --up y --view 20,20 --size 1000x750 \
    -o "docs/images/demolition_${frame}.png"
done
