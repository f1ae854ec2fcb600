#include "lsdem/geometry/Grid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>
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

// ---- the Catmull-Rom tricubic interpolant ----

namespace {

// A random point of the node box at least `inset` cells from its border (grid coordinates).
template <int D>
Vec<D> pointInBox(const Grid<D>& g, std::mt19937& rng, double inset) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Vec<D> p;
  for (int a = 0; a < D; ++a) p[a] = inset + u(rng) * (double(g.dims()[a] - 1) - 2.0 * inset);
  return p;
}

// The largest error of the interpolant (cubic or multilinear) against |x| - R
// over points within one cell of a sphere of radius R sampled at spacing h.
double sphereError(double R, double h, bool cubic) {
  const Grid<3> g = sampled(Grid<3>::covering(Box<3>{Vec<3>::Constant(-R), Vec<3>::Constant(R)}, h, 4),
                            [R](const Vec<3>& x) { return x.norm() - R; });
  std::mt19937 rng(3);
  double worst = 0.0;
  for (int k = 0, found = 0; found < 4000 && k < 400000; ++k) {
    const Vec<3> c = pointInBox(g, rng, 0.0);
    const Vec<3> x = g.toWorld(c);
    const double exact = x.norm() - R;
    if (std::abs(exact) > h) continue;
    ++found;
    const double v = cubic ? g.cubicValueAtCells(c) : g.valueAtCells(c);
    worst = std::max(worst, std::abs(v - exact));
  }
  return worst;
}

}  // namespace

// Catmull-Rom reproduces quadratics: on cells whose 4^D stencil is inside
// the grid, the value and gradient of x^T C x + b . x + a are exact (to the
// floats the grid stores); at grid nodes it equals the stored value.
template <int D>
void checkCubicReproducesQuadratics() {
  Mat<D> C = Mat<D>::Zero();
  Vec<D> b;
  for (int i = 0; i < D; ++i) {
    b[i] = 0.3 - 0.2 * i;
    for (int j = 0; j < D; ++j) C(i, j) = 0.1 * (i + 1) + 0.05 * (i == j) - 0.03 * j;
  }
  C = 0.5 * (C + C.transpose()).eval();
  Index<D> dims = Index<D>::Constant(7);
  const Grid<D> g = sampled(Grid<D>(dims, Vec<D>::Constant(-0.6), 0.2),
                            [&](const Vec<D>& x) { return x.dot(C * x) + b.dot(x) + 0.25; });
  std::mt19937 rng(11);
  for (int k = 0; k < 200; ++k) {
    const Vec<D> c = pointInBox(g, rng, 1.0);  // the stencil stays inside
    const Vec<D> x = g.toWorld(c);
    Vec<D> grad;
    const double v = g.cubicValueAndGradientAtCells(c, grad);
    EXPECT_NEAR(v, x.dot(C * x) + b.dot(x) + 0.25, 1e-6);
    const Vec<D> exact = 2.0 * C * x + b;
    EXPECT_LT((grad / g.spacing() - exact).norm(), 1e-5);
    EXPECT_EQ(g.cubicValueAtCells(c), v);  // the same arithmetic with and without the gradient
  }
  const Index<D> node = Index<D>::Constant(3);
  EXPECT_NEAR(g.cubicValueAtCells(node.template cast<double>().matrix()), double(g.at(node)), 1e-12);
}

TEST(Grid, CubicReproducesQuadratics2D) { checkCubicReproducesQuadratics<2>(); }
TEST(Grid, CubicReproducesQuadratics3D) { checkCubicReproducesQuadratics<3>(); }

// The gradient is the derivative of the value (central differences of a
// sphere's distance with a ripple, so every cell differs).
TEST(Grid, CubicGradientMatchesFiniteDifferences) {
  const Grid<3> g = sampled(Grid<3>::covering(Box<3>{Vec<3>::Constant(-0.5), Vec<3>::Constant(0.5)}, 0.1, 4),
                            [](const Vec<3>& x) { return x.norm() - 0.5 + 0.02 * std::sin(9.0 * x[0] + 4.0 * x[2]); });
  std::mt19937 rng(5);
  for (int k = 0; k < 200; ++k) {
    const Vec<3> c = pointInBox(g, rng, 0.01);
    Vec<3> grad;
    g.cubicValueAndGradientAtCells(c, grad);
    for (int a = 0; a < 3; ++a) {
      Vec<3> e = Vec<3>::Zero();
      e[a] = 1e-5;
      const double fd = (g.cubicValueAtCells(c + e) - g.cubicValueAtCells(c - e)) / 2e-5;
      EXPECT_NEAR(grad[a], fd, 1e-6 + 1e-5 * std::abs(fd));
    }
  }
}

