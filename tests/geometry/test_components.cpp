#include "lsdem/geometry/Components.h"
#include "lsdem/geometry/Csg.h"
#include "lsdem/geometry/MassProperties.h"
#include "lsdem/geometry/Primitives.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#ifdef LSDEM_HAVE_OPENMP
#include <omp.h>
#endif

using namespace lsdem::geometry;

namespace {

// A grid covering `box` with spacing h (4 cells of padding), sampled from f(world point).
template <int D, class F>
Grid<D> sampled(const Box<D>& box, double h, F f) {
  return sampleGrid<D>(box, h, kDefaultPaddingCells, f);
}
// Dumbbell along x: balls of radius 0.3 at x = +-0.5 joined by a neck (a bar
// of half width 0.1 in 2D, a cylinder of radius 0.1 in 3D), as the union (min) of the parts.
template <int D>
double dumbbell(const Vec<D>& x) {
  Vec<D> c = Vec<D>::Zero();
  c[0] = 0.5;
  const double balls = std::min((x - c).norm(), (x + c).norm()) - 0.3;
  double neck;
  if constexpr (D == 2) {
    neck = sdfBox<2>(x, Vec<2>(0.5, 0.1));
  } else {
    // Capped cylinder: axial and radial excess.
    const Vec<2> q(std::abs(x[0]) - 0.5, std::hypot(x[1], x[2]) - 0.1);
    neck = q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
  }
  return std::min(balls, neck);
}

// A slab |x - x0| < w across the x axis.
template <int D>
SignedDistance<D> slab(double x0, double w) {
  return [x0, w](const Vec<D>& x) { return std::abs(x[0] - x0) - w; };
}

// Nodes of `piece` that also are nodes of `grid` (same spacing, node-aligned): index in grid, or -1.
template <int D>
std::int64_t sharedNode(const Grid<D>& grid, const Grid<D>& piece, std::size_t m) {
  const Vec<D> g = grid.toGrid(piece.nodePosition(piece.unlinear(m)));
  Index<D> i;
  for (int a = 0; a < D; ++a) {
    i[a] = int(std::lround(g[a]));
    EXPECT_NEAR(g[a], double(i[a]), 1e-6);  // node-aligned
  }
  return grid.inBounds(i) ? std::int64_t(grid.linear(i)) : -1;
}

// Checks the pieces of `grid`: one component each, own nodes equal to the
// input, volumes adding up to the input's; returns the pieces' volumes.
template <int D>
std::vector<double> checkPieces(const Grid<D>& grid, const std::vector<Grid<D>>& pieces) {
  std::vector<int> labels;
  const int count = labelComponents(grid, labels);
  EXPECT_EQ(std::size_t(count), pieces.size());
  std::vector<double> volumes;
  double sum = 0.0;
  for (std::size_t k = 0; k < pieces.size(); ++k) {
    const Grid<D>& piece = pieces[k];
    EXPECT_EQ(piece.spacing(), grid.spacing());
    std::vector<int> own;
    EXPECT_EQ(labelComponents(piece, own), 1) << "piece " << k;
    std::size_t inside = 0;
    for (std::size_t m = 0; m < piece.size(); ++m) {
      const std::int64_t n = sharedNode(grid, piece, m);
      const bool mine = n >= 0 && labels[std::size_t(n)] == int(k);
      // Inside exactly on the component's own nodes, with the input's values there.
      EXPECT_EQ(piece[m] < 0.0f, mine) << "piece " << k << " node " << m;
      if (mine) {
        EXPECT_EQ(piece[m], grid[std::size_t(n)]);
        ++inside;
      }
    }
    EXPECT_EQ(inside, std::size_t(std::count(labels.begin(), labels.end(), int(k))));
    volumes.push_back(massProperties(piece).volume);
    sum += volumes.back();
  }
  const double whole = massProperties(grid).volume;
  EXPECT_NEAR(sum, whole, 1e-3 * whole);
  std::printf("%zu pieces, volume sum / whole - 1 = %.2e\n", pieces.size(), sum / whole - 1.0);
  return volumes;
}

}  // namespace

