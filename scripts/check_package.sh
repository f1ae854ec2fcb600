#!/usr/bin/env bash
# Installs the built lsdem (build/) into a scratch prefix and builds a small
# program against it twice, with find_package(lsdem) and with pkg-config, and
# runs both (tests/package/). Run after scripts/build.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
prefix="$work/prefix"
cmake --install build --prefix "$prefix" >/dev/null
for f in bin/lsdem include/lsdem/dynamics/World.h; do
  [[ -e "$prefix/$f" ]] || { echo "check_package: $f not installed" >&2; exit 1; }
done
"$prefix/bin/lsdem" --version >/dev/null

# find_package(lsdem)
cmake -S tests/package -B "$work/cmake-build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$prefix" >/dev/null
cmake --build "$work/cmake-build" >/dev/null
"$work/cmake-build/consumer"

# pkg-config (static libraries: --static lists what they use inside)
pcdir=$(dirname "$(find "$prefix" -name lsdem.pc | head -n 1)")
read -r -a flags <<<"$(PKG_CONFIG_PATH="$pcdir" pkg-config --static --cflags --libs lsdem)"
g++ -O2 tests/package/consumer.cpp -o "$work/consumer-pc" "${flags[@]}"
"$work/consumer-pc"
echo "check_package: find_package and pkg-config consumers built and ran"