// The gradient modes share one gather of the stencil: value and gradient
// are, bit for bit, the value-only look-up's and the tensor-product sums
// formed separately (x derivatives of the rows, then the y and z weights),
// and the Below mode gives the gradient exactly where the value is below
// the threshold.
TEST(Grid, CubicGradientModesAgreeBitForBit) {
  const Grid<3> g = sampled(Grid<3>::covering(Box<3>{Vec<3>::Constant(-0.5), Vec<3>::Constant(0.5)}, 0.1, 2),
                            [](const Vec<3>& x) { return x.norm() - 0.4 + 0.03 * std::sin(7.0 * x[1] - 3.0 * x[0]); });
  std::mt19937 rng(23);
  int below = 0;
  for (int k = 0; k < 2000; ++k) {
    const Vec<3> c = pointInBox(g, rng, 0.0);  // border cells too (clamped stencils)
    // The sums formed one by one.
    double w[3][4], d[3][4];
    int cell[3];
    for (int a = 0; a < 3; ++a) {
      cell[a] = std::clamp(int(c[a]), 0, g.dims()[a] - 2);
      detail::catmullRomWeights(c[a] - cell[a], w[a]);
      detail::catmullRomDerivatives(c[a] - cell[a], d[a]);
    }
    const auto at = [&](int i, int j, int l) {
      Index<3> n(std::clamp(cell[0] + i - 1, 0, g.dims()[0] - 1), std::clamp(cell[1] + j - 1, 0, g.dims()[1] - 1),
                 std::clamp(cell[2] + l - 1, 0, g.dims()[2] - 1));
      return double(g.at(n));
    };
    double row[4][4], plane[4], expected[3] = {0.0, 0.0, 0.0};
    for (int l = 0; l < 4; ++l) {
      double px = 0.0;
      for (int j = 0; j < 4; ++j) {
        row[l][j] = w[0][0] * at(0, j, l) + w[0][1] * at(1, j, l) + w[0][2] * at(2, j, l) + w[0][3] * at(3, j, l);
        px += w[1][j] * (d[0][0] * at(0, j, l) + d[0][1] * at(1, j, l) + d[0][2] * at(2, j, l) + d[0][3] * at(3, j, l));
      }
      plane[l] = w[1][0] * row[l][0] + w[1][1] * row[l][1] + w[1][2] * row[l][2] + w[1][3] * row[l][3];
      expected[0] += w[2][l] * px;
      expected[1] += w[2][l] * (d[1][0] * row[l][0] + d[1][1] * row[l][1] + d[1][2] * row[l][2] + d[1][3] * row[l][3]);
    }
    expected[2] = d[2][0] * plane[0] + d[2][1] * plane[1] + d[2][2] * plane[2] + d[2][3] * plane[3];
    const double value = w[2][0] * plane[0] + w[2][1] * plane[1] + w[2][2] * plane[2] + w[2][3] * plane[3];
    Vec<3> always, some = Vec<3>::Constant(7.0);
    ASSERT_EQ(g.cubicValueAndGradientAtCells(c, always), value);
    ASSERT_EQ(g.cubicValueAtCells(c), value);
    for (int a = 0; a < 3; ++a) ASSERT_EQ(always[a], expected[a]) << "axis " << a;
    ASSERT_EQ(g.cubicValueAtCellsGradientBelow(c, 0.0, some), value);
    if (value < 0.0) {
      ++below;
      ASSERT_EQ(some, always);
    } else {
      ASSERT_EQ(some, Vec<3>::Constant(7.0));  // left as it was
    }
  }
  EXPECT_GT(below, 100);
}

// On a sphere's signed distance near the surface the multilinear
// interpolant's error falls like h^2 (~h^2 / (8 R) per curved direction),
// the Catmull-Rom one's at least like h^3. Measured at R / h = 5, 10:
// trilinear 6.05e-3 -> 1.36e-3 (order 2.15), tricubic 2.94e-4 -> 3.15e-5
// (order 3.22).
TEST(Grid, CubicErrorOnASphereIsThirdOrder) {
  const double R = 0.5;
  const double linear5 = sphereError(R, R / 5, false), linear10 = sphereError(R, R / 10, false);
  const double cubic5 = sphereError(R, R / 5, true), cubic10 = sphereError(R, R / 10, true);
  const double linearOrder = std::log2(linear5 / linear10), cubicOrder = std::log2(cubic5 / cubic10);
  std::printf("sphere error: trilinear %.2e -> %.2e (order %.2f), tricubic %.2e -> %.2e (order %.2f)\n", linear5,
              linear10, linearOrder, cubic5, cubic10, cubicOrder);
  EXPECT_NEAR(linearOrder, 2.0, 0.3);
  EXPECT_GE(cubicOrder, 3.0);
  EXPECT_LT(cubic5, 0.2 * linear5);
}