// A dumbbell cut through its neck by a slab: two components of half the volume each.
TEST(Components, DumbbellCutThroughNeck2D) {
  const Grid<2> grain = sampled<2>(Box<2>{Vec<2>(-0.8, -0.3), Vec<2>(0.8, 0.3)}, 0.02, dumbbell<2>);
  ASSERT_EQ(connectedComponents(grain).size(), 1u);
  const Grid<2> cut = csgDifference(grain, slab<2>(0.0, 0.05));  // faces between node layers
  const std::vector<Grid<2>> pieces = connectedComponents(cut);
  ASSERT_EQ(pieces.size(), 2u);
  const std::vector<double> v = checkPieces(cut, pieces);
  const double whole = massProperties(cut).volume;
  EXPECT_NEAR(v[0], 0.5 * whole, 1e-3 * whole);
  EXPECT_NEAR(v[1], 0.5 * whole, 1e-3 * whole);
  // Each piece is centred on its own ball side.
  EXPECT_LT(massProperties(pieces[0]).centroid[0] * massProperties(pieces[1]).centroid[0], 0.0);
}

TEST(Components, DumbbellCutThroughNeck3D) {
  const Grid<3> grain = sampled<3>(Box<3>{Vec<3>(-0.8, -0.3, -0.3), Vec<3>(0.8, 0.3, 0.3)}, 0.03, dumbbell<3>);
  const Grid<3> cut = csgDifference(grain, slab<3>(0.0, 0.0605));  // faces between node layers
  const std::vector<Grid<3>> pieces = connectedComponents(cut);
  ASSERT_EQ(pieces.size(), 2u);
  const std::vector<double> v = checkPieces(cut, pieces);
  const double whole = massProperties(cut).volume;
  EXPECT_NEAR(v[0], 0.5 * whole, 1e-3 * whole);
  EXPECT_NEAR(v[1], 0.5 * whole, 1e-3 * whole);
  // Analytic: a ball plus the neck piece outside it, from x = 0.0605 to the ball's
  // surface at x = 0.5 - sqrt(0.09 - rho^2), integrated over the neck's disc.
  const double pi = std::numbers::pi;
  const double half = 4.0 / 3.0 * pi * 0.027 + pi * 0.01 * (0.5 - 0.0605) - 2.0 * pi / 3.0 * (std::pow(0.09, 1.5) - std::pow(0.08, 1.5));
  EXPECT_NEAR(v[0], half, 5e-3 * half);
  EXPECT_NEAR(v[1], half, 5e-3 * half);
  std::printf("3D dumbbell half: piece %.6f, whole/2 %.6f, analytic %.6f\n", v[0], 0.5 * whole, half);
}

// A crescent (a C-shaped, concave grain) cut across both arms: the back and two horns.
TEST(Components, CrescentCutAcrossBothArms) {
  const Grid<2> disc = sampled<2>(Box<2>{Vec<2>(-0.5, -0.5), Vec<2>(0.5, 0.5)}, 0.01, [](const Vec<2>& x) { return x.norm() - 0.5; });
  const Grid<2> crescent = csgDifference<2>(disc, [](const Vec<2>& x) { return (x - Vec<2>(0.3, 0.0)).norm() - 0.4; });
  ASSERT_EQ(connectedComponents(crescent).size(), 1u);
  const Grid<2> cut = csgDifference(crescent, slab<2>(-0.05, 0.0305));
  std::vector<int> labels;
  ASSERT_EQ(labelComponents(cut, labels), 3);
  // Numbered by their lowest linear node index.
  std::vector<std::size_t> first(3, cut.size());
  for (std::size_t n = cut.size(); n-- > 0;) {
    if (labels[n] >= 0) first[std::size_t(labels[n])] = n;
  }
  EXPECT_LT(first[0], first[1]);
  EXPECT_LT(first[1], first[2]);
  const std::vector<Grid<2>> pieces = connectedComponents(cut);
  const std::vector<double> v = checkPieces(cut, pieces);
  // The two horns are mirror images about y = 0; the back is the largest.
  std::vector<double> sorted = v;
  std::sort(sorted.begin(), sorted.end());
  EXPECT_NEAR(sorted[0], sorted[1], 2e-3 * sorted[1]);
  EXPECT_GT(sorted[2], sorted[1]);
}

