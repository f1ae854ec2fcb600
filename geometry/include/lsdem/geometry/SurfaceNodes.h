#pragma once
/// @file SurfaceNodes.h
/// @brief Surface nodes (eq. 2: points on phi = 0) of a level-set grid, with
/// their length (2D) or area (3D) weights. The node density is the paper's
/// "pts/pix": nodes per grid cell of length along the surface.

#include "lsdem/geometry/Grid.h"
#include "lsdem/geometry/NodeSet.h"
#include "lsdem/geometry/TriangleMesh.h"

#include <functional>

namespace lsdem::geometry {

/// A shape's exact surface as the zero set of a function of a point (world
/// units, grid frame; negative inside): an exact signed distance, or any
/// function with the same zero set and a non-zero gradient there (the
/// distance along the ray from the centre of a superellipsoid or random
/// grain). Empty: the shape has no better description than its grid.
template <int D>
using SurfaceFunction = std::function<double(const Vec<D>&)>;

/// Moves a point (world units, grid frame) onto a shape's true surface and
/// returns where it lands, or the point unmoved where it cannot be moved
/// soundly (it then stays on the grid's surface). Called from several
/// threads at once: it must not change state. Made from a SurfaceFunction
/// (projectorOnto: primitives, random grains) or from a CAD mesh
/// (meshSurfaceProjector, MeshToLevelSet.h: the closest point on its
/// triangles). Empty: the shape has no better description than its grid.
template <int D>
using SurfaceProjector = std::function<Vec<D>(const Vec<D>&)>;

/// @brief eq. 2 in 2D: nodes spread evenly along every closed contour of the
/// zero level set.
/// @param grid level set, world units, phi < 0 inside.
/// @param nodesPerCell target node density in nodes per grid cell of contour
/// length (the paper's pts/pix): target arc-length spacing = spacing / nodesPerCell.
/// @return Per contour (marchingSquares), n = max(3, round(L / target)) nodes at
/// equal arc-length steps L / n of the marching-squares polyline (length L),
/// each then projected onto phi = 0 of the grid's bilinear interpolant by
/// damped Newton steps along the gradient (|phi| never grows). A node's weight is half the distance to its
/// two neighbours along the contour, so the weights sum to the length of the
/// closed polygon through the nodes (the perimeter, world units). Positions are
/// in the grid's frame (world units). Empty when no node is inside.
/// @param onSurface when not empty, each node then moves on to the true
/// surface (a SurfaceProjector) before the weights are taken: nodes on the
/// true surface, not h^2 / (8 R) inside it on the interpolant's.
/// @note Throws std::invalid_argument when nodesPerCell is not finite or <= 0.
NodeSet<2> surfaceNodes(const Grid<2>& grid, double nodesPerCell, const SurfaceProjector<2>& onSurface = {});

/// @brief eq. 2 in 3D: nodes spread evenly over the zero level set.
/// @param grid level set, world units, phi < 0 inside.
/// @param nodesPerCell target node density in nodes per grid cell of length
/// along the surface (pts/pix): target edge length = spacing / nodesPerCell,
/// so node counts grow like nodesPerCell^2.
/// @param meshOut when not null, receives the remeshed surface whose vertices
/// are the nodes (same order), for output and shape descriptors.
/// @return The marching-cubes mesh (marchingCubes) is remeshed isotropically to
/// the target edge length (CGAL Polygon_mesh_processing::isotropic_remeshing,
/// 3 iterations, nothing protected), its vertices are projected onto phi = 0 of
/// the trilinear interpolant by damped Newton steps along the gradient (for a
/// smooth distance field to ~1e-9 cells; in a rough field where the marching
/// surface and the interpolant disagree a vertex stops at its closest
/// approach), and each
/// vertex becomes a node whose weight is a third of the area of its incident
/// triangles, so the weights sum to the mesh area (world units^2). Empty when
/// no node is inside.
/// @param onSurface when not empty, each vertex then moves on to the true
/// surface (a SurfaceProjector, called in parallel) before the weights are taken.
/// @note Throws std::invalid_argument when nodesPerCell is not finite or <= 0.
NodeSet<3> surfaceNodes(const Grid<3>& grid, double nodesPerCell, TriangleMesh* meshOut = nullptr,
                        const SurfaceProjector<3>& onSurface = {});

/// @brief Moves the point x (world units) onto the zero set of `surface` by
/// Newton steps along its gradient (central differences of 1e-6 spacing;
/// each step at most half a cell, halved until |f| decreases), to |f| <=
/// 1e-10 spacing. A point that does not get there, or would move more than
/// one cell, is returned unmoved (it stays on the grid's surface).
/// @param spacing the grid spacing, world units: the scale of the steps and tolerances.
template <int D>
Vec<D> projectOntoSurface(const SurfaceFunction<D>& surface, const Vec<D>& x, double spacing);

extern template Vec<2> projectOntoSurface<2>(const SurfaceFunction<2>&, const Vec<2>&, double);
extern template Vec<3> projectOntoSurface<3>(const SurfaceFunction<3>&, const Vec<3>&, double);

/// @brief The projector onto the zero set of `surface`: projectOntoSurface
/// at `spacing` (world units). Empty when `surface` is.
template <int D>
SurfaceProjector<D> projectorOnto(SurfaceFunction<D> surface, double spacing);

extern template SurfaceProjector<2> projectorOnto<2>(SurfaceFunction<2>, double);
extern template SurfaceProjector<3> projectorOnto<3>(SurfaceFunction<3>, double);

/// Which interpolant of a grid's values a point is looked up with.
enum class GridInterpolant {
  /// Grid::value / valueAndGradient: multilinear (the paper's).
  Multilinear,
  /// Grid::cubicValueAtCells and its exact gradient: Catmull-Rom tricubic
  /// (bicubic in 2D), the narrow phase's `interpolation = "tricubic"`.
  CatmullRom,
};

/// @brief The grid's `interpolant` at world point x (grid frame, world
/// units), and its gradient (per world unit) in `grad` when given. Outside
/// the node box both extend as Grid::value does: the value at the closest
/// point of the box plus the distance to it.
template <int D>
double interpolantValue(const Grid<D>& grid, const Vec<D>& x, GridInterpolant interpolant, Vec<D>* grad = nullptr);

extern template double interpolantValue<2>(const Grid<2>&, const Vec<2>&, GridInterpolant, Vec<2>*);
extern template double interpolantValue<3>(const Grid<3>&, const Vec<3>&, GridInterpolant, Vec<3>*);

/// @brief Moves the point x (world units, grid frame) onto the set where
/// the grid's `interpolant` equals `level` (world units) by damped Newton
/// steps along the gradient (x -= t (phi - level) grad / |grad|^2, each step
/// at most half a cell, halved until |phi - level| decreases, so it never
/// grows, even where the gradient is small or jumps between cells). Where
/// Newton stalls (at the kink of a cut, eq. 14-15) the level is bracketed
/// between x and the closest grid node on its other side within two cells
/// and found by bisection. Where there is none the point stops at its
/// closest approach.
/// @param level 0 for the zero set; a fragment's node taken from its parent
/// keeps the offset it had from the parent's interpolant (breakage/Split.cpp).
/// @param toleranceCells stop once |phi - level| <= toleranceCells x spacing.
/// @param maxIterations Newton steps at most.
template <int D>
Vec<D> projectOntoLevel(const Grid<D>& grid, Vec<D> x, double level, GridInterpolant interpolant,
                        double toleranceCells = 1e-9, int maxIterations = 8);

extern template Vec<2> projectOntoLevel<2>(const Grid<2>&, Vec<2>, double, GridInterpolant, double, int);
extern template Vec<3> projectOntoLevel<3>(const Grid<3>&, Vec<3>, double, GridInterpolant, double, int);

/// @brief Moves the point x (world units, grid frame) onto phi = 0 of the
/// grid's multilinear interpolant: projectOntoLevel(grid, x, 0,
/// GridInterpolant::Multilinear, ...). Where the interpolant has no zero
/// nearby the point stops at its closest approach.
/// @param toleranceCells stop once |phi| <= toleranceCells x spacing.
/// @param maxIterations Newton steps at most.
template <int D>
Vec<D> projectOntoZero(const Grid<D>& grid, Vec<D> x, double toleranceCells = 1e-9, int maxIterations = 8);

extern template Vec<2> projectOntoZero<2>(const Grid<2>&, Vec<2>, double, int);
extern template Vec<3> projectOntoZero<3>(const Grid<3>&, Vec<3>, double, int);

}  // namespace lsdem::geometry
