/// @file fuzz_mesh.cpp
/// @brief libFuzzer target: the input is a mesh file (STL, OBJ or PLY). It is
/// imported (readMesh, assimp in a child process), inspected (inspectMesh)
/// and, when it bounds a solid, turned into a level set (meshToLevelSet, CGAL)
/// on a grid of about 12 cells across its smallest side.
///
/// The format is chosen from the first bytes, as a user's file extension
/// would: "ply" -> .ply, "solid" -> .stl (ASCII), a line starting "v ", "f ",
/// "o ", "g " or "#" -> .obj, anything else -> .stl (binary). The input is
/// written to a folder of this process's own (made once under TMPDIR).
///
/// Invariants (a violation aborts):
///   - readMesh throws nothing but MeshError (a named, one-line refusal);
///   - an imported mesh is what readMesh promises: at least one face, every
///     vertex finite, every face's indices in range;
///   - inspectMesh never throws; meshToLevelSet throws nothing but MeshError,
///     and only when inspectMesh found a problem; its grid is finite.

#include "FuzzFolder.h"

#include "lsdem/geometry/MeshIO.h"
#include "lsdem/geometry/MeshToLevelSet.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

namespace {

using namespace lsdem;
namespace fs = std::filesystem;

[[noreturn]] void violation(const char* what, const std::string& detail = "") {
  std::fprintf(stderr, "fuzz_mesh: invariant violated: %s %s\n", what, detail.c_str());
  std::abort();
}

const char* extensionOf(std::string_view head) {
  if (head.rfind("ply", 0) == 0) return ".ply";
  if (head.rfind("solid", 0) == 0) return ".stl";
  for (const std::string_view obj : {"v ", "f ", "o ", "g ", "#"}) {
    if (head.rfind(obj, 0) == 0) return ".obj";
  }
  return ".stl";
}

void check(const geometry::TriangleMesh& mesh, const std::string& name) {
  if (mesh.faces.empty()) violation("readMesh returned no faces");
  for (const auto& v : mesh.vertices) {
    if (!v.allFinite()) violation("readMesh returned a non-finite vertex");
  }
  const long long n = static_cast<long long>(mesh.vertices.size());
  for (const auto& f : mesh.faces) {
    for (const int i : f) {
      if (i < 0 || i >= n) violation("readMesh returned a face index out of range", std::to_string(i));
    }
  }
  geometry::MeshReport report;
  try {
    report = geometry::inspectMesh(mesh);
  } catch (const std::exception& e) {
    violation("inspectMesh threw:", e.what());
  }
  if (!report.ok()) return;
  // About 12 cells across the smallest side of the bounding box.
  geometry::Vec<3> lo = mesh.vertices[0], hi = mesh.vertices[0];
  for (const auto& v : mesh.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  const double smallest = (hi - lo).minCoeff();
  const double spacing = smallest / 12.0;
  if (!(spacing > 0.0) || !std::isfinite(spacing) || (hi - lo).maxCoeff() / spacing > 200.0) return;
  try {
    const geometry::Grid<3> grid = geometry::meshToLevelSet(mesh, spacing, 2, name);
    for (const float v : grid.values()) {
      if (!std::isfinite(v)) violation("meshToLevelSet gave a non-finite value");
    }
  } catch (const geometry::MeshError& e) {
    violation("meshToLevelSet refused a mesh inspectMesh passed:", e.what());
  } catch (const std::exception& e) {
    violation("meshToLevelSet threw:", e.what());
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view head(reinterpret_cast<const char*>(data), std::min<std::size_t>(size, 8));
  const fs::path path = fuzz::scratchFolder("mesh") / (std::string("input") + extensionOf(head));
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
  }
  geometry::MeshImportLimits limits;
  limits.seconds = 20.0;
  try {
    const geometry::TriangleMesh mesh = geometry::readMesh(path.string(), 1.0, nullptr, limits);
    check(mesh, path.filename().string());
  } catch (const geometry::MeshError& e) {
    const std::string message = e.what();
    if (message.find('\n') != std::string::npos) violation("a multi-line mesh error:", message);
  } catch (const std::exception& e) {
    violation("readMesh threw something other than MeshError:", e.what());
  }
  fs::remove(path);
  return 0;
}
