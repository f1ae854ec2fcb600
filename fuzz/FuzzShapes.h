#pragma once
/// @file FuzzShapes.h
/// @brief A fixed library of grain shapes the fuzz targets draw from, built
/// once per process: spheres from 3 to 12 cells across (the resolution limit),
/// a needle and (3D) a disc of aspect 10, a sharp and a rounded box, and a
/// concave comb, plus two fragments of a split sphere.

#include "lsdem/breakage/Split.h"
#include "lsdem/geometry/Primitives.h"
#include "lsdem/geometry/ShapeDef.h"

#include <cmath>
#include <memory>
#include <vector>

namespace lsdem::fuzz {

template <int D>
std::shared_ptr<const geometry::Shape<D>> buildKind(geometry::ShapeKind kind, double cells, const geometry::Vec<D>& axes,
                                                     double rounding = 0.0) {
  geometry::ShapeDef<D> def;
  def.kind = kind;
  def.radius = axes[0];
  def.semiAxes = axes;
  def.halfExtents = axes;
  def.rounding = rounding;
  def.cellsAcross = cells;
  def.options.nodesPerCell = 1.0;
  return geometry::buildShape(def);
}

/// @brief The shape library of dimension D (built on first use).
template <int D>
const std::vector<std::shared_ptr<const geometry::Shape<D>>>& shapeLibrary() {
  static const std::vector<std::shared_ptr<const geometry::Shape<D>>> library = [] {
    using geometry::ShapeKind;
    using geometry::Vec;
    std::vector<std::shared_ptr<const geometry::Shape<D>>> out;
    const double r = 0.01;
    // Spheres at and above the resolution limit.
    for (double cells : {3.0, 4.0, 6.0, 12.0}) out.push_back(buildKind<D>(ShapeKind::Sphere, cells, Vec<D>::Constant(r)));
    // Needle (and disc): degenerate inertia.
    Vec<D> needle = Vec<D>::Constant(0.1 * r);
    needle[0] = r;
    out.push_back(buildKind<D>(ShapeKind::Ellipsoid, 4, needle));
    if constexpr (D == 3) out.push_back(buildKind<D>(ShapeKind::Ellipsoid, 4, Vec<D>(r, r, 0.1 * r)));
    // Boxes, sharp and rounded (flat faces: many nodes on one plane).
    Vec<D> half = Vec<D>::Constant(0.5 * r);
    half[0] = r;
    out.push_back(buildKind<D>(ShapeKind::Box, 6, half));
    out.push_back(buildKind<D>(ShapeKind::Box, 6, half, 0.2 * r));
    // A concave comb of three teeth (a cut across them gives four pieces).
    {
      const double t = 0.4 * r;
      geometry::Box<D> box;
      box.lower = Vec<D>::Constant(-t);
      box.lower[0] = -3.0 * t;
      box.upper = Vec<D>::Constant(t);
      box.upper[0] = 3.0 * t;
      box.upper[1] = 5.0 * t;
      auto sdf = [t](const Vec<D>& x) {
        Vec<D> back = Vec<D>::Constant(t);
        back[0] = 2.5 * t;
        back[1] = 0.5 * t;
        double phi = geometry::sdfBox<D>(x, back);
        for (int k = -1; k <= 1; ++k) {
          Vec<D> c = Vec<D>::Zero();
          c[0] = 2.0 * t * k;
          c[1] = 2.25 * t;
          Vec<D> tooth = Vec<D>::Constant(t);
          tooth[0] = 0.5 * t;
          tooth[1] = 2.25 * t;
          phi = std::min(phi, geometry::sdfBox<D>(x - c, tooth));
        }
        return phi;
      };
      geometry::ShapeOptions options;
      options.nodesPerCell = 1.0;
      out.push_back(
          geometry::Shape<D>::fromGrid(geometry::sampleGrid<D>(box, 0.25 * t, geometry::kDefaultPaddingCells, sdf), options));
    }
    // Fragments of a sphere cut off-centre (a cap and the rest).
    {
      breakage::FractureSurface<D> surface;
      geometry::HalfSpace<D> plane;
      plane.normal = Vec<D>::Ones().normalized();
      plane.offset = 0.5 * r;
      surface.plane = plane;
      const auto split = breakage::splitShape(*out[3], surface);
      for (const auto& f : split.fragments) out.push_back(f.shape);
    }
    return out;
  }();
  return library;
}

}  // namespace lsdem::fuzz
