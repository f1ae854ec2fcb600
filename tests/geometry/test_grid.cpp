#include "lsdem/geometry/Grid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

using namespace lsdem::geometry;

namespace {

// Fill a grid with an analytic function of world position.
template <int D, class F>
Grid<D> sampled(const Grid<D>& shape, F f) {
  Grid<D> g = shape;
  for (std::size_t n = 0; n < g.size(); ++n) g[n] = float(f(g.nodePosition(g.unlinear(n))));
  return g;
}

}  // namespace

TEST(Grid, IndexRoundTrip3D) {
  Grid<3> g(Index<3>(4, 5, 6), Vec<3>(-1, 2, 0.5), 0.25);
  EXPECT_EQ(g.size(), 120u);
  for (std::size_t n = 0; n < g.size(); ++n) {
    EXPECT_EQ(g.linear(g.unlinear(n)), n);
  }
  const Index<3> i(3, 1, 5);
  const Vec<3> x = g.nodePosition(i);
  EXPECT_DOUBLE_EQ(x[0], -1 + 0.75);
  EXPECT_DOUBLE_EQ(x[2], 0.5 + 1.25);
  EXPECT_TRUE(((g.toGrid(x) - i.cast<double>().matrix()).array().abs() < 1e-12).all());
}

TEST(Grid, RejectsBadSpacingAndDims) {
  EXPECT_THROW(Grid<2>(Index<2>(4, 4), Vec<2>::Zero(), 0.0), std::invalid_argument);
  EXPECT_THROW(Grid<2>(Index<2>(4, 4), Vec<2>::Zero(), -1.0), std::invalid_argument);
  EXPECT_THROW(Grid<2>(Index<2>(1, 4), Vec<2>::Zero(), 1.0), std::invalid_argument);
}

TEST(Grid, CoveringIsSymmetricAndPadded) {
  Box<3> box{Vec<3>(-1, -0.5, -0.25), Vec<3>(1, 0.5, 0.25)};
  Grid<3> g = Grid<3>::covering(box, 0.1, 3);
  const Box<3> b = g.bounds();
  // At least 3 cells of padding, less than one cell more than that, centred.
  for (int a = 0; a < 3; ++a) {
    EXPECT_LE(b.lower[a], box.lower[a] - 0.3 + 1e-12);
    EXPECT_GT(b.lower[a], box.lower[a] - 0.4);
    EXPECT_NEAR(b.lower[a] + b.upper[a], box.lower[a] + box.upper[a], 1e-12);
  }
  EXPECT_NEAR(b.lower[0], -1.3, 1e-12);  // an exact multiple of the spacing gets exactly 3 cells
}

// A multilinear interpolant reproduces linear functions exactly, with their
// exact gradient, on every axis.
TEST(Grid, LinearFieldsAreExact) {
  Grid<3> g = sampled(Grid<3>(Index<3>(6, 7, 8), Vec<3>(-0.3, 0.1, -1), 0.2),
                      [](const Vec<3>& x) { return 0.5 * x[0] - 2.0 * x[1] + 1.5 * x[2] + 0.25; });
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int s = 0; s < 200; ++s) {
    const Box<3> b = g.bounds();
    Vec<3> x;
    for (int a = 0; a < 3; ++a) x[a] = b.lower[a] + u(rng) * (b.upper[a] - b.lower[a]);
    Vec<3> grad;
    const double v = g.valueAndGradient(x, grad);
    EXPECT_NEAR(v, 0.5 * x[0] - 2.0 * x[1] + 1.5 * x[2] + 0.25, 1e-5);
    EXPECT_NEAR(grad[0], 0.5, 1e-5);
    EXPECT_NEAR(grad[1], -2.0, 1e-5);
    EXPECT_NEAR(grad[2], 1.5, 1e-5);
  }
}

// The analytic gradient equals central finite differences of the interpolant
// (away from cell faces, where the interpolant is smooth) on every axis.
template <int D>
void checkGradientAgainstFiniteDifferences() {
  Index<D> dims = Index<D>::Constant(12);
  Grid<D> g = sampled(Grid<D>(dims, Vec<D>::Constant(-1.1), 0.2),
                      [](const Vec<D>& x) { return x.norm() - 0.7 + 0.1 * std::sin(3 * x[0]); });
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.1, 0.9);
  const double h = 1e-6;
  for (int s = 0; s < 300; ++s) {
    // A random point inside a random cell, not on its faces.
    Vec<D> gcoord;
    for (int a = 0; a < D; ++a) gcoord[a] = double(int(u(rng) * 10)) + u(rng);
    const Vec<D> x = g.toWorld(gcoord);
    Vec<D> grad;
    g.valueAndGradient(x, grad);
    for (int a = 0; a < D; ++a) {
      Vec<D> e = Vec<D>::Zero();
      e[a] = h;
      const double fd = (g.value(x + e) - g.value(x - e)) / (2 * h);
      EXPECT_NEAR(grad[a], fd, 1e-5) << "axis " << a;
    }
  }
}

