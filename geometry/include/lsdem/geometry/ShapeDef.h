#pragma once
/// @file ShapeDef.h
/// @brief A definition struct for a shape (STYLE: create things from small
/// definition structs with defaults): which primitive, its dimensions, the grid
/// resolution and the node density. Scene and shape files fill one in; tests
/// build them in code. `buildShape` turns it into a shared immutable Shape.

#include "lsdem/geometry/RandomGrain.h"
#include "lsdem/geometry/Shape.h"
#include "lsdem/geometry/SurfaceNodes.h"
#include "lsdem/geometry/Types.h"

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace lsdem::geometry {

struct MeshImportReport;  // MeshIO.h
struct TriangleMesh;      // TriangleMesh.h

/// The kinds of shape lsdem builds. Sphere is the circle in 2D, Ellipsoid the
/// ellipse, Box the rectangle, Superellipsoid the superellipse.
enum class ShapeKind { Sphere, Box, Ellipsoid, Superellipsoid, Polygon, RandomGrain, Mesh };

/// @brief The scene-file name of a kind in dimension D ("circle" / "sphere", ...).
template <int D>
const char* shapeKindName(ShapeKind kind);

template <int D>
struct ShapeDef {
  ShapeKind kind = ShapeKind::Sphere;

  // --- dimensions, world units (metres); only those of `kind` are read ---
  double radius = 0.0;                        ///< Sphere
  Vec<D> semiAxes = Vec<D>::Zero();           ///< Ellipsoid, Superellipsoid
  Vec<D> halfExtents = Vec<D>::Zero();        ///< Box
  double rounding = 0.0;                      ///< Box: edge/corner radius, 0 = sharp
  std::vector<double> exponents;              ///< Superellipsoid: {n} in 2D, {n1, n2} in 3D
  std::vector<Vec<2>> vertices;               ///< Polygon (2D only)
  RandomGrainDef grain;                       ///< RandomGrain
  std::string meshFile;                       ///< Mesh (3D only): STL/OBJ/PLY path
  double meshScale = 1.0;                     ///< Mesh: factor from file units to metres

  // --- resolution: exactly one of spacing / cellsAcross is > 0 ---
  double spacing = 0.0;       ///< grid spacing, world units
  double cellsAcross = 0.0;   ///< grid cells across the smallest dimension of the shape

  ShapeOptions options;       ///< node density and mass estimator
  /// Surface nodes on the shape's true surface where it has one (the
  /// exactSurface function of a primitive or random grain, the triangles of
  /// a mesh: meshSurfaceProjector), rather than on the zero set of the
  /// grid's multilinear interpolant, which lies ~h^2 / (8 R) inside a convex
  /// surface (R the radius of curvature) and cuts a mesh's edges and
  /// corners: the contact then loses none of a small overlap on its own side.
  bool exactNodes = true;
};

/// @brief The definition's exact surface as the zero set of a function
/// (grid frame = the definition's frame, world units): the exact signed
/// distance of spheres, boxes, ellipsoids and polygons, the distance along
/// the ray from the centre of superellipsoids and random grains; empty for
/// meshes (their nodes go on the triangles: meshSurfaceProjector).
/// @note Throws std::invalid_argument for invalid dimensions.
template <int D>
SurfaceFunction<D> exactSurface(const ShapeDef<D>& def);

/// @brief The smallest dimension of the shape (world units), used to turn
/// `cellsAcross` into a spacing: the diameter of a sphere, twice the smallest
/// semi-axis or half extent, the smallest extent of a polygon or mesh, and the
/// short axis of a random grain (equivalent diameter / sqrt(elongation) in 2D,
/// x elongation^(-1/3) in 3D).
template <int D>
double smallestDimension(const ShapeDef<D>& def);

/// @brief A resolution (spacing or cells across) that cannot resolve the
/// shape: what buildGrid and buildShape throw when only the shape's own
/// size shows it (a mesh's, read from its file).
class ResolutionError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// The grid cells across a shape's smallest dimension lsdem accepts
/// (`cells_across`, or what a `spacing` gives a shape, a mesh or a CT grain):
/// fewer hold no shape (1 cell gave 5x a grain's volume), more make grids no
/// machine holds.
constexpr double kMinCellsAcross = 2.0, kMaxCellsAcross = 1e4;

/// @brief Throws ResolutionError unless `spacing` gives 2 to 1e4 cells across
/// the smallest extent of `mesh`'s box (the range cells_across allows) and a
/// grid of at most 2^31 values over the box with its padding.
void checkMeshResolution(const TriangleMesh& mesh, double spacing);

/// @brief The grid spacing the definition asks for (world units).
/// @note Throws std::invalid_argument unless exactly one of spacing and
/// cellsAcross is positive.
template <int D>
double resolvedSpacing(const ShapeDef<D>& def);

/// @brief The level-set grid of the definition, centred on the origin (meshes
/// keep their file coordinates, scaled).
/// @param meshReport when given and the shape is a mesh: what reading it left
/// out (readMesh).
/// @note Throws ResolutionError when a mesh's spacing gives fewer than 2 or
/// more than 1e4 cells across its smallest extent.
template <int D>
Grid<D> buildGrid(const ShapeDef<D>& def, MeshImportReport* meshReport = nullptr);

/// @brief The shape of the definition: grid, mass properties, nodes (on the
/// true surface when `def.exactNodes`: projectorOnto(exactSurface(def)), or
/// a mesh's meshSurfaceProjector), descriptors.
/// @param meshReport as for buildGrid.
template <int D>
std::shared_ptr<const Shape<D>> buildShape(const ShapeDef<D>& def, MeshImportReport* meshReport = nullptr);

}  // namespace lsdem::geometry