// cubicDeviationBounds bounds |cubic - multilinear| in every cell, border
// cells (clamped stencils) included.
TEST(Grid, CubicDeviationBoundHolds) {
  const Grid<3> g = sampled(Grid<3>::covering(Box<3>{Vec<3>::Constant(-0.5), Vec<3>::Constant(0.5)}, 0.1, 2),
                            [](const Vec<3>& x) { return x.norm() - 0.5 + 0.05 * std::sin(13.0 * x[1]); });
  const std::vector<float> bound = g.cubicDeviationBounds();
  ASSERT_EQ(bound.size(), g.size());
  std::mt19937 rng(9);
  double tightest = 1e30;
  for (int k = 0; k < 20000; ++k) {
    const Vec<3> c = pointInBox(g, rng, 0.0);
    Index<3> cell;
    for (int a = 0; a < 3; ++a) cell[a] = std::min(int(c[a]), g.dims()[a] - 2);
    const double e = bound[g.linear(cell)];
    const double deviation = std::abs(g.cubicValueAtCells(c) - g.valueAtCells(c));
    ASSERT_LE(deviation, e) << "cell " << cell.transpose();
    tightest = std::min(tightest, e - deviation);
  }
  EXPECT_GE(tightest, 0.0);
}

// The batched look-up (two points per instruction where the target has
// SSE2) gives valueAtCells' values bit for bit: inside cells, on cell faces
// and nodes, on the box's faces and its upper border (the last cell), for
// an odd count (the last point alone) and for none; the batched look-up
// with gradients gives valueAndGradientAtCells' values and gradients. A
// sign-changing, non-linear field, so every corner weight matters.
template <int D>
void checkBatchedLookupsAgree() {
  Index<D> dims;
  for (int a = 0; a < D; ++a) dims[a] = 5 + 2 * a;
  const Grid<D> g = sampled(Grid<D>(dims, Vec<D>::Constant(-0.7), 0.15),
                            [](const Vec<D>& x) { return x.squaredNorm() - 0.3 + 0.2 * std::sin(7.0 * x[0]); });
  std::mt19937 rng(5);
  std::vector<Vec<D>> points;
  for (int k = 0; k < 301; ++k) points.push_back(pointInBox(g, rng, 0.0));
  for (int k = 0; k < 40; ++k) {
    Vec<D> p = pointInBox(g, rng, 0.0);
    const int a = k % D;
    p[a] = k % 3 == 0 ? 0.0 : k % 3 == 1 ? double(dims[a] - 1) : std::floor(p[a]);  // faces, the upper border, a node plane
    points.push_back(p);
  }
  std::vector<double> batched(points.size(), -1.0);
  g.valuesAtCells(points.data(), points.size(), batched.data());
  for (std::size_t j = 0; j < points.size(); ++j) {
    ASSERT_EQ(batched[j], g.valueAtCells(points[j])) << "point " << j << " at " << points[j].transpose();
  }
  double untouched = 7.0;
  g.valuesAtCells(points.data(), 0, &untouched);
  EXPECT_EQ(untouched, 7.0);
  // With the gradients: valueAndGradientAtCells' value and gradient bit for
  // bit, also written over the points themselves (as the narrow phase does).
  std::vector<Vec<D>> grads(points.size(), Vec<D>::Constant(-1.0)), inPlace = points;
  std::vector<double> values(points.size(), -1.0), valuesInPlace(points.size(), -1.0);
  g.valuesAndGradientsAtCells(points.data(), points.size(), values.data(), grads.data());
  g.valuesAndGradientsAtCells(inPlace.data(), inPlace.size(), valuesInPlace.data(), inPlace.data());
  for (std::size_t j = 0; j < points.size(); ++j) {
    Vec<D> grad;
    const double value = g.valueAndGradientAtCells(points[j], grad);
    ASSERT_EQ(values[j], value) << "point " << j;
    ASSERT_EQ(valuesInPlace[j], value) << "point " << j;
    for (int a = 0; a < D; ++a) {
      ASSERT_EQ(grads[j][a], grad[a]) << "point " << j << " axis " << a;
      ASSERT_EQ(inPlace[j][a], grad[a]) << "point " << j << " axis " << a << " (in place)";
    }
  }
}
TEST(Grid, BatchedLookupsAgreeBitForBit2D) { checkBatchedLookupsAgree<2>(); }
TEST(Grid, BatchedLookupsAgreeBitForBit3D) { checkBatchedLookupsAgree<3>(); }
