#!/usr/bin/env bash
# Installs the built lsdem (build/) into a scratch prefix and builds a small
# program against it twice, with find_package(lsdem) and with pkg-config, and
# runs both (tests/package/); builds it a third time with lsdem's source tree
# as a subproject (add_subdirectory) and checks that lsdem leaves the parent
# project's build type, cache and flags alone; when the build has the Python module, imports
# the installed module from the prefix and runs a short scene with it. Run
# after scripts/build.sh (LSDEM_BUILD_DIR: another build folder than build/).
set -euo pipefail
cd "$(dirname "$0")/.."
build=${LSDEM_BUILD_DIR:-build}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
prefix="$work/prefix"
cmake --install "$build" --prefix "$prefix" >/dev/null
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

# As a subproject (add_subdirectory of this source tree; FetchContent does the
# same): tests/package/subproject/ fails to configure when lsdem sets the
# parent's build type or a cache variable it does not own. Configured first
# without a build type, which must stay empty, and its program's compile
# command must carry C++20 (from lsdem's targets) but none of lsdem's warning
# flags; then built in Release and run (ccache, when installed, has lsdem's
# objects from the main build).
sub="$work/subproject-build"
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
cmake -S tests/package/subproject -B "$sub" -G Ninja -DLSDEM_SOURCE_DIR="$PWD" \
  -DCMAKE_EXPORT_COMPILE_COMMANDS=ON "${launcher[@]}" >"$work/subproject.log" 2>&1 ||
  { cat "$work/subproject.log" >&2; echo "check_package: lsdem as a subproject failed to configure" >&2; exit 1; }
grep -qx 'CMAKE_BUILD_TYPE:STRING=' "$sub/CMakeCache.txt" ||
  { echo "check_package: lsdem as a subproject set the build type: $(grep '^CMAKE_BUILD_TYPE:' "$sub/CMakeCache.txt")" >&2; exit 1; }
python3 - "$sub/compile_commands.json" <<'PY'
import json, sys
commands = [c["command"] for c in json.load(open(sys.argv[1])) if c["file"].endswith("consumer.cpp")]
assert len(commands) == 1, "check_package: no compile command for the subproject's consumer.cpp"
flags = commands[0].split()
leaked = [f for f in flags if f in ("-Wall", "-Wextra", "-Wpedantic", "-Werror")]
assert not leaked, "check_package: lsdem's warning flags reached the parent's program: %s" % leaked
assert any(f in ("-std=c++20", "-std=gnu++20") for f in flags), \
    "check_package: linking lsdem did not bring C++20: %s" % commands[0]
PY
cmake -S tests/package/subproject -B "$sub" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$sub" --target consumer >/dev/null
"$sub/consumer"
echo "check_package: a subproject consumer (add_subdirectory) built and ran; lsdem left its build type, cache and flags alone"

# The Python module (docs/python.md), when the build has it: imported from the
# prefix alone (run from an empty folder), one short scene run.
if grep -q '^LSDEM_PYTHON:BOOL=ON' "$build/CMakeCache.txt"; then
  pydir=$(sed -n 's/^LSDEM_PYTHON_INSTALL_DIR:STRING=//p' "$build/CMakeCache.txt")
  python=$(sed -n 's/^_Python3_EXECUTABLE:INTERNAL=//p' "$build/CMakeCache.txt")
  compgen -G "$prefix/$pydir/lsdem.*.so" >/dev/null || { echo "check_package: Python module not installed in $pydir" >&2; exit 1; }
  mkdir "$work/py" && cd "$work/py"
  PYTHONPATH="$prefix/$pydir" "${python:-/usr/bin/python3}" - "$prefix" <<'PY'
import json, pathlib, sys
import lsdem
prefix = pathlib.Path(sys.argv[1]).resolve()
assert pathlib.Path(lsdem.__file__).resolve().is_relative_to(prefix), lsdem.__file__
scene = prefix / "share" / "lsdem" / "examples" / "three_grains" / "three_grains_2d.toml"
result = lsdem.run(scene, out="out", steps=50, threads=1)
summary = json.loads(pathlib.Path("out/summary.json").read_text())
assert result["steps"] == summary["steps"] == 50 and summary["particles"] == 3, summary
sim = lsdem.Simulation(scene, threads=1)
sim.step(50)
assert (sim.positions == lsdem.read_vtp(pathlib.Path("out") / lsdem.read_pvd("out/particles.pvd")[-1][1])["points"][:, :2]).all()
print(f"check_package: Python module {lsdem.__version__} imported from {lsdem.__file__} and ran {result['steps']} steps")
PY
fi
