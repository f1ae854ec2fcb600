#pragma once
/// @file Descriptors.h
/// @brief Shape descriptors of a grain for particle-size and shape statistics:
/// circularity (eq. 23) / Wadell sphericity, best-fit ellipse/ellipsoid axes and
/// aspect ratio, equivalent diameter, and the sieve size along the line through
/// the centroid and the closest surface node (eq. 21).

#include "lsdem/geometry/Grid.h"
#include "lsdem/geometry/MassProperties.h"
#include "lsdem/geometry/NodeSet.h"
#include "lsdem/geometry/Types.h"

namespace lsdem::geometry {

/// Shape descriptors of one grain; lengths in world units.
template <int D>
struct Descriptors {
  double volume = 0.0;              ///< area (2D) / volume (3D), from MassProperties; world units^D
  double surfaceArea = 0.0;         ///< perimeter (2D) / surface area (3D): the sum of the node weights; world units^(D-1)
  double circularity = 0.0;         ///< 2D: 4 pi A / P^2 (eq. 23); 3D: Wadell's true sphericity pi^(1/3) (6V)^(2/3) / A. 1 for a circle / sphere
  double aspectRatio = 0.0;         ///< shortest / longest best-fit semi-axis, in (0, 1]
  Vec<D> bestFitSemiAxes = Vec<D>::Zero();  ///< semi-axes of the uniform ellipse (ellipsoid) with the same volume-normalised second moments, descending; world units
  double equivalentDiameter = 0.0;  ///< diameter of the circle (sphere) of the same area (volume): 2 sqrt(A/pi) in 2D, (6V/pi)^(1/3) in 3D
  double sieveSize = 0.0;           ///< eq. 21: length inside the shape of the line through the centroid and the closest surface node; equivalentDiameter where that is below a quarter cell (a piece a cell or two thin the line misses or grazes)
  double intermediateAxis = 0.0;    ///< 3D: 2 x the middle best-fit semi-axis; 2D: 2 x the minor one
};

/// @brief Shape descriptors of the grain {phi < 0} of `grid`.
///
/// Best-fit axes: a uniform ellipse with semi-axis a has second moment
/// S_i / A = a^2 / 4 along it, a uniform ellipsoid S_i / V = a^2 / 5, so
/// a_i = sqrt(4 S_i / A) (2D), sqrt(5 S_i / V) (3D), with S_i the principal
/// second moments of `mass`.
///
/// Sieve size (eq. 21 and the paper's particle-size definition): p_min is the
/// surface node closest to the centroid; along the line through the centroid
/// and p_min, clipped to the grid's box, the lengths of all the intervals where
/// the grid's multilinear interpolant is negative are summed (marching in steps
/// of at most h/4, each sign change refined by bisection), so concave shapes and
/// a centroid outside the shape are handled. If p_min coincides with the
/// centroid the line follows the shortest principal axis.
///
/// @param grid level-set grid of the grain (world units).
/// @param mass mass properties of that grid (massProperties(grid)).
/// @param nodes surface nodes in the grid's frame, with their length/area weights.
/// @note Throws std::invalid_argument when nodes are empty, weights and
/// positions differ in number, the total weight is not positive, or
/// mass.volume <= 0.
template <int D>
Descriptors<D> computeDescriptors(const Grid<D>& grid, const MassProperties<D>& mass, const NodeSet<D>& nodes);

extern template struct Descriptors<2>;
extern template struct Descriptors<3>;
extern template Descriptors<2> computeDescriptors<2>(const Grid<2>&, const MassProperties<2>&, const NodeSet<2>&);
extern template Descriptors<3> computeDescriptors<3>(const Grid<3>&, const MassProperties<3>&, const NodeSet<3>&);

}  // namespace lsdem::geometry
