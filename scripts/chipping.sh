#!/usr/bin/env bash
# Runs the chipping scenes (apps/scenes/chipping/: one angular grain between
# platens, and a small oedometer, each with chipping and without) and draws
# the trend of their mean circularity (the 2D sphericity, eq. 23) against the
# platen's travel into docs/images/chipping_circularity.png (needs gnuplot),
# plus `lsdem plot` of each run. Uses the build in build/ (scripts/build.sh).
# Usage: bash scripts/chipping.sh
# Environment: LSDEM = the lsdem executable (default build/apps/lsdem, built
# when missing); LSDEM_OUT = folder for the output folders (default: the
# repository root).
set -euo pipefail
cd "$(dirname "$0")/.."
lsdem="${LSDEM:-./build/apps/lsdem}"
[ -x "$lsdem" ] || bash scripts/build.sh
root="${LSDEM_OUT:-.}"
mkdir -p docs/images "$root"

for scene in single_grain_2d single_grain_2d_no_chipping oedometer_small_2d oedometer_small_2d_no_chipping; do
  "$lsdem" run "apps/scenes/chipping/$scene.toml" --out "$root/$scene-out" --overwrite --threads 1 -q
  "$lsdem" plot "$root/$scene-out" > /dev/null
  # Mean circularity against the platen's travel (mm): 20 mm/s for the single
  # grain, 50 mm/s for the oedometer; and the chips and splits of each run.
  speed=20; case "$scene" in oedometer*) speed=50 ;; esac
  awk -F, -v v="$speed" 'NR > 1 { printf "%.4f %s %s\n", $1 * v, $4, $3 }' "$root/$scene-out/shape_stats.csv" \
    > "$root/$scene-out/circularity.dat"
  echo "$scene: $(awk -F, 'NR > 1 { n[$19]++ } END { printf "%d chips, %d splits", n["chip"], n["split"] }' \
    "$root/$scene-out/breakage_log.csv")"
done

gnuplot <<GP
set terminal pngcairo size 1100,450 font ",11"
set output "docs/images/chipping_circularity.png"
set multiplot layout 1,2 title "Mean circularity of the grains (pieces at least 10 / 6 cells across): chipping on and off"
set xlabel "platen travel (mm)"
set ylabel "mean circularity 4 pi A / P^2"
set key bottom left
set grid
set title "one pentagon between platens"
plot "$root/single_grain_2d-out/circularity.dat" using 1:2 with linespoints lw 2 pt 7 ps 0.6 title "chipping + splitting", \
     "$root/single_grain_2d_no_chipping-out/circularity.dat" using 1:2 with linespoints lw 2 pt 5 ps 0.6 title "splitting only"
set title "small oedometer, 24 angular grains"
plot "$root/oedometer_small_2d-out/circularity.dat" using 1:2 with linespoints lw 2 pt 7 ps 0.6 title "chipping + splitting", \
     "$root/oedometer_small_2d_no_chipping-out/circularity.dat" using 1:2 with linespoints lw 2 pt 5 ps 0.6 title "splitting only"
unset multiplot
GP
echo "wrote docs/images/chipping_circularity.png"
