#pragma once
/// @file Primitives.h
/// @brief Analytic signed distances of primitive shapes (sphere, box, ellipsoid,
/// polygon, half-space; eq. 18-20 for the half-spaces) and level-set grids
/// sampled from them, in 2D and 3D.
///
/// Every shape is centred on the origin of its frame. Sign convention of the
/// whole library: phi < 0 inside, phi >= 0 outside (phi == 0 counts as outside),
/// values in world units (metres).

#include "lsdem/geometry/Grid.h"
#include "lsdem/geometry/Types.h"

#include <cstddef>
#include <exception>
#include <vector>

namespace lsdem::geometry {

/// @brief Exact signed distance from x to the sphere (circle in 2D) of radius
/// `radius` centred on the origin: |x| - radius, world units.
/// @param x point, world units.
/// @param radius sphere radius, world units.
/// @note radius > 0 and finite; throws std::invalid_argument otherwise.
template <int D>
double sdfSphere(const Vec<D>& x, double radius);

/// @brief Exact signed distance from x to the axis-aligned box [-halfExtents,
/// halfExtents] centred on the origin, optionally with rounded edges and corners.
/// @param x point, world units.
/// @param halfExtents half the box size along each axis, world units.
/// @param rounding radius of the rounded edges/corners, world units. The box
/// keeps its outer half extents: it is the inner box (halfExtents - rounding)
/// grown by `rounding`. 0 gives sharp corners.
/// @note halfExtents > 0 and finite, 0 <= rounding <= min(halfExtents); throws
/// std::invalid_argument otherwise.
template <int D>
double sdfBox(const Vec<D>& x, const Vec<D>& halfExtents, double rounding = 0.0);

/// @brief Exact Euclidean signed distance from x to the ellipse (2D) /
/// ellipsoid (3D) with semi-axes `semiAxes` along the coordinate axes, centred
/// on the origin.
///
/// The closest point is x_i = a_i^2 p_i / (a_i^2 + t) with the Lagrange
/// multiplier t the unique root of sum_i (a_i p_i / (a_i^2 + t))^2 = 1 above
/// -min(a_i^2); it is found by bisection on a bracket that is valid for every
/// point. Points on the shortest axes (including the centre), where that root
/// may not exist, are handled in closed form.
/// @param x point, world units.
/// @param semiAxes semi-axis lengths (a, b[, c]), world units.
/// @note semiAxes > 0 and finite; throws std::invalid_argument otherwise.
template <int D>
double sdfEllipsoid(const Vec<D>& x, const Vec<D>& semiAxes);

/// @brief Exact signed distance from x to a simple polygon (convex or concave,
/// vertices in either orientation): the distance to the nearest edge, negative
/// inside (even-odd rule).
/// @param x point, world units.
/// @param vertices polygon vertices in order (the closing edge from the last to
/// the first vertex is implied), world units.
/// @note At least 3 finite vertices with non-zero area; throws
/// std::invalid_argument otherwise. The polygon must not self-intersect: that
/// O(n^2) check is made once by polygonGrid and validatePolygon, not on every
/// call here.
double sdfPolygon(const Vec<2>& x, const std::vector<Vec<2>>& vertices);

/// @brief Checks that `vertices` describe a simple polygon: at least 3 finite
/// vertices, no repeated consecutive vertex, non-zero signed area, and no two
/// edges that intersect other than adjacent edges at their shared vertex.
/// @note Throws std::invalid_argument naming the first problem found.
void validatePolygon(const std::vector<Vec<2>>& vertices);

/// @brief A half-space with the flat boundary normal . x = offset (a line in
/// 2D, a plane in 3D); phi(x) = normal . x - offset is the exact signed
/// distance (eq. 18-20), negative on the side opposite to the normal.
template <int D>
struct HalfSpace {
  Vec<D> normal = Vec<D>::UnitX();  ///< unit outward normal (points to phi > 0)
  double offset = 0.0;              ///< normal . x on the boundary, world units

  /// @brief Signed distance normal . x - offset of x, world units.
  double distance(const Vec<D>& x) const { return normal.dot(x) - offset; }

  /// @brief eq. 18: the line through p1 and p2 (2D). The normal is the
  /// direction p2 - p1 turned clockwise, so points on the left of p1 -> p2 are
  /// inside (phi < 0) and points on the right are outside; phi equals eq. 18's
  /// ((y2-y1)x - (x2-x1)y + x2 y1 - y2 x1) / |p2 - p1|.
  /// @note Throws std::invalid_argument when the points coincide (|p2 - p1| <=
  /// 1e-12 max(|p1|, |p2|)) or are not finite.
  static HalfSpace throughPoints(const Vec<2>& p1, const Vec<2>& p2) requires(D == 2);