TEST(Grid, GradientMatchesFiniteDifferences2D) { checkGradientAgainstFiniteDifferences<2>(); }
TEST(Grid, GradientMatchesFiniteDifferences3D) { checkGradientAgainstFiniteDifferences<3>(); }

// The sampled signed distance of a sphere: value and gradient approach the
// analytic ones, the gradient pointing along the radius.
TEST(Grid, SphereDistanceAndNormal) {
  const double R = 0.5;
  Grid<3> g = sampled(Grid<3>::covering(Box<3>{Vec<3>::Constant(-R), Vec<3>::Constant(R)}, 0.025, 4),
                      [R](const Vec<3>& x) { return x.norm() - R; });
  for (const Vec<3>& dir : {Vec<3>(1, 0, 0), Vec<3>(0, 1, 0), Vec<3>(0, 0, 1), Vec<3>(1, 1, 1).normalized()}) {
    const Vec<3> x = 0.48 * dir;
    Vec<3> grad;
    const double v = g.valueAndGradient(x, grad);
    EXPECT_NEAR(v, -0.02, 1e-3);
    EXPECT_GT(grad.normalized().dot(dir), 0.999);
  }
}

// maxGradientNorm is the supremum of |grad phi| of the interpolant: exact for
// a linear field (|(0.5, -2, 1.5)| = 2.55); for a field with kinks (a sphere's
// distance plus a ripple) no point of the box exceeds it, the corners of
// some cell reach it, and values differ by at most it times the distance.
TEST(Grid, MaxGradientNormBoundsTheInterpolant) {
  const Grid<3> linear = sampled(Grid<3>(Index<3>(6, 7, 8), Vec<3>(-0.3, 0.1, -1), 0.2),
                                 [](const Vec<3>& x) { return 0.5 * x[0] - 2.0 * x[1] + 1.5 * x[2] + 0.25; });
  EXPECT_NEAR(linear.maxGradientNorm(), std::sqrt(0.25 + 4.0 + 2.25), 1e-5);

  const Grid<3> g = sampled(Grid<3>(Index<3>::Constant(12), Vec<3>::Constant(-1.1), 0.2),
                            [](const Vec<3>& x) { return x.norm() - 0.7 + 0.1 * std::sin(3 * x[0]); });
  const double bound = g.maxGradientNorm();
  EXPECT_GT(bound, 1.0);
  EXPECT_LT(bound, 2.0);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const Box<3> b = g.bounds();
  const auto inBox = [&] {
    Vec<3> x;
    for (int a = 0; a < 3; ++a) x[a] = b.lower[a] + u(rng) * (b.upper[a] - b.lower[a]);
    return x;
  };
  double largest = 0.0, steepest = 0.0;
  for (int s = 0; s < 20000; ++s) {
    const Vec<3> x = inBox(), y = inBox();
    Vec<3> grad;
    g.valueAndGradient(x, grad);
    largest = std::max(largest, grad.norm());
    steepest = std::max(steepest, std::abs(g.value(y) - g.value(x)) / (y - x).norm());
  }
  EXPECT_LE(largest, bound * (1.0 + 1e-12));
  EXPECT_GT(largest, 0.9 * bound);  // random points come close to the corner maximum
  EXPECT_LE(steepest, bound * (1.0 + 1e-12));
}

// Outside the node box the value keeps growing like a distance, continuously.
TEST(Grid, OutsideIsDefinedAndContinuous) {
  Grid<2> g = sampled(Grid<2>(Index<2>(5, 5), Vec<2>(0, 0), 1.0), [](const Vec<2>& x) { return x[0] - 2.0; });
  Vec<2> grad;
  // Just inside and just outside the +x border agree.
  EXPECT_NEAR(g.value(Vec<2>(4.0 - 1e-9, 2.0)), g.value(Vec<2>(4.0 + 1e-9, 2.0)), 1e-6);
  const double v = g.valueAndGradient(Vec<2>(7.0, 2.0), grad);
  EXPECT_NEAR(v, 2.0 + 3.0, 1e-6);
  EXPECT_NEAR(grad[0], 1.0, 1e-12);
  EXPECT_NEAR(grad[1], 0.0, 1e-12);
  // Diagonally outside a corner: distance to the corner is added.
  const double vc = g.valueAndGradient(Vec<2>(7.0, 8.0), grad);
  EXPECT_NEAR(vc, 2.0 + std::hypot(3.0, 4.0), 1e-6);
  EXPECT_NEAR(grad[0], 0.6, 1e-12);
  EXPECT_NEAR(grad[1], 0.8, 1e-12);
  // Far outside the value is positive and finite.
  EXPECT_GT(g.value(Vec<2>(-100.0, -100.0)), 100.0);
}

TEST(Grid, CoveringRefusesAbsurdSizes) {
  Box<3> box{Vec<3>::Constant(-1.0), Vec<3>::Constant(1.0)};
  EXPECT_THROW(Grid<3>::covering(box, 1e-9, 4), std::invalid_argument);
  EXPECT_THROW(Grid<3>::covering(box, std::nan(""), 4), std::invalid_argument);
}
