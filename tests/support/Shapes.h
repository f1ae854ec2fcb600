#pragma once
/// @file Shapes.h
/// @brief Test helpers shared by the suites: small shapes built once from
/// definition structs.

#include "lsdem/geometry/ShapeDef.h"

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

}  // namespace lsdem::test
