#!/usr/bin/env bash
# The oedometer of the paper (section 5, Table 2): runs the 2D scene (von
# Mises by default; the Tresca and maximum principal stress variants and the
# 3D variant on request) with the built lsdem, and draws, per run: vertical
# stress against strain, void ratio against log stress, the PSD at a few
# strains, mean circularity and aspect ratio against strain, and their
# histograms (paper Fig. 11-15). Prints a summary per run: initial void ratio,
# breakage onset and yield stress, stress at the end, breakages, fines (% of
# the specimen's mass), mass balance, steps, particles and wall time.
#
# Usage: scripts/oedometer.sh [OUTDIR] [CASE ...]
#   OUTDIR  where the runs go (default: oedometer-out); OUTDIR/CASE per run
#   CASE    von_mises (default), tresca, max_principal, 3d
# Environment: LSDEM (the lsdem executable, default build/apps/lsdem, built
# with scripts/build.sh when missing), THREADS (default: the scenes'),
# SKIP_RUN=1 (only post-process runs already in OUTDIR).
#
# The test starts when friction starts to act (the scene's [contact]
# friction_from): the specimen is generated and densified frictionless, then
# loaded with friction. Strain, the initial void ratio and the snapshots count
# from there.
# Besides the paper's figures the summary gives the strain and stress at which
# the target void ratio (0.18 in 2D, eq. 22; 0.6 in 3D) is reached and a quasi-static check: the
# largest kinetic / elastic energy ratio once the stress exceeds 0.5 MPa.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
out=${1:-oedometer-out}
shift || true
cases=("$@")
[ ${#cases[@]} -gt 0 ] || cases=(von_mises)
lsdem=${LSDEM:-$root/build/apps/lsdem}
if [ ! -x "$lsdem" ]; then
  echo "oedometer.sh: $lsdem not found; building it (scripts/build.sh)" >&2
  bash scripts/build.sh
fi
mkdir -p "$out"

scene_of() {
  case "$1" in
    von_mises) echo apps/scenes/oedometer/oedometer_2d.toml ;;
    tresca) echo apps/scenes/oedometer/oedometer_2d_tresca.toml ;;
    max_principal) echo apps/scenes/oedometer/oedometer_2d_max_principal.toml ;;
    3d) echo apps/scenes/oedometer/oedometer_3d.toml ;;
    *) echo "oedometer.sh: unknown case '$1' (von_mises, tresca, max_principal, 3d)" >&2; exit 2 ;;
  esac
}
# The test's start, s: the scene's [contact] friction_from.
test_start_of() {
  local t
  t=$(sed -n 's/^friction_from *= *\([0-9.eE+-]*\).*/\1/p' "$1" | head -1)
  [ -n "$t" ] || { echo "oedometer.sh: $1 has no [contact] friction_from (the test's start)" >&2; exit 2; }
  echo "$t"
}
target_void_ratio_of() { case "$1" in 3d) echo 0.6 ;; *) echo 0.18 ;; esac; }

have_gnuplot=0
command -v gnuplot >/dev/null 2>&1 && have_gnuplot=1
terminal="set terminal pngcairo size 900,600 noenhanced"
if [ $have_gnuplot = 1 ] && ! gnuplot -e "set terminal pngcairo" >/dev/null 2>&1; then terminal="set terminal png size 900,600"; fi

json() { grep -o "\"$2\": *[-0-9.eE+]*" "$1" | head -1 | sed 's/.*: *//'; }

summary="$out/oedometer_summary.csv"
echo "case,initial_void_ratio,start_time_s,start_height_mm,start_stress_MPa,target_void_ratio_strain,target_void_ratio_stress_MPa,max_kinetic_to_elastic,breakage_onset_stress_MPa,breakage_onset_strain,yield_stress_MPa,final_strain,final_stress_MPa,final_void_ratio,breakages,particles_end,fines_percent_of_specimen,mass_balance_relative,steps,simulated_s,wall_s" > "$summary"

