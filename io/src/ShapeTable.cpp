#include "ShapeTable.h"

#include "TomlReader.h"

#include <filesystem>
#include <sstream>

namespace lsdem::io::detail {
namespace {

using geometry::ShapeDef;
using geometry::ShapeKind;
using geometry::Vec;

// The kinds a file may name, per dimension.
std::optional<ShapeKind> kindFromName(const std::string& name, int dimension) {
  const bool two = dimension == 2;
  if (name == (two ? "circle" : "sphere")) return ShapeKind::Sphere;
  if (name == (two ? "rectangle" : "box") || (two && name == "box")) return ShapeKind::Box;
  if (name == (two ? "ellipse" : "ellipsoid")) return ShapeKind::Ellipsoid;
  if (name == (two ? "superellipse" : "superellipsoid")) return ShapeKind::Superellipsoid;
  if (name == "random_grain") return ShapeKind::RandomGrain;
  if (two && name == "polygon") return ShapeKind::Polygon;
  if (!two && name == "mesh") return ShapeKind::Mesh;
  return std::nullopt;
}

std::string shortNumber(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

template <int D>
Vec<D> positiveVector(TomlReader& r, const std::string& key) {
  const std::vector<double> v = r.numbers(key, D);
  Vec<D> out;
  for (int a = 0; a < D; ++a) {
    if (!(v[a] > 0.0)) r.fail(key, "every component must be positive");
    out[a] = v[a];
  }
  return out;
}

template <int D>
ShapeDecl readOfDimension(TomlReader& r, const std::string& file, int line, const std::string& path, bool inScene) {
  ShapeDef<D> def;
  const std::string kindName = r.string("kind");
  const std::optional<ShapeKind> kind = kindFromName(kindName, D);
  if (!kind) {
    r.fail("kind", "unknown " + std::to_string(D) + "D kind '" + kindName + "' (" +
                       (D == 2 ? "circle, ellipse, rectangle or box, superellipse, polygon, random_grain"
                               : "sphere, ellipsoid, box, superellipsoid, random_grain, mesh") +
                       (inScene ? ", grain_file, grain_folder" : "") + ")");
  }
  def.kind = *kind;

  // Dimensions of the kind.
  switch (def.kind) {
    case ShapeKind::Sphere: def.radius = r.positive("radius"); break;
    case ShapeKind::Ellipsoid: def.semiAxes = positiveVector<D>(r, "semi_axes"); break;
    case ShapeKind::Box:
      def.halfExtents = positiveVector<D>(r, "half_extents");
      def.rounding = r.inRange("rounding", 0.0, def.halfExtents.minCoeff(), 0.0);
      break;
    case ShapeKind::Superellipsoid: {
      def.semiAxes = positiveVector<D>(r, "semi_axes");
      def.exponents = r.numbers("exponents", D == 2 ? 1 : 2);
      for (double e : def.exponents) {
        if (!(e > 0.0)) r.fail("exponents", "exponents must be positive");
      }
      break;
    }
    case ShapeKind::Polygon: {
      if constexpr (D == 2) {
        for (const std::vector<double>& row : r.numberRows("vertices", 2)) def.vertices.emplace_back(row[0], row[1]);
        if (def.vertices.size() < 3) r.fail("vertices", "a polygon needs at least 3 vertices");
      }
      break;
    }
    case ShapeKind::RandomGrain:
      def.grain.equivalentDiameter = r.positive("equivalent_diameter");
      def.grain.elongation = r.inRange("elongation", 1.0, 10.0, 1.0);
      def.grain.roughness = r.inRange("roughness", 0.0, 0.5, 0.1);
      {
        const std::int64_t seed = r.integer("seed", 1);
        if (seed < 0) r.fail("seed", "must be >= 0");
        def.grain.seed = std::uint64_t(seed);
      }
      break;
    case ShapeKind::Mesh: {
      std::filesystem::path mesh = r.string("file");
      if (mesh.is_relative()) mesh = std::filesystem::path(file).parent_path() / mesh;
      def.meshFile = mesh.string();
      def.meshScale = r.positive("scale", 1.0);
      break;
    }
  }

  // Resolution and nodes.
  if (r.has("spacing") == r.has("cells_across")) {
    r.fail(r.has("spacing") ? "cells_across" : "", "give exactly one of 'spacing' (metres) and 'cells_across'");
  }
  def.spacing = r.has("spacing") ? r.positive("spacing") : 0.0;
  def.cellsAcross = r.has("cells_across") ? r.inRange("cells_across", geometry::kMinCellsAcross, geometry::kMaxCellsAcross, 0.0) : 0.0;
  // A spacing must resolve the shape like cells_across would: 2 to 1e4 cells
  // across its smallest dimension (a mesh is checked when it is read).
  if (def.spacing > 0.0 && def.kind != ShapeKind::Mesh) {
    const double cells = geometry::smallestDimension<D>(def) / def.spacing;
    if (!(cells >= geometry::kMinCellsAcross && cells <= geometry::kMaxCellsAcross)) {
      r.fail("spacing", "gives " + shortNumber(cells) + " cells across the shape's smallest dimension (" +
                            shortNumber(geometry::smallestDimension<D>(def)) + "); it must give 2 to 1e4");
    }
  }
  def.options.nodesPerCell = r.positive("node_density", 2.0);
  // Nodes on the exact surface (default) or on the grid's interpolated one.
  const std::string nodesOn = r.string("nodes_on", "exact_surface");
  if (nodesOn == "exact_surface") {
    def.exactNodes = true;
  } else if (nodesOn == "grid") {
    def.exactNodes = false;
  } else {
    r.fail("nodes_on", "must be \"exact_surface\" or \"grid\", got \"" + nodesOn + "\"");
  }
  const std::string method = r.string("mass_method", "extrapolated");
  if (method == "extrapolated") {
    def.options.massMethod = geometry::MassMethod::Extrapolated;
  } else if (method == "paper") {
    def.options.massMethod = geometry::MassMethod::Paper;
  } else {
    r.fail("mass_method", "must be \"extrapolated\" or \"paper\", got \"" + method + "\"");
  }
  r.finish();
  const std::string resolution = r.has("spacing") ? "spacing" : "cells_across";
  return ShapeDecl{def, file, line, path, r.lineOf(resolution), r.pathOf(resolution), r.keyLines()};
}

}  // namespace

ShapeDecl readShapeTable(const toml::table& table, const std::string& file, const std::string& path, int sceneDimension) {
  TomlReader r(table, file, path);
  const int line = int(table.source().begin.line);
  const std::int64_t dimension = sceneDimension == 0 ? r.integer("dimension") : r.integer("dimension", sceneDimension);
  if (sceneDimension != 0 && dimension != sceneDimension) {
    r.fail("dimension", "is " + std::to_string(dimension) + " in a " + std::to_string(sceneDimension) + "D scene");
  }
  // (A scene's shapes may also be grain files, which the scene reader takes first.)
  if (dimension == 2) return readOfDimension<2>(r, file, line, path, sceneDimension != 0);
  if (dimension == 3) return readOfDimension<3>(r, file, line, path, sceneDimension != 0);
  r.fail("dimension", "must be 2 or 3, got " + std::to_string(dimension));
}

}  // namespace lsdem::io::detail