TEST(Components, EmptyGridHasNone) {
  const Grid<3> empty(Index<3>(5, 6, 7), Vec<3>::Zero(), 0.1, 0.5f);
  std::vector<int> labels{7, 7};
  EXPECT_EQ(labelComponents(empty, labels), 0);
  EXPECT_EQ(labels.size(), empty.size());
  EXPECT_EQ(std::count(labels.begin(), labels.end(), -1), std::ptrdiff_t(empty.size()));
  EXPECT_TRUE(connectedComponents(empty).empty());
  // phi == 0 is outside.
  const Grid<2> zero(Index<2>(4, 4), Vec<2>::Zero(), 0.1, 0.0f);
  EXPECT_TRUE(connectedComponents(zero).empty());
  EXPECT_TRUE(connectedComponents(Grid<2>()).empty());
}

// A single sphere: one component whose values equal the input's at every shared node.
TEST(Components, SingleShapeKeepsItsValues) {
  const Vec<3> c(0.013, -0.021, 0.007);
  const Grid<3> ball = sampled<3>(Box<3>{c - Vec<3>::Constant(0.5), c + Vec<3>::Constant(0.5)}, 0.05,
                                  [&](const Vec<3>& x) { return (x - c).norm() - 0.5; });
  const std::vector<Grid<3>> pieces = connectedComponents(ball);
  ASSERT_EQ(pieces.size(), 1u);
  std::size_t shared = 0;
  for (std::size_t m = 0; m < pieces[0].size(); ++m) {
    const std::int64_t n = sharedNode(ball, pieces[0], m);
    if (n < 0) continue;
    EXPECT_EQ(pieces[0][m], ball[std::size_t(n)]) << "node " << m;
    ++shared;
  }
  EXPECT_GT(shared, pieces[0].size() / 2);
  EXPECT_NEAR(massProperties(pieces[0]).volume, massProperties(ball).volume, 1e-12);
}

// Pieces that touch only diagonally are separate; each sees the other as outside.
TEST(Components, DiagonalNeighboursAreSeparate) {
  Grid<2> g(Index<2>(7, 7), Vec<2>(0.0, 0.0), 0.5, 1.0f);
  g.at(Index<2>(2, 2)) = -0.2f;
  g.at(Index<2>(3, 3)) = -0.3f;
  g.at(Index<2>(3, 4)) = -0.1f;
  std::vector<int> labels;
  ASSERT_EQ(labelComponents(g, labels), 2);
  EXPECT_EQ(labels[g.linear(Index<2>(2, 2))], 0);
  EXPECT_EQ(labels[g.linear(Index<2>(3, 3))], 1);
  EXPECT_EQ(labels[g.linear(Index<2>(3, 4))], 1);
  const std::vector<Grid<2>> pieces = connectedComponents(g, 1);
  ASSERT_EQ(pieces.size(), 2u);
  // Piece 0: nodes (1..3, 1..3); the other component's node (3, 3) at distance h sqrt(2) -> h (sqrt(2) - 1).
  EXPECT_TRUE((pieces[0].dims() == Index<2>(3, 3)).all());
  EXPECT_EQ(pieces[0].origin(), g.nodePosition(Index<2>(1, 1)));
  EXPECT_EQ(pieces[0].at(Index<2>(1, 1)), -0.2f);
  EXPECT_FLOAT_EQ(pieces[0].at(Index<2>(2, 2)), float(0.5 * (std::sqrt(2.0) - 1.0)));
  // Exterior nodes keep phi = 1 (larger than the distance bound here).
  EXPECT_EQ(pieces[0].at(Index<2>(0, 0)), 1.0f);
  // Piece 1: nodes (2..4, 2..5).
  EXPECT_TRUE((pieces[1].dims() == Index<2>(3, 4)).all());
  EXPECT_EQ(pieces[1].at(Index<2>(1, 1)), -0.3f);
  EXPECT_EQ(pieces[1].at(Index<2>(1, 2)), -0.1f);
  EXPECT_FLOAT_EQ(pieces[1].at(Index<2>(0, 0)), float(0.5 * (std::sqrt(2.0) - 1.0)));
}