  /// @brief eq. 19-20: the plane through p1, p2, p3 (3D), normal along
  /// n = (p2 - p1) x (p3 - p1). Seen from the outside (phi > 0), p1, p2, p3 run
  /// counter-clockwise.
  /// @note Throws std::invalid_argument when two points coincide or the three
  /// are collinear (|n| <= 1e-12 |p2 - p1| |p3 - p1|, the sine of the angle at
  /// p1), or are not finite.
  static HalfSpace throughPoints(const Vec<3>& p1, const Vec<3>& p2, const Vec<3>& p3) requires(D == 3);
};

namespace detail {
/// @brief Checks the arguments of a grid sampling (box lower <= upper and
/// finite, spacing > 0, 0 <= paddingCells, fewer than 2^24 nodes per axis and
/// 2^31 in all); throws std::invalid_argument naming the bad one.
template <int D>
void checkSampling(const Box<D>& box, double spacing, int paddingCells);
}  // namespace detail

/// @brief Builds a grid covering `box` plus `paddingCells` cells on every side
/// (Grid<D>::covering) with the value sdf(node position) at every node.
/// @param box region the shape occupies, world units.
/// @param spacing node spacing, world units.
/// @param paddingCells cells of padding around `box`, in cells.
/// @param sdf callable double(const Vec<D>&) giving the signed distance in world
/// units; called concurrently from several threads, so it must be thread-safe.
/// @note Throws std::invalid_argument on bad box, spacing or padding, and
/// rethrows the first exception `sdf` throws.
template <int D, class F>
Grid<D> sampleGrid(const Box<D>& box, double spacing, int paddingCells, F&& sdf) {
  detail::checkSampling<D>(box, spacing, paddingCells);
  Grid<D> grid = Grid<D>::covering(box, spacing, paddingCells);
  // Evaluate the distance at every node; nodes are independent, so the result
  // does not depend on the thread count. An exception thrown by `sdf` must not
  // leave a parallel region: the first one caught is kept and rethrown afterwards.
  const std::ptrdiff_t count = std::ptrdiff_t(grid.size());
  std::exception_ptr failure;
#ifdef LSDEM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
  for (std::ptrdiff_t n = 0; n < count; ++n) {
    try {
      grid[std::size_t(n)] = float(sdf(grid.nodePosition(grid.unlinear(std::size_t(n)))));
    } catch (...) {
#ifdef LSDEM_HAVE_OPENMP
#pragma omp critical(lsdem_sample_grid_failure)
#endif
      if (!failure) failure = std::current_exception();
    }
  }
  if (failure) std::rethrow_exception(failure);
  return grid;
}

/// @brief Signed-distance grid of a sphere (circle in 2D) of radius `radius`
/// centred on the origin.
/// @param radius world units, > 0.
/// @param spacing node spacing, world units, > 0.
/// @param paddingCells cells of padding beyond the sphere's bounding box.
template <int D>
Grid<D> sphereGrid(double radius, double spacing, int paddingCells = kDefaultPaddingCells);

/// @brief Signed-distance grid of the (optionally rounded) box of sdfBox.
/// @param halfExtents world units, > 0.
/// @param rounding edge/corner radius, world units, in [0, min(halfExtents)].
/// @param spacing node spacing, world units, > 0.
/// @param paddingCells cells of padding beyond the box.
template <int D>
Grid<D> boxGrid(const Vec<D>& halfExtents, double rounding, double spacing, int paddingCells = kDefaultPaddingCells);

/// @brief Signed-distance grid of the ellipse/ellipsoid of sdfEllipsoid.
/// @param semiAxes world units, > 0.
/// @param spacing node spacing, world units, > 0.
/// @param paddingCells cells of padding beyond the ellipsoid's bounding box.
template <int D>
Grid<D> ellipsoidGrid(const Vec<D>& semiAxes, double spacing, int paddingCells = kDefaultPaddingCells);

/// @brief Signed-distance grid of a superellipse (2D) / superellipsoid (3D).
///
/// 2D: |x/a|^n + |y/b|^n = 1 with exponents = {n}; 3D:
/// (|x/a|^n2 + |y/b|^n2)^(n1/n2) + |z/c|^n1 = 1 with exponents = {n1, n2}
/// (n = 2: ellipse/ellipsoid; large n: towards the box; the blockiness form
/// used by superquadric DEM codes). The inside-outside function is not a
/// distance: it is first turned into the signed distance along the ray from the
/// centre (exact on the surface, smooth, overflow-free for large exponents),
/// then reinitialised to a signed distance by fast sweeping (eq. 17, see
/// Reinitialize.h), whose subcell interface step makes the nodes next to the
/// surface accurate.
/// @param semiAxes world units, > 0.
/// @param exponents {n} in 2D, {n1, n2} in 3D; each > 0 and finite.
/// @param spacing node spacing, world units, > 0.
/// @param paddingCells cells of padding beyond the bounding box.
template <int D>
Grid<D> superellipsoidGrid(const Vec<D>& semiAxes, const std::vector<double>& exponents, double spacing,
                           int paddingCells = kDefaultPaddingCells);

/// @brief The function superellipsoidGrid samples before reinitialising:
/// |x| (1 - 1/N(x)), N the superellipsoid's degree-1 "norm" (N = 1 on the
/// surface), the signed distance along the ray from the centre: exact on the
/// surface, world units. Arguments as for superellipsoidGrid, not checked.
template <int D>
double superellipsoidRadialDistance(const Vec<D>& x, const Vec<D>& semiAxes, const std::vector<double>& exponents);

/// @brief Signed-distance grid of a simple polygon (see sdfPolygon), in the
/// polygon's own coordinates (not re-centred).
/// @param vertices polygon vertices, world units; validated with validatePolygon.
/// @param spacing node spacing, world units, > 0.
/// @param paddingCells cells of padding beyond the polygon's bounding box.
Grid<2> polygonGrid(const std::vector<Vec<2>>& vertices, double spacing, int paddingCells = kDefaultPaddingCells);

}  // namespace lsdem::geometry
