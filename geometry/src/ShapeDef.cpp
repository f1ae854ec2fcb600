#include "lsdem/geometry/ShapeDef.h"

#include "lsdem/geometry/MeshIO.h"
#include "lsdem/geometry/MeshToLevelSet.h"
#include "lsdem/geometry/Primitives.h"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

namespace lsdem::geometry {

template <int D>
const char* shapeKindName(ShapeKind kind) {
  switch (kind) {
    case ShapeKind::Sphere: return D == 2 ? "circle" : "sphere";
    case ShapeKind::Box: return D == 2 ? "rectangle" : "box";
    case ShapeKind::Ellipsoid: return D == 2 ? "ellipse" : "ellipsoid";
    case ShapeKind::Superellipsoid: return D == 2 ? "superellipse" : "superellipsoid";
    case ShapeKind::Polygon: return "polygon";
    case ShapeKind::RandomGrain: return "random_grain";
    case ShapeKind::Mesh: return "mesh";
  }
  return "unknown";
}

template <int D>
double smallestDimension(const ShapeDef<D>& def) {
  switch (def.kind) {
    case ShapeKind::Sphere: return 2.0 * def.radius;
    case ShapeKind::Box: return 2.0 * def.halfExtents.minCoeff();
    case ShapeKind::Ellipsoid:
    case ShapeKind::Superellipsoid: return 2.0 * def.semiAxes.minCoeff();
    case ShapeKind::Polygon: {
      if (def.vertices.empty()) return 0.0;
      Vec<2> lo = def.vertices.front(), hi = def.vertices.front();
      for (const Vec<2>& v : def.vertices) {
        lo = lo.cwiseMin(v);
        hi = hi.cwiseMax(v);
      }
      return (hi - lo).minCoeff();
    }
    case ShapeKind::RandomGrain: {
      const double e = std::max(def.grain.elongation, 1.0);
      return D == 2 ? def.grain.equivalentDiameter / std::sqrt(e) : def.grain.equivalentDiameter * std::pow(e, -1.0 / 3.0);
    }
    case ShapeKind::Mesh: {
      if constexpr (D == 3) {
        return readMesh(def.meshFile, def.meshScale).bounds().size().minCoeff();
      } else {
        return 0.0;
      }
    }
  }
  return 0.0;
}

namespace {

// The spacing of `def`, given the shape's smallest dimension (world units).
template <int D>
double spacingFor(const ShapeDef<D>& def, double smallest) {
  const bool hasSpacing = def.spacing > 0.0;
  const bool hasCells = def.cellsAcross > 0.0;
  if (hasSpacing == hasCells) {
    throw std::invalid_argument("give exactly one of spacing (world units) and cells_across (cells across the smallest dimension)");
  }
  if (hasSpacing) {
    if (!std::isfinite(def.spacing)) throw std::invalid_argument("spacing must be finite");
    return def.spacing;
  }
  if (!(smallest > 0.0) || !std::isfinite(smallest)) {
    throw std::invalid_argument("cannot derive a spacing: the shape's smallest dimension is " + std::to_string(smallest));
  }
  return smallest / def.cellsAcross;
}

// Refuses a shape `smallest` m across its smallest dimension outside
// [1e-10, 1e10] m: lengths are metres, and far beyond that range the exact
// geometry of the node placement (CGAL) overflows (a sphere of radius 1e40
// crashed it).
void checkShapeSize(double smallest) {
  if (std::isfinite(smallest) && smallest > 0.0 && (smallest > 1e10 || smallest < 1e-10)) {
    std::ostringstream what;
    what << "the shape is " << smallest
         << " m across its smallest dimension: lsdem takes shapes 1e-10 to 1e10 m across (lengths are in metres)";
    throw std::invalid_argument(what.str());
  }
}

}  // namespace

template <int D>
double resolvedSpacing(const ShapeDef<D>& def) {
  return spacingFor(def, def.cellsAcross > 0.0 ? smallestDimension(def) : 0.0);
}

void checkMeshResolution(const TriangleMesh& mesh, double spacing) {
  const double smallest = mesh.bounds().size().minCoeff();
  if (!(smallest / spacing >= kMinCellsAcross && smallest / spacing <= kMaxCellsAcross)) {
    std::ostringstream what;
    what << "gives " << smallest / spacing << " cells across the mesh's smallest extent (" << smallest
         << " at spacing " << spacing << "); it must give 2 to 1e4";
    throw ResolutionError(what.str());
  }
  // The grid over the box and its padding: at most 2^31 - 1 values. (Grid::
  // covering makes 2 (ceil(size / 2h) + pad) + 1 per axis, at most size / h
  // + 2 pad + 3.)
  double values = 1.0;
  for (int a = 0; a < 3; ++a) values *= mesh.bounds().size()[a] / spacing + 2.0 * kDefaultPaddingCells + 3.0;
  if (!(values <= 2147483647.0)) {
    std::ostringstream what;
    what << "gives a grid of " << values << " values over the mesh's box (" << mesh.bounds().size().x() << " x "
         << mesh.bounds().size().y() << " x " << mesh.bounds().size().z() << " at spacing " << spacing
         << "); the limit is 2^31: give a larger spacing";
    throw ResolutionError(what.str());
  }
}

namespace {

// The level set of a mesh definition's mesh (read by the caller, scaled).
Grid<3> meshGrid(const ShapeDef<3>& def, const TriangleMesh& mesh) {
  const double smallest = mesh.bounds().size().minCoeff();
  checkShapeSize(smallest);
  const double h = spacingFor(def, smallest);
  checkMeshResolution(mesh, h);
  return meshToLevelSet(mesh, h, kDefaultPaddingCells, def.meshFile);
}

}  // namespace

template <int D>
Grid<D> buildGrid(const ShapeDef<D>& def, MeshImportReport* meshReport) {
  const int pad = kDefaultPaddingCells;
  // A mesh is read once, and its extent gives the spacing.
  if constexpr (D == 3) {
    if (def.kind == ShapeKind::Mesh) return meshGrid(def, readMesh(def.meshFile, def.meshScale, meshReport));
  }
  checkShapeSize(smallestDimension(def));
  const double h = resolvedSpacing(def);
  switch (def.kind) {
    case ShapeKind::Sphere: return sphereGrid<D>(def.radius, h, pad);
    case ShapeKind::Box: return boxGrid<D>(def.halfExtents, def.rounding, h, pad);
    case ShapeKind::Ellipsoid: return ellipsoidGrid<D>(def.semiAxes, h, pad);
    case ShapeKind::Superellipsoid: return superellipsoidGrid<D>(def.semiAxes, def.exponents, h, pad);
    case ShapeKind::RandomGrain: return randomGrainGrid<D>(def.grain, h, pad);
    case ShapeKind::Polygon:
      if constexpr (D == 2) {
        return polygonGrid(def.vertices, h, pad);
      } else {
        throw std::invalid_argument("a polygon shape is 2D only (use a mesh in 3D)");
      }
    case ShapeKind::Mesh: throw std::invalid_argument("a mesh shape is 3D only (use a polygon in 2D)");
  }
  throw std::invalid_argument("unknown shape kind");
}

template <int D>
SurfaceFunction<D> exactSurface(const ShapeDef<D>& def) {
  // Check the dimensions once (the sampled grid does the same), not per call.
  switch (def.kind) {
    case ShapeKind::Sphere: {
      (void)sdfSphere<D>(Vec<D>::Zero(), def.radius);
      const double r = def.radius;
      return [r](const Vec<D>& x) { return x.norm() - r; };
    }
    case ShapeKind::Box: {
      (void)sdfBox<D>(Vec<D>::Zero(), def.halfExtents, def.rounding);
      const Vec<D> half = def.halfExtents;
      const double rounding = def.rounding;
      return [half, rounding](const Vec<D>& x) { return sdfBox<D>(x, half, rounding); };
    }
    case ShapeKind::Ellipsoid: {
      (void)sdfEllipsoid<D>(Vec<D>::Zero(), def.semiAxes);
      const Vec<D> axes = def.semiAxes;
      return [axes](const Vec<D>& x) { return sdfEllipsoid<D>(x, axes); };
    }
    case ShapeKind::Superellipsoid: {
      const Vec<D> axes = def.semiAxes;
      const std::vector<double> exponents = def.exponents;
      if (exponents.size() != (D == 2 ? 1u : 2u)) return {};  // superellipsoidGrid names the problem
      return [axes, exponents](const Vec<D>& x) { return superellipsoidRadialDistance<D>(x, axes, exponents); };
    }
    case ShapeKind::RandomGrain: return randomGrainSurface<D>(def.grain);
    case ShapeKind::Polygon:
      if constexpr (D == 2) {
        validatePolygon(def.vertices);
        const std::vector<Vec<2>> vertices = def.vertices;
        return [vertices](const Vec<2>& x) { return sdfPolygon(x, vertices); };
      } else {
        return {};
      }
    case ShapeKind::Mesh: return {};
  }
  return {};
}

template <int D>
std::shared_ptr<const Shape<D>> buildShape(const ShapeDef<D>& def, MeshImportReport* meshReport) {
  // The grid, and the true surface the nodes go on: the exact function of a
  // primitive or random grain, the triangles of a mesh (read once for both).
  Grid<D> grid;
  SurfaceProjector<D> onSurface;
  if constexpr (D == 3) {
    if (def.kind == ShapeKind::Mesh) {
      const TriangleMesh mesh = readMesh(def.meshFile, def.meshScale, meshReport);
      grid = meshGrid(def, mesh);
      if (def.exactNodes) onSurface = meshSurfaceProjector(mesh, grid.spacing());
    }
  }
  if (def.kind != ShapeKind::Mesh) {
    grid = buildGrid(def, meshReport);
    if (def.exactNodes) onSurface = projectorOnto(exactSurface(def), grid.spacing());
  }
  if (!onSurface) return Shape<D>::fromGrid(std::move(grid), def.options);
  // Nodes made on the grid's surface, then moved on to the true one.
  NodeSet<D> nodes;
  if constexpr (D == 2) {
    nodes = surfaceNodes(grid, def.options.nodesPerCell, onSurface);
  } else {
    nodes = surfaceNodes(grid, def.options.nodesPerCell, nullptr, onSurface);
  }
  if (nodes.empty()) throw std::invalid_argument("the level set has no surface to place nodes on");
  return Shape<D>::fromGridAndNodes(std::move(grid), std::move(nodes), def.options);
}

template const char* shapeKindName<2>(ShapeKind);
template const char* shapeKindName<3>(ShapeKind);
template double smallestDimension<2>(const ShapeDef<2>&);
template double smallestDimension<3>(const ShapeDef<3>&);
template double resolvedSpacing<2>(const ShapeDef<2>&);
template double resolvedSpacing<3>(const ShapeDef<3>&);
template Grid<2> buildGrid<2>(const ShapeDef<2>&, MeshImportReport*);
template Grid<3> buildGrid<3>(const ShapeDef<3>&, MeshImportReport*);
template SurfaceFunction<2> exactSurface<2>(const ShapeDef<2>&);
template SurfaceFunction<3> exactSurface<3>(const ShapeDef<3>&);
template std::shared_ptr<const Shape<2>> buildShape<2>(const ShapeDef<2>&, MeshImportReport*);
template std::shared_ptr<const Shape<3>> buildShape<3>(const ShapeDef<3>&, MeshImportReport*);

}  // namespace lsdem::geometry
