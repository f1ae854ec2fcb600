#!/usr/bin/env bash
# End-to-end robustness of the lsdem command line (docs/reliability.md): bad
# scenes, broken meshes, damaged grain files and checkpoints, signals and
# resume, concurrent runs, a full disk. Each case runs the built lsdem as a
# user would and prints one row: case, expected, got, PASS/FAIL. Exit 1 when
# any case fails.
#
# Usage: scripts/robustness.sh [WORKDIR]
#   WORKDIR  scratch folder (default: a new mktemp -d folder, removed at the end)
# Environment: LSDEM (default build/apps/lsdem, built with scripts/build.sh
# when missing), MUTATIONS (random single-byte mutations of a scene, default 40).
set -uo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
lsdem=${LSDEM:-$root/build/apps/lsdem}
if [ ! -x "$lsdem" ]; then
  echo "robustness.sh: $lsdem not found; building it (scripts/build.sh)" >&2
  bash scripts/build.sh || exit 1
fi
mutations=${MUTATIONS:-40}
if [ $# -ge 1 ]; then
  work=$1
  mkdir -p "$work"
  keep=1
else
  work=$(mktemp -d /tmp/lsdem_robustness.XXXXXX)
  keep=0
fi
work=$(cd "$work" && pwd)
failures=0
cases=0

row() {  # case expected got
  local verdict=PASS
  [ "$2" == "$3" ] || { verdict=FAIL; failures=$((failures + 1)); }
  cases=$((cases + 1))
  printf '%-58s %-26s %-26s %s\n' "$1" "$2" "$3" "$verdict"
}

# Runs lsdem with a time bound; prints "exit N" and the number of output lines
# ("exit N, 1 line"), or "hang" / "signal N".
outcome() {
  local out rc lines
  out=$(timeout 60 "$lsdem" "$@" 2>&1)
  rc=$?
  if [ $rc -eq 124 ]; then echo "hang"; return; fi
  if [ $rc -gt 128 ] && [ $rc -ne 130 ] && [ $rc -ne 143 ]; then echo "signal $((rc - 128))"; return; fi
  lines=$(printf '%s' "$out" | grep -c '')
  echo "exit $rc, $lines line$([ "$lines" == 1 ] || echo s)"
}

# The files a run writes that must not depend on interruptions (summary.json
# holds wall-clock times; lsdem.log the progress lines).
fingerprint() {
  (cd "$1" && find . -type f ! -name summary.json ! -name 'lsdem.log' ! -name checkpoint.lsc ! -name lsdem.lock \
    -print0 | sort -z | xargs -0 sha256sum)
}

printf '%-58s %-26s %-26s %s\n' "case" "expected" "got" "verdict"

# ---------------------------------------------------------------- scenes --
scene=$root/apps/scenes/three_grains/three_grains_2d.toml
mkdir -p "$work/scenes"
# A case of the 2D three-grains scene with one change that must be refused.
refused_scene() {  # NAME SED-EXPRESSION DESCRIPTION
  local file=$work/scenes/$1.toml
  sed -e "$2" "$scene" > "$file"
  row "scene: $3" "exit 2, 1 line" "$(outcome run "$file" --out "$work/o_$1")"
}
refused_scene negative_density 's/^density = .*/density = -2650.0/' "negative density"
refused_scene tiny_duration 's/^duration = .*/duration = 1e-308/' "duration = 1e-308 (once hung)"
refused_scene tiny_checkpoint 's/^checkpoint_every = .*/checkpoint_every = 1e-308/' "checkpoint_every = 1e-308 (once hung)"
refused_scene huge_gravity 's/^gravity = .*/gravity = [0.0, -1e308]/' "gravity = -1e308 (once gave NaN rows)"
refused_scene comma_name 's/^name = "platen"/name = "pla,ten"/' "a comma in a plane's name"
refused_scene unknown_key 's/^\[output\]/[output]\nframs = 3/' "a misspelled key"

# Random single-byte mutations: every run ends with 0, 1 or 2 (never a
# signal or a hang); runs are cut to 3 steps.
bad=""
size=$(wc -c < "$scene")
RANDOM=7
for ((k = 0; k < mutations; k++)); do
  f=$work/scenes/mutant_$k.toml
  cp "$scene" "$f"
  offset=$(( (RANDOM * 32768 + RANDOM) % size ))
  printf "\\x$(printf %02x $(( RANDOM % 256 )))" | dd of="$f" bs=1 seek=$offset conv=notrunc status=none
  got=$(outcome run "$f" --out "$work/o_mutant" --steps 3 --overwrite --quiet)
  case "$got" in
    "exit 0,"* | "exit 1,"* | "exit 2,"*) ;;
    *) bad="$bad $k:$got" ;;
  esac
