/// @file fuzz_scene.cpp
/// @brief libFuzzer target: the input is a scene file (TOML). It is read,
/// checked and built the way `lsdem run` does (readScene, buildWorld) and,
/// when the world is small, stepped a few times.
///
/// The input is written as `scene.toml` to a folder of this process's own
/// (made once under TMPDIR) that also holds `cube.stl`, a closed unit cube, so
/// a scene's `mesh` shapes and relative paths have something to find.
///
/// Invariants (a violation aborts):
///   - reading and building throw nothing but io::InputError, and its
///     message is one line that starts with the scene's path (`lsdem run`
///     prints it as is and exits 2: every bad scene is a clean refusal);
///   - a scene that is accepted has a dimension of 2 or 3, a finite time step
///     setting and a positive, finite duration or step count;
///   - stepping a built world of at most 64 particles and 100,000 surface
///     nodes throws nothing but std::exception (a run that fails says why).
/// Time and memory are libFuzzer's to bound (-timeout, -rss_limit_mb): a
/// scene that takes longer than the timeout to read is a hang and reported.

#include "FuzzFolder.h"

#include "lsdem/io/InputError.h"
#include "lsdem/io/Scene.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>
#include <variant>

namespace {

using namespace lsdem;
namespace fs = std::filesystem;

[[noreturn]] void violation(const char* what, const std::string& detail = "") {
  std::fprintf(stderr, "fuzz_scene: invariant violated: %s %s\n", what, detail.c_str());
  std::abort();
}

// The target's folder (FuzzFolder.h), with cube.stl written into it once.
const fs::path& folder() {
  static const fs::path& dir = [] () -> const fs::path& {
    const fs::path& d = fuzz::scratchFolder("scene");
    std::ofstream stl(d / "cube.stl");
    stl << "solid cube\n";
    // The 12 outward triangles of the unit cube [0, 1]^3.
    const int faces[12][3][3] = {
        {{0, 0, 0}, {0, 1, 0}, {1, 1, 0}}, {{0, 0, 0}, {1, 1, 0}, {1, 0, 0}}, {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}},
        {{0, 0, 1}, {1, 1, 1}, {0, 1, 1}}, {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}}, {{0, 0, 0}, {1, 0, 1}, {0, 0, 1}},
        {{0, 1, 0}, {0, 1, 1}, {1, 1, 1}}, {{0, 1, 0}, {1, 1, 1}, {1, 1, 0}}, {{0, 0, 0}, {0, 0, 1}, {0, 1, 1}},
        {{0, 0, 0}, {0, 1, 1}, {0, 1, 0}}, {{1, 0, 0}, {1, 1, 0}, {1, 1, 1}}, {{1, 0, 0}, {1, 1, 1}, {1, 0, 1}}};
    for (const auto& f : faces) {
      stl << "facet normal 0 0 0\nouter loop\n";
      for (const auto& v : f) stl << "vertex " << v[0] << ' ' << v[1] << ' ' << v[2] << '\n';
      stl << "endloop\nendfacet\n";
    }
    stl << "endsolid cube\n";
    return d;
  }();
  return dir;
}

template <int D>
void check(const io::SceneDef<D>& scene) {
  if (!(scene.world.dt >= 0.0) || !std::isfinite(scene.world.dt)) violation("accepted a non-finite dt");
  const bool hasDuration = scene.duration > 0.0 && std::isfinite(scene.duration);
  if (!hasDuration && scene.steps == 0) violation("accepted a scene with neither a duration nor steps");

  io::SceneWorld<D> built = io::buildWorld(scene);
  dynamics::World<D>& world = *built.world;
  std::size_t nodes = 0;
  for (std::size_t i = 0; i < world.particles().size(); ++i) nodes += world.particles().shape[i]->nodes().size();
  if (world.particles().size() > 64 || nodes > 100000) return;
  try {
    world.run(5);
  } catch (const std::exception&) {
    // A run that fails stops with its reason (exit 1): allowed.
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const fs::path path = folder() / "scene.toml";
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
  }
  try {
    const io::AnySceneDef scene = io::readScene(path.string());
    std::visit([](const auto& s) { check(s); }, scene);
  } catch (const io::InputError& e) {
    const std::string message = e.what();
    if (message.find('\n') != std::string::npos) violation("a multi-line input error:", message);
    if (message.rfind(path.string(), 0) != 0) violation("an input error that does not name the scene:", message);
  } catch (const std::exception& e) {
    violation("an exception that is not an input error:", e.what());
  }
  return 0;
}