for c in "${cases[@]}"; do
  scene=$(scene_of "$c")
  d="$out/$c"
  if [ "${SKIP_RUN:-0}" != 1 ]; then
    echo "== oedometer $c: $scene -> $d" >&2
    args=(run "$scene" --out "$d" --overwrite)
    [ -n "${THREADS:-}" ] && args+=(--threads "$THREADS")
    "$lsdem" "${args[@]}"
  fi
  [ -f "$d/summary.json" ] || { echo "oedometer.sh: $d/summary.json is missing (run without SKIP_RUN=1)" >&2; exit 1; }
  p="$d/oedometer"
  mkdir -p "$p"
  t_load=$(test_start_of "$scene")

  # 1. The test curve: strain from the start height (history.csv), stress in MPa.
  awk -F, -v tl="$t_load" -v dir="$p" '
    NR == 1 { for (i = 1; i <= NF; ++i) col[$i] = i; next }
    {
      n++; T[n] = $col["time_s"]; H[n] = $col["height_m"]; S[n] = $col["stress_Pa"]; E[n] = $col["void_ratio"]
      B[n] = $col["breakages"]; P[n] = $col["particles"]; K[n] = $col["kinetic_J"]; U[n] = $col["elastic_J"]
    }
    END {
      # the test starts at the first row at or after friction_from
      for (k = 1; k <= n && !start; ++k) if (T[k] + 1e-12 >= tl) start = k
      if (!start) start = n
      h0 = H[start]
      print "time_s,strain,stress_MPa,void_ratio,breakages,particles,kinetic_to_elastic" > (dir "/curve.csv")
      for (k = start; k <= n; ++k) printf "%.9g,%.6g,%.6g,%.6g,%d,%d,%.3g\n", T[k], (h0 - H[k]) / h0, S[k] / 1e6, E[k], B[k], P[k], (U[k] > 0 ? K[k] / U[k] : 0) > (dir "/curve.csv")
      printf "%.9g %.9g %.6g %.4g\n", T[start], h0, E[start], S[start] / 1e6 > (dir "/start.txt")
      for (k = 1; k <= n; ++k) printf "%.9g %.6g\n", T[k], (h0 - H[k]) / h0 > (dir "/strain_of_time.txt")
    }' "$d/history.csv"
  read -r t0 h0 e0 s0 < "$p/start.txt"
  # The strain and stress at the target void ratio, and the quasi-static check.
  read -r target_eps target_s ke_max < <(awk -F, -v et="$(target_void_ratio_of "$c")" '
    NR == 1 { next }
    { if (!hit && $4 <= et) { hit = 1; eps = $2; s = $3 }
      if ($3 > 0.5 && $7 > r) r = $7 }
    END { if (hit) printf "%.4f %.4g %.3g\n", eps, s, r; else printf "nan nan %.3g\n", r }' "$p/curve.csv")

  # 2. Breakage onset (first breakage after the start) and a yield stress: the
  # stress at which the void ratio has fallen 0.01 below the line through the
  # curve at the onset with the slope de/dlog10(stress) before it (the knee).
  read -r onset_s onset_eps yield_s < <(awk -F, '
    NR == 1 { next }
    { n++; eps[n] = $2; s[n] = $3; e[n] = $4; b[n] = $5 }
    END {
      for (k = 1; k <= n; ++k) if (b[k] > b[1]) { o = k; break }
      if (!o) { print "nan nan nan"; exit }
      # pre-onset slope in e - log10(s) from the rows with s > 5% of the onset stress
      for (k = 1; k < o; ++k) if (s[k] > 0.05 * s[o]) { a = k; break }
      slope = (a && a < o && s[a] > 0 && s[o] > s[a]) ? (e[o] - e[a]) / (log(s[o] / s[a]) / log(10)) : 0
      y = "nan"
      for (k = o; k <= n; ++k) {
        if (s[k] <= 0) continue
        line = e[o] + slope * log(s[k] / s[o]) / log(10)
        if (e[k] < line - 0.01) { y = sprintf("%.4g", s[k]); break }
      }
      printf "%.4g %.4g %s\n", s[o], eps[o], y
    }' "$p/curve.csv")

  # 3. Strain of every distribution snapshot (psd.csv, shape_stats.csv, shape_histograms.csv).
  strain_at() { awk -v t="$1" 'function abs(x) { return x < 0 ? -x : x }
                               { if (!found || abs($1 - t) < best) { best = abs($1 - t); v = $2; found = 1 } } END { printf "%.4f", v }' "$p/strain_of_time.txt"; }
  times=$(awk -F, 'NR > 1 && !seen[$1]++ { print $1 }' "$d/psd.csv")
  : > "$p/snapshots.txt"
  for t in $times; do
    awk -v t="$t" -v tl="$t_load" 'BEGIN { exit !(t + 1e-12 >= tl) }' || continue
    echo "$t $(strain_at "$t")" >> "$p/snapshots.txt"
  done
  # Mean circularity and aspect ratio against the test's strain.
  echo "strain,mean_circularity,mean_aspect_ratio,particles,shape_particles" > "$p/shape_stats.csv"
  while read -r t eps; do
    awk -F, -v t="$t" -v eps="$eps" 'NR > 1 && $1 == t { printf "%s,%s,%s,%s,%s\n", eps, $4, $5, $3, $7 }' "$d/shape_stats.csv" >> "$p/shape_stats.csv"
  done < "$p/snapshots.txt"

  # Final state and run figures.
  s="$d/summary.json"
  mb() { grep -A6 '"mass_balance"' "$s" | grep -o "\"$1\": *[-0-9.eE+]*" | sed 's/.*: *//'; }
  m_spec=$(mb initial)
  fines=$(awk -F, 'NR > 1 && $6 == "fines" { m += $3 } END { printf "%.6g", m + 0 }' "$d/removed.csv")
  fines_pct=$(awk -v f="$fines" -v m="$m_spec" 'BEGIN { printf "%.3g", 100 * f / m }')
  read -r eps_end s_end e_end < <(tail -1 "$p/curve.csv" | awk -F, '{ printf "%.4f %.4g %.4f\n", $2, $3, $4 }')
  rel=$(awk -v a="$(mb relative_error)" 'BEGIN { printf "%.2g", a }')
  echo "$c,$(printf %.4f "$e0"),$(printf %.4g "$t0"),$(awk -v h="$h0" 'BEGIN { printf "%.4f", 1000 * h }'),$s0,$target_eps,$target_s,$ke_max,$onset_s,$onset_eps,$yield_s,$eps_end,$s_end,$e_end,$(json "$s" breakages),$(json "$s" particles),$fines_pct,$rel,$(json "$s" steps),$(printf %.4f "$(json "$s" simulated_time)"),$(printf %.0f "$(json "$s" wall_time)")" >> "$summary"

  [ $have_gnuplot = 1 ] || continue
  "$lsdem" plot "$d" >/dev/null
  # The last frame's outlines, coloured by generation (fragments stand out).
  "$lsdem" render "$d" -o "$p/final.png" --color generation >/dev/null || echo "oedometer.sh: lsdem render failed for $d" >&2
  # 4. The plots.
  gnuplot <<GP
$terminal
set datafile separator ','
set grid
set key left top
set output '$p/stress_strain.png'
set title 'Oedometer ($c): vertical stress against strain (Fig. 11)'
set xlabel 'vertical strain'; set ylabel 'vertical stress (MPa)'
plot '$p/curve.csv' every ::1 using 2:3 with lines lw 2 title 'stress', \
     '' every ::1 using 2:(\$5 > 0 ? \$3 : 1/0) with dots notitle
set output '$p/void_ratio.png'
set title 'Oedometer ($c): void ratio against log stress (Fig. 11)'
set xlabel 'vertical stress (MPa)'; set ylabel 'void ratio (2D)'
set logscale x
set key right top
plot '$p/curve.csv' every ::1 using (\$3 > 0.01 ? \$3 : 1/0):4 with lines lw 2 title 'void ratio'
unset logscale x
set output '$p/shape_stats.png'
set title 'Oedometer ($c): mean circularity and aspect ratio against strain (Fig. 14)'
set xlabel 'vertical strain'; set ylabel 'mean value'
set key right top
plot '$p/shape_stats.csv' every ::1 using 1:2 with linespoints lw 2 title 'circularity (eq. 23)', \
     '' every ::1 using 1:3 with linespoints lw 2 title 'aspect ratio'
GP
  # PSD and histograms at the snapshots (at most 6: evenly through the test).
  mapfile -t snaps < "$p/snapshots.txt"
  nsnap=${#snaps[@]}
  pick=()
  if [ "$nsnap" -le 6 ]; then pick=("${snaps[@]}"); else
    for k in 0 1 2 3 4 5; do pick+=("${snaps[$(( k * (nsnap - 1) / 5 ))]}"); done
  fi
  psd_plot="plot"; circ_plot="plot"; ar_plot="plot"; sep=""
  for entry in "${pick[@]}"; do
    read -r t eps <<< "$entry"
    pct=$(awk -v e="$eps" 'BEGIN { printf "%.1f", 100 * e }')
    awk -F, -v t="$t" 'NR > 1 && $1 == t { printf "%.6g %s\n", 1000 * $2, $3 }' "$d/psd.csv" > "$p/psd_$pct.dat"
    awk -F, -v t="$t" 'NR > 1 && $1 == t && $3 == "circularity" { printf "%s %s\n", ($4 + $5) / 2, $6 }' "$d/shape_histograms.csv" > "$p/hist_circularity_$pct.dat"
    awk -F, -v t="$t" 'NR > 1 && $1 == t && $3 == "aspect_ratio" { printf "%s %s\n", ($4 + $5) / 2, $6 }' "$d/shape_histograms.csv" > "$p/hist_aspect_ratio_$pct.dat"
    psd_plot="$psd_plot$sep '$p/psd_$pct.dat' using 1:2 with steps lw 2 title 'strain $pct%'"
    circ_plot="$circ_plot$sep '$p/hist_circularity_$pct.dat' using 1:2 with linespoints lw 2 title 'strain $pct%'"
    ar_plot="$ar_plot$sep '$p/hist_aspect_ratio_$pct.dat' using 1:2 with linespoints lw 2 title 'strain $pct%'"
    sep=","
  done
  if [ -n "$sep" ]; then
    gnuplot <<GP
$terminal
set grid
set key left top
set output '$p/psd.png'
set title 'Oedometer ($c): particle size distribution at several strains (Fig. 12-13)'
set xlabel 'sieve size (mm, eq. 21)'; set ylabel 'percent passing (by mass)'
set logscale x; set yrange [0:100]
$psd_plot
unset logscale x; set autoscale y
set output '$p/circularity_histograms.png'
set title 'Oedometer ($c): circularity histograms (Fig. 15; bins of 0.1)'
set xlabel 'circularity (eq. 23)'; set ylabel 'particles'
set xrange [0:1]
$circ_plot
set output '$p/aspect_ratio_histograms.png'
set title 'Oedometer ($c): aspect ratio histograms (Fig. 15; bins of 0.1)'
set xlabel 'aspect ratio'
$ar_plot
GP
  fi
  echo "wrote $p/{stress_strain,void_ratio,psd,shape_stats,circularity_histograms,aspect_ratio_histograms,final}.png" >&2
done

column -s, -t < "$summary" 2>/dev/null || cat "$summary"
echo "(stresses in MPa; strain from the start height; fines: mass removed as fines / specimen mass x 100)"