done
row "scene: $mutations random byte mutations" "no signal or hang" "$([ -z "$bad" ] && echo "no signal or hang" || echo "$bad")"

# ---------------------------------------------------------------- meshes --
mkdir -p "$work/meshes"
cat > "$work/meshes/nan.stl" <<'EOF'
solid nan
facet normal 0 0 1
outer loop
vertex 0 0 0
vertex 1 0 0
vertex nan 1 0
endloop
endfacet
endsolid nan
EOF
# A broken mesh that mesh2ls must refuse.
refused_mesh() {  # FILE DESCRIPTION
  row "mesh: $2" "exit 2, 1 line" "$(outcome mesh2ls "$work/meshes/$1" --spacing 0.1 -o "$work/meshes/$1.lsg")"
}
refused_mesh nan.stl "NaN vertex in an STL (once SIGFPE)"
ply_header() {  # FORMAT VERTICES FACES END
  printf 'ply\nformat %s 1.0\nelement vertex %d\nproperty float x\nproperty float y\nproperty float z\nelement face %d\nproperty list uchar int vertex_indices\n%s\n' "$@"
}
{ ply_header ascii 4 4 end_header; printf '0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 99\n'; } > "$work/meshes/index.ply"
refused_mesh index.ply "face index out of range in a PLY (once SIGSEGV)"
{ ply_header binary_little_endian 4 4 end_header; printf '\x00\x00\x00\x00\x00\x00'; } > "$work/meshes/truncated.ply"
refused_mesh truncated.ply "truncated binary PLY (once crashed)"
{ ply_header ascii 4 4 end_headr; printf '0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n'; } > "$work/meshes/header.ply"
refused_mesh header.ply "misspelled end_header in a PLY (once hung)"

# ---------------------------------------------------------- grain files --
grain=$work/meshes/cube.lsg
"$lsdem" mesh2ls examples/grains/cube.stl --spacing 0.002 --scale 0.001 --nodes-per-cell 1 --binary -o "$grain" >/dev/null 2>&1
cat > "$work/scenes/grain.toml" <<EOF
[simulation]
dimension = 3
duration = 1e-4

[contact]
kn = 1e4

[shapes.cube]
kind = "grain_file"
path = "$work/meshes/damaged.lsg"

[[particles]]
shape = "cube"
density = 2650.0
placement = "list"
positions = [[0.0, 0.0, 0.0]]
EOF
cp "$grain" "$work/meshes/damaged.lsg"
row "grain file: the intact binary file" "exit 0, 0 lines" "$(outcome run "$work/scenes/grain.toml" --out "$work/o_grain" --quiet)"
grain_size=$(wc -c < "$grain")
flips=0
for offset in $(seq 200 $(( (grain_size - 200) / 10 )) $((grain_size - 1)) | head -n 10); do
  cp "$grain" "$work/meshes/damaged.lsg"
  byte=$(od -An -tu1 -j "$offset" -N1 "$grain" | tr -d ' ')
  printf "\\x$(printf %02x $(( byte ^ 16 )))" | dd of="$work/meshes/damaged.lsg" bs=1 seek="$offset" conv=notrunc status=none
  got=$(outcome run "$work/scenes/grain.toml" --out "$work/o_grain" --overwrite --quiet)
  [ "$got" == "exit 2, 1 line" ] && flips=$((flips + 1))
done
row "grain file: 10 single-bit flips refused (checksum)" "10 refused" "$flips refused"

