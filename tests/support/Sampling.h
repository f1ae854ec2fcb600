#pragma once
/// @file Sampling.h
/// @brief Test helpers shared by the suites: grids sampled from analytic
/// signed distances.

#include "lsdem/geometry/Primitives.h"

namespace lsdem::test {

using geometry::Box;
using geometry::Grid;
using geometry::Vec;

/// A grid covering `box` with spacing h and the default 4 cells of padding,
/// sampled from the analytic level set f(world point).
template <int D, class F>
Grid<D> sampled(const Box<D>& box, double h, F f) {
  return geometry::sampleGrid<D>(box, h, geometry::kDefaultPaddingCells, f);
}

/// The cube (square) of half side `radius` around `centre`.
template <int D>
Box<D> boxAround(const Vec<D>& centre, double radius) {
  return {centre - Vec<D>::Constant(radius), centre + Vec<D>::Constant(radius)};
}

}  // namespace lsdem::test
