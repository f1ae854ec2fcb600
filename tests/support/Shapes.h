#pragma once
/// @file Shapes.h
/// @brief Test helpers shared by the suites: small shapes built once from
/// definition structs.

#include "lsdem/geometry/ShapeDef.h"

#include <algorithm>
#include <cstdint>
#include <memory>

namespace lsdem::test {

/// A circle (2D) or sphere (3D) of `radius` (m) with `cells` grid cells across
/// its diameter and one surface node per cell length.
template <int D>
std::shared_ptr<const geometry::Shape<D>> sphereShape(double radius, double cells = 10) {
  geometry::ShapeDef<D> def;
  def.kind = geometry::ShapeKind::Sphere;
  def.radius = radius;
  def.cellsAcross = cells;
  def.options.nodesPerCell = 1.0;
  return geometry::buildShape(def);
}

/// How far past its bounding sphere the shape's material reaches: the largest
/// |x| / boundingRadius - 1 over the points x where the interpolated level set
/// is negative, sampled at `per`^D points in every grid cell that has a
/// negative corner (<= 0: the sphere holds it).
template <int D>
double boundingSphereExcess(const geometry::Shape<D>& shape, int per = 6) {
  const geometry::Grid<D>& grid = shape.grid();
  const double h = grid.spacing();
  double worst = -1.0;
  for (std::size_t n = 0; n < grid.size(); ++n) {
    if (!(grid[n] < 0.0f)) continue;
    // The 2^D cells that have this node as their lower corner's neighbour.
    const geometry::Vec<D> base = grid.nodePosition(grid.unlinear(n)) - geometry::Vec<D>::Constant(h);
    int count = 1;
    for (int a = 0; a < D; ++a) count *= 2 * per;
    for (int k = 0; k < count; ++k) {
      geometry::Vec<D> g = base;
      int rest = k;
      for (int a = 0; a < D; ++a) {
        g[a] += (rest % (2 * per) + 0.5) * h / per;
        rest /= 2 * per;
      }
      if (!grid.contains(g) || !(grid.value(g) < 0.0)) continue;
      worst = std::max(worst, shape.bodyToGrid().applyInverse(g).norm() / shape.boundingRadius() - 1.0);
    }
  }
  return worst;
}

}  // namespace lsdem::test