# ------------------------------------------------ signals, resume, checkpoints --
long=$work/scenes/long.toml
sed -e 's/^threads = .*/threads = 1/' "$scene" > "$long"
"$lsdem" run "$long" --out "$work/ref" --quiet >/dev/null 2>&1
ref=$(fingerprint "$work/ref")

# SIGTERM: exit 143 with a checkpoint, then --resume to the end.
"$lsdem" run "$long" --out "$work/term" --quiet >/dev/null 2>&1 &
pid=$!
while kill -0 $pid 2>/dev/null && [ ! -e "$work/term/frames/particles_000010.vtp" ]; do sleep 0.02; done
kill -TERM $pid 2>/dev/null
wait $pid
row "SIGTERM: stops with its checkpoint" "exit 143" "exit $?"
row "SIGTERM: --resume to the end" "exit 0, 0 lines" "$(outcome run --resume "$work/term" --quiet)"
row "SIGTERM: outputs equal the uninterrupted run" "identical" \
  "$([ "$(fingerprint "$work/term")" == "$ref" ] && echo identical || echo differ)"

# SIGKILL after a periodic checkpoint: --resume from it gives the same outputs.
"$lsdem" run "$long" --out "$work/kill" --quiet >/dev/null 2>&1 &
pid=$!
while kill -0 $pid 2>/dev/null && [ ! -e "$work/kill/checkpoint.lsc" ]; do sleep 0.01; done
sleep 0.3
kill -KILL $pid 2>/dev/null
wait $pid 2>/dev/null
row "SIGKILL after a periodic checkpoint: --resume" "exit 0, 0 lines" "$(outcome run --resume "$work/kill" --quiet)"
row "SIGKILL: outputs equal the uninterrupted run" "identical" \
  "$([ "$(fingerprint "$work/kill")" == "$ref" ] && echo identical || echo differ)"

# Damaged and foreign checkpoints.
cp -r "$work/ref" "$work/damaged"
size=$(wc -c < "$work/damaged/checkpoint.lsc")
printf '\x5a' | dd of="$work/damaged/checkpoint.lsc" bs=1 seek=$((size / 2)) conv=notrunc status=none
row "checkpoint: one byte changed, --resume refused" "exit 2, 1 line" "$(outcome run --resume "$work/damaged" --steps 1)"
cp "$grain" "$work/meshes/damaged.lsg"
"$lsdem" run "$work/scenes/grain.toml" --out "$work/foreign" --quiet >/dev/null 2>&1 || true
cp -r "$work/ref" "$work/mixed"
cp "$work/foreign/checkpoint.lsc" "$work/mixed/checkpoint.lsc"
row "checkpoint: another run's copied in, --resume refused" "exit 2, 1 line" "$(outcome run --resume "$work/mixed" --steps 1)"

# ------------------------------------------------------ output folders --
row "output folder: another run's outputs, no --overwrite" "exit 2, 1 line" "$(outcome run "$long" --out "$work/ref" --steps 1)"
"$lsdem" run "$long" --out "$work/busy" --quiet >/dev/null 2>&1 &
pid=$!
while kill -0 $pid 2>/dev/null && [ ! -e "$work/busy/lsdem.lock" ]; do sleep 0.01; done
row "output folder: a second run while the first runs" "exit 2, 1 line" "$(outcome run "$long" --out "$work/busy" --overwrite --steps 1)"
kill -TERM $pid 2>/dev/null
wait $pid 2>/dev/null

# A full disk: a 64 KiB file-size limit stops the run at its first big write
# (lsdem ignores SIGXFSZ itself, so the write fails instead of killing it).
got=$( (ulimit -f 64; timeout 60 "$lsdem" run "$long" --out "$work/full" --quiet 2>&1) )
rc=$?
named=$(printf '%s' "$got" | grep -c "$work/full" || true)
row "full disk (file-size limit): stops naming the file" "exit 1, names the file" \
  "exit $rc, $([ "$named" -ge 1 ] && echo "names the file" || echo "no file named")"

echo "$cases cases, $failures failed"
[ $keep -eq 1 ] || rm -rf "$work"
[ $failures -eq 0 ]
