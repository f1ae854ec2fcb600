#!/usr/bin/env bash
# The 2D jaw crusher of the paper (section 4, Table 1) at closed side settings
# of 100, 80 and 50 mm: runs apps/scenes/jaw_crusher/jaw_crusher_css*.toml with
# the built lsdem, draws each run's plots (lsdem plot) and one plot with the
# three product PSD curves, and prints a summary table per CSS: P50 and P80 of
# the product, throughput, mean power drawn by the swing jaw, breakages, fines
# and the mass balance.
#
# Usage: scripts/jaw_crusher.sh [OUTDIR] [CSS_MM ...]
#   OUTDIR  where the runs go (default: jaw_crusher-out); OUTDIR/cssNN per run
#   CSS_MM  which settings to run (default: 100 80 50)
# Environment: LSDEM (the lsdem executable, default build/apps/lsdem, built
# with scripts/build.sh when missing), THREADS (default: the scenes' 1),
# SKIP_RUN=1 (only post-process runs already in OUTDIR).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
out=${1:-jaw_crusher-out}
shift || true
settings=("$@")
[ ${#settings[@]} -gt 0 ] || settings=(100 80 50)
lsdem=${LSDEM:-$root/build/apps/lsdem}
if [ ! -x "$lsdem" ]; then
  echo "jaw_crusher.sh: $lsdem not found; building it (scripts/build.sh)" >&2
  bash scripts/build.sh
fi
mkdir -p "$out"

# Run the scenes (one after the other: each uses one thread).
for css in "${settings[@]}"; do
  scene=apps/scenes/jaw_crusher/jaw_crusher_css$css.toml
  [ -f "$scene" ] || { echo "jaw_crusher.sh: no scene $scene (settings: 100 80 50)" >&2; exit 2; }
  if [ "${SKIP_RUN:-0}" != 1 ]; then
    echo "== CSS $css mm: $scene -> $out/css$css" >&2
    args=(run "$scene" --out "$out/css$css" --overwrite)
    [ -n "${THREADS:-}" ] && args+=(--threads "$THREADS")
    "$lsdem" "${args[@]}"
  fi
done

# Per-run plots (energies, breakages, PSD of the particles in the crusher, ...).
have_gnuplot=0
command -v gnuplot >/dev/null 2>&1 && have_gnuplot=1
if [ $have_gnuplot = 1 ]; then
  for css in "${settings[@]}"; do "$lsdem" plot "$out/css$css" >/dev/null; done
else
  echo "jaw_crusher.sh: gnuplot is not installed; no PNG plots (the CSV files are in $out)" >&2
fi

# A number from summary.json: the first "key": value (keys used here are unique
# in the file, or the first occurrence is the one meant).
json() { grep -o "\"$2\": *[-0-9.eE+]*" "$1" | head -1 | sed 's/.*: *//'; }

# Sieve size (mm) at which P percent passes, interpolated linearly between the
# rows of a cumulative PSD (sieve_size_m, percent_passing, ...).
passing() {
  awk -F, -v p="$2" 'NR > 1 {
      if ($2 + 0 >= p) { if (NR == 2 || $2 == q) { printf "%.1f", 1000 * $1 } else { printf "%.1f", 1000 * (s + ($1 - s) * (p - q) / ($2 - q)) }; found = 1; exit }
      s = $1; q = $2 }
    END { if (!found) printf "nan" }' "$1"
}

# The summary table (also written to OUTDIR/crusher_summary.csv).
csv="$out/crusher_summary.csv"
echo "css_mm,product_particles,product_kg_per_m,P50_mm,P80_mm,throughput_t_per_h_per_m,mean_power_kW_per_m,boundary_work_power_kW_per_m,breakages,fines_kg_per_m,ejected_kg_per_m,in_crusher_kg_per_m,feed_kg_per_m,mass_balance_relative,steps,simulated_s,wall_s,particles_end" > "$csv"
for css in "${settings[@]}"; do
  d="$out/css$css"
  s="$d/summary.json"
  [ -f "$s" ] || { echo "jaw_crusher.sh: $s is missing (run without SKIP_RUN=1)" >&2; exit 1; }
  T=$(json "$s" simulated_time)
  # Product: the particles that left through the discharge under the jaws;
  # ejected: those thrown out of the mouth (removed.csv reasons).
  read -r n_product m_product m_fines m_ejected < <(awk -F, 'NR > 1 { if ($6 == "discharge") { n++; m += $3 } else if ($6 == "fines") f += $3; else if ($6 == "outflow") e += $3 }
                                                 END { printf "%d %.1f %.1f %.1f\n", n, m, f, e }' "$d/removed.csv")
  if [ -f "$d/product_psd.csv" ]; then
    p50=$(passing "$d/product_psd.csv" 50); p80=$(passing "$d/product_psd.csv" 80)
  else
    p50=nan; p80=nan
  fi
  # Power drawn by the swing jaw: the mean of history.csv's swing_jaw_power_W,
  # and the work all tools did on the particles over the run / time (the
  # other tools do not move, so it is the swing jaw's too).
  p_mean=$(awk -F, 'NR == 1 { for (i = 1; i <= NF; ++i) if ($i == "swing_jaw_power_W") c = i; next }
                    c { s += $c; n++ } END { printf "%.4g", n ? s / n / 1000 : 0 }' "$d/history.csv")
  work=$(json "$s" boundary_work)
  p_work=$(awk -v w="$work" -v t="$T" 'BEGIN { printf "%.4g", w / t / 1000 }')
  tph=$(awk -v m="$m_product" -v t="$T" 'BEGIN { printf "%.4g", m / t * 3.6 }')
  # The mass balance block: initial + fed = particles + removed (product and fines).
  mb() { grep -A6 '"mass_balance"' "$s" | grep -o "\"$1\": *[-0-9.eE+]*" | sed 's/.*: *//'; }
  m_in=$(awk -v a="$(mb initial)" -v b="$(mb fed)" 'BEGIN { printf "%.6g", a + b }')
  m_now=$(awk -v a="$(mb particles)" 'BEGIN { printf "%.6g", a }')
  rel=$(awk -v a="$(mb relative_error)" 'BEGIN { printf "%.2g", a }')
  echo "$css,$n_product,$m_product,$p50,$p80,$tph,$p_mean,$p_work,$(json "$s" breakages),$m_fines,$m_ejected,$m_now,$m_in,$rel,$(json "$s" steps),$(printf %.3f "$T"),$(printf %.0f "$(json "$s" wall_time)"),$(json "$s" particles)" >> "$csv"
done

# The table on stdout.
column -s, -t < "$csv" 2>/dev/null || cat "$csv"
echo "(per metre of jaw width; mass balance: (particles + removed) / (initial + fed) - 1, removed = product + ejected + fines)"

# One plot with the product PSD of every CSS.
if [ $have_gnuplot = 1 ]; then
  plot="$out/product_psd.png"
  cmd="set terminal pngcairo size 900,600 noenhanced; set output '$plot';"
  gnuplot -e "set terminal pngcairo" >/dev/null 2>&1 || cmd="set terminal png size 900,600; set output '$plot';"
  cmd="$cmd set title 'Jaw crusher product PSD (2D, per CSS)'; set xlabel 'sieve size (mm, eq. 21)'; set ylabel 'percent passing (by mass)';"
  cmd="$cmd set logscale x; set key left top; set grid; set datafile separator ',';"
  cmd="$cmd set xrange [1:300]; set yrange [0:100]; plot"
  sep=""
  for css in "${settings[@]}"; do
    f="$out/css$css/product_psd.csv"
    [ -f "$f" ] || continue
    cmd="$cmd$sep '$f' every ::1 using (\$1 > 0 ? 1000*\$1 : 1/0):2 with steps lw 2 title 'CSS $css mm'"
    sep=","
  done
  if [ -n "$sep" ]; then
    gnuplot -e "$cmd"
    echo "wrote $plot"
  fi
fi

# The README's pictures: the CSS 80 mm crusher at 4 s (frame 16 of 80 over
# 20 s) and the product PSD plot.
if [ $have_gnuplot = 1 ] && [ -d "$out/css80/frames" ]; then
  mkdir -p docs/images
  "$lsdem" render "$out/css80" --frame 16 --size 1200x900 -o docs/images/jaw_crusher_css80.png
  [ -f "$out/product_psd.png" ] && cp "$out/product_psd.png" docs/images/jaw_crusher_product_psd.png
fi