// Away from the shape the exterior values are max(phi, d - h sqrt(D)) with d
// the exact Euclidean distance to the component's nodes (checked by brute force).
TEST(Components, ExteriorUsesExactDistanceToComponent) {
  Grid<3> g(Index<3>(14, 12, 10), Vec<3>(-1.0, 0.5, 0.0), 0.1, 0.0f);
  const std::vector<Index<3>> seeds = {Index<3>(5, 5, 5), Index<3>(6, 5, 5), Index<3>(6, 6, 5), Index<3>(6, 6, 6),
                                       Index<3>(6, 7, 6), Index<3>(7, 7, 6)};
  for (const Index<3>& s : seeds) g.at(s) = -0.05f;
  const std::vector<Grid<3>> pieces = connectedComponents(g, 3);
  ASSERT_EQ(pieces.size(), 1u);
  const Grid<3>& p = pieces[0];
  EXPECT_TRUE((p.dims() == Index<3>(9, 9, 8)).all());
  for (std::size_t m = 0; m < p.size(); ++m) {
    const Vec<3> x = p.nodePosition(p.unlinear(m));
    double d = 1e9;
    for (const Index<3>& s : seeds) d = std::min(d, (x - g.nodePosition(s)).norm());
    const double expected = (d < 1e-9) ? -0.05 : std::max(0.0, d - 0.1 * std::sqrt(3.0));
    EXPECT_NEAR(p[m], expected, 1e-6) << "node " << m;
  }
}

// A one-node component with no padding still makes a valid grid (2 nodes per axis).
TEST(Components, TinyComponentAndBadPadding) {
  Grid<2> g(Index<2>(5, 5), Vec<2>::Zero(), 1.0, 2.0f);
  g.at(Index<2>(4, 4)) = -0.5f;
  const std::vector<Grid<2>> pieces = connectedComponents(g, 0);
  ASSERT_EQ(pieces.size(), 1u);
  EXPECT_TRUE((pieces[0].dims() == Index<2>(2, 2)).all());
  EXPECT_EQ(pieces[0].at(Index<2>(0, 0)), -0.5f);
  // The node beyond the input's box takes the outside extension: phi(corner) + distance, raised by the bound.
  EXPECT_GT(pieces[0].at(Index<2>(1, 1)), 0.0f);
  EXPECT_THROW(connectedComponents(g, -1), std::invalid_argument);
}

// Bitwise identical pieces for 1 and 2 threads.
TEST(Components, DeterministicAcrossThreadCounts) {
  const Grid<3> grain = sampled<3>(Box<3>{Vec<3>(-0.8, -0.3, -0.3), Vec<3>(0.8, 0.3, 0.3)}, 0.04, dumbbell<3>);
  const Grid<3> cut = csgDifference(grain, slab<3>(0.013, 0.07));
#ifdef LSDEM_HAVE_OPENMP
  const int saved = omp_get_max_threads();
  omp_set_num_threads(1);
#endif
  const std::vector<Grid<3>> one = connectedComponents(cut);
#ifdef LSDEM_HAVE_OPENMP
  omp_set_num_threads(2);
#endif
  const std::vector<Grid<3>> two = connectedComponents(cut);
#ifdef LSDEM_HAVE_OPENMP
  omp_set_num_threads(saved);
#endif
  ASSERT_EQ(one.size(), 2u);
  ASSERT_EQ(two.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_TRUE(one[k].values() == two[k].values());
    EXPECT_EQ(one[k].origin(), two[k].origin());
  }
}
