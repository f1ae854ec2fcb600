#include "support/Sampling.h"
#include "lsdem/geometry/SurfaceNodes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <limits>
#include <numbers>
#include <random>

#ifdef LSDEM_HAVE_OPENMP
#include <omp.h>
#endif

using namespace lsdem::geometry;
using lsdem::test::sampled;
using lsdem::test::boxAround;

namespace {

constexpr double kPi = std::numbers::pi;


// Ramanujan's second approximation of an ellipse's perimeter.
double ellipsePerimeter(double a, double b) {
  const double h = (a - b) * (a - b) / ((a + b) * (a + b));
  return kPi * (a + b) * (1 + 3 * h / (10 + std::sqrt(4 - 3 * h)));
}

// Surface area of an ellipsoid with semi-axes a, b, c by midpoint quadrature
// of |r_u x r_v| over the (polar, azimuth) parametrisation, fine enough for ~1e-6.
double ellipsoidArea(double a, double b, double c) {
  const int nu = 800, nv = 1600;
  double sum = 0;
  for (int i = 0; i < nu; ++i) {
    const double u = kPi * (i + 0.5) / nu;
    for (int j = 0; j < nv; ++j) {
      const double v = 2 * kPi * (j + 0.5) / nv;
      const Vec<3> ru(a * std::cos(u) * std::cos(v), b * std::cos(u) * std::sin(v), -c * std::sin(u));
      const Vec<3> rv(-a * std::sin(u) * std::sin(v), b * std::sin(u) * std::cos(v), 0.0);
      sum += ru.cross(rv).norm();
    }
  }
  return sum * (kPi / nu) * (2 * kPi / nv);
}

// Approximate distance to the implicit surface f = 0: f / |grad f|.
template <int D>
double ellipsoidDistance(const Vec<D>& x, const Vec<D>& semi) {
  const Vec<D> q = x.cwiseQuotient(semi);
  const double f = q.squaredNorm() - 1.0;
  const Vec<D> grad = 2.0 * q.cwiseQuotient(semi);
  return f / grad.norm();
}

// Largest distance from a node to its nearest other node (brute force).
template <int D>
double maxNearestNeighbour(const NodeSet<D>& nodes) {
  double worst = 0;
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    double nearest = std::numeric_limits<double>::infinity();
    for (std::size_t j = 0; j < nodes.size(); ++j) {
      if (j != i) nearest = std::min(nearest, (nodes.positions[i] - nodes.positions[j]).squaredNorm());
    }
    worst = std::max(worst, std::sqrt(nearest));
  }
  return worst;
}

}  // namespace

// ---- 2D -------------------------------------------------------------------------

// Circle: weights sum to 2 pi R, nodes on the circle, counts proportional to
// the density, spacing even.
TEST(SurfaceNodes2D, CirclePerimeterCountAndSpacing) {
  const double R = 1.0, h = 0.1;
  const Vec<2> c(0.017, -0.031);
  const Grid<2> g = sampled<2>(Box<2>{c - Vec<2>::Constant(R), c + Vec<2>::Constant(R)}, h,
                              [&](const Vec<2>& x) { return (x - c).norm() - R; });
  std::size_t previousCount = 0;
  for (const double density : {1.0, 2.0, 4.0}) {
    const NodeSet<2> nodes = surfaceNodes(g, density);
    ASSERT_EQ(nodes.weights.size(), nodes.size());
    const double expectedCount = 2 * kPi * R / (h / density);
    std::cout << "circle density " << density << ": " << nodes.size() << " nodes, perimeter error "
              << nodes.totalWeight() / (2 * kPi * R) - 1 << "\n";
    EXPECT_NEAR(double(nodes.size()), expectedCount, 1.0 + 0.01 * expectedCount);
    EXPECT_NEAR(nodes.totalWeight(), 2 * kPi * R, 0.01 * 2 * kPi * R);
    for (const Vec<2>& x : nodes.positions) EXPECT_LT(std::abs((x - c).norm() - R), 0.05 * h);
    // Nodes lie on phi = 0 of the interpolant itself.
    for (const Vec<2>& x : nodes.positions) EXPECT_LT(std::abs(g.value(x)), 1e-6 * h);
    EXPECT_LT(maxNearestNeighbour(nodes), 2.0 * h / density);
    for (const double w : nodes.weights) EXPECT_NEAR(w, h / density, 0.1 * h / density);
    if (previousCount > 0) {
      EXPECT_NEAR(double(nodes.size()) / double(previousCount), 2.0, 0.02);
    }
    previousCount = nodes.size();
  }
}

// Ellipse: weights sum to Ramanujan's perimeter within 1% at densities 1 and 2.
TEST(SurfaceNodes2D, EllipsePerimeter) {
  const Vec<2> semi(1.0, 0.4);
  const double h = 0.05;
  const Grid<2> g = sampled<2>(Box<2>{-semi, semi}, h, [&](const Vec<2>& x) { return ellipsoidDistance<2>(x, semi); });
  for (const double density : {1.0, 2.0}) {
    const NodeSet<2> nodes = surfaceNodes(g, density);
    const double P = ellipsePerimeter(semi[0], semi[1]);
    std::cout << "ellipse density " << density << ": " << nodes.size() << " nodes, perimeter error "
              << nodes.totalWeight() / P - 1 << "\n";
    EXPECT_NEAR(nodes.totalWeight() / P, 1.0, 0.01);
    for (const Vec<2>& x : nodes.positions) EXPECT_LT(std::abs(ellipsoidDistance<2>(x, semi)), 0.05 * h);
    EXPECT_LT(maxNearestNeighbour(nodes), 2.0 * h / density);
  }
}

// Every contour gets nodes: an annulus has nodes on both circles, weights sum
// to both perimeters; a tiny blob still gets 3 nodes.
TEST(SurfaceNodes2D, EveryContourGetsNodes) {
  const double R0 = 0.3, R1 = 0.8, h = 0.05;
  const Grid<2> ring = sampled<2>(Box<2>{Vec<2>::Constant(-R1), Vec<2>::Constant(R1)}, h,
                                 [&](const Vec<2>& x) { return std::max(x.norm() - R1, R0 - x.norm()); });
  const NodeSet<2> nodes = surfaceNodes(ring, 1.0);
  EXPECT_NEAR(nodes.totalWeight(), 2 * kPi * (R0 + R1), 0.01 * 2 * kPi * (R0 + R1));
  int inner = 0;
  for (const Vec<2>& x : nodes.positions) inner += x.norm() < 0.5 * (R0 + R1) ? 1 : 0;
  EXPECT_NEAR(inner, 2 * kPi * R0 / h, 2);

  Grid<2> blob(Index<2>(5, 5), Vec<2>::Zero(), 1.0, 1.0f);
  blob.at(Index<2>(2, 2)) = -0.1f;
  EXPECT_EQ(surfaceNodes(blob, 1.0).size(), 3u);
}

TEST(SurfaceNodes2D, BadDensityAndEmpty) {
  Grid<2> g(Index<2>(4, 4), Vec<2>::Zero(), 1.0, 1.0f);
  EXPECT_TRUE(surfaceNodes(g, 2.0).empty());
  EXPECT_THROW(surfaceNodes(g, 0.0), std::invalid_argument);
  EXPECT_THROW(surfaceNodes(g, -1.0), std::invalid_argument);
  EXPECT_THROW(surfaceNodes(g, std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
  EXPECT_THROW(surfaceNodes(g, std::numeric_limits<double>::infinity()), std::invalid_argument);
}

// ---- 3D -------------------------------------------------------------------------

// Sphere 20 cells across: weights sum to 4 pi R^2, nodes on the sphere, counts
// grow like density^2, spacing even, the returned mesh carries the nodes.
TEST(SurfaceNodes3D, SphereAreaCountAndSpacing) {
  const double R = 1.0, h = 0.1;
  const Vec<3> c(0.013, -0.027, 0.004);
  const Grid<3> g = sampled<3>(Box<3>{c - Vec<3>::Constant(R), c + Vec<3>::Constant(R)}, h,
                              [&](const Vec<3>& x) { return (x - c).norm() - R; });
  std::size_t previousCount = 0;
  for (const double density : {1.0, 2.0}) {
    TriangleMesh mesh;
    const auto start = std::chrono::steady_clock::now();
    const NodeSet<3> nodes = surfaceNodes(g, density, &mesh);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double areaError = nodes.totalWeight() / (4 * kPi * R * R) - 1;
    std::cout << "sphere 20 cells across, density " << density << ": " << nodes.size() << " nodes in "
              << seconds * 1e3 << " ms, area error " << areaError << "\n";
    ASSERT_EQ(nodes.weights.size(), nodes.size());
    EXPECT_LT(std::abs(areaError), 0.01);
    double worstDistance = 0;
    for (const Vec<3>& x : nodes.positions) worstDistance = std::max(worstDistance, std::abs((x - c).norm() - R));
    std::cout << "  max |sdf| at nodes " << worstDistance / h << " h\n";
    EXPECT_LT(worstDistance, 0.05 * h);
    EXPECT_LT(maxNearestNeighbour(nodes), 2.0 * h / density);
    for (const double w : nodes.weights) EXPECT_GT(w, 0.0);
    // The mesh: its vertices are the nodes, its area the weight sum, it is closed.
    ASSERT_EQ(mesh.vertices.size(), nodes.size());
    for (std::size_t v = 0; v < nodes.size(); ++v) EXPECT_EQ(mesh.vertices[v], nodes.positions[v]);
    EXPECT_NEAR(mesh.area(), nodes.totalWeight(), 1e-9);
    EXPECT_NEAR(mesh.signedVolume() / (4.0 / 3.0 * kPi * R * R * R), 1.0, 0.01);
    EXPECT_EQ(mesh.vertices.size() + mesh.faces.size() - 3 * mesh.faces.size() / 2, 2u);  // chi = 2
    // Count: area / (equilateral triangle of the target edge) / 2 vertices, within 30%.
    const double target = h / density;
    const double expectedCount = 4 * kPi * R * R / (std::sqrt(3.0) / 4 * target * target) / 2;
    EXPECT_NEAR(double(nodes.size()) / expectedCount, 1.0, 0.3);
    if (previousCount > 0) {
      EXPECT_NEAR(double(nodes.size()) / double(previousCount), 4.0, 0.4);
    }
    previousCount = nodes.size();
  }
}

// Ellipsoid: weights sum to the area from fine quadrature within 1%.
TEST(SurfaceNodes3D, EllipsoidArea) {
  const Vec<3> semi(1.0, 0.7, 0.45);
  const double h = 0.04;
  const Grid<3> g = sampled<3>(Box<3>{-semi, semi}, h, [&](const Vec<3>& x) { return ellipsoidDistance<3>(x, semi); });
  const double reference = ellipsoidArea(semi[0], semi[1], semi[2]);
  for (const double density : {1.0, 2.0}) {
    const NodeSet<3> nodes = surfaceNodes(g, density);
    std::cout << "ellipsoid density " << density << ": " << nodes.size() << " nodes, area error "
              << nodes.totalWeight() / reference - 1 << "\n";
    EXPECT_NEAR(nodes.totalWeight() / reference, 1.0, 0.01);
    for (const Vec<3>& x : nodes.positions) EXPECT_LT(std::abs(ellipsoidDistance<3>(x, semi)), 0.05 * h);
  }
}

TEST(SurfaceNodes3D, BadDensityAndEmpty) {
  Grid<3> g(Index<3>(4, 4, 4), Vec<3>::Zero(), 1.0, 1.0f);
  TriangleMesh mesh;
  mesh.faces.push_back({0, 0, 0});
  EXPECT_TRUE(surfaceNodes(g, 1.0, &mesh).empty());
  EXPECT_TRUE(mesh.empty());
  EXPECT_THROW(surfaceNodes(g, 0.0), std::invalid_argument);
  EXPECT_THROW(surfaceNodes(g, -2.0), std::invalid_argument);
  EXPECT_THROW(surfaceNodes(g, std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
}

// Same nodes and weights for 1 and 2 threads.
TEST(SurfaceNodes3D, DeterministicAcrossThreads) {
  const Grid<3> g = sampled<3>(Box<3>{Vec<3>::Constant(-0.5), Vec<3>::Constant(0.5)}, 0.1,
                              [](const Vec<3>& x) { return x.norm() - 0.5; });
#ifdef LSDEM_HAVE_OPENMP
  omp_set_num_threads(1);
  const NodeSet<3> one = surfaceNodes(g, 1.5);
  omp_set_num_threads(2);
#else
  const NodeSet<3> one = surfaceNodes(g, 1.5);
#endif
  const NodeSet<3> two = surfaceNodes(g, 1.5);
  ASSERT_EQ(one.size(), two.size());
  EXPECT_EQ(one.weights, two.weights);
  for (std::size_t i = 0; i < one.size(); ++i) EXPECT_EQ(one.positions[i], two.positions[i]);
}

// A random field (many small, odd-shaped components, some one node big) is
// handled: finite nodes, weights summing to the mesh area, and nearly all nodes
// on phi = 0 (where the piecewise-linear marching surface and the trilinear
// interpolant disagree in topology, a node stops at the closest approach).
TEST(SurfaceNodes3D, RandomFieldIsHandled) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.3, 1.0);
  Grid<3> g(Index<3>(10, 9, 8), Vec<3>::Zero(), 0.1);
  for (std::size_t n = 0; n < g.size(); ++n) g[n] = float(0.1 * u(rng));
  for (const double density : {0.5, 1.0, 3.0}) {
    TriangleMesh mesh;
    const NodeSet<3> nodes = surfaceNodes(g, density, &mesh);
    ASSERT_FALSE(nodes.empty());
    EXPECT_NEAR(nodes.totalWeight(), mesh.area(), 1e-9);
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      ASSERT_TRUE(nodes.positions[i].allFinite());
      EXPECT_GE(nodes.weights[i], 0.0);
    }
    int offSurface = 0;
    double worst = 0;
    for (const Vec<3>& x : nodes.positions) {
      offSurface += std::abs(g.value(x)) > 1e-3 * g.spacing() ? 1 : 0;
      worst = std::max(worst, std::abs(g.value(x)) / g.spacing());
    }
    std::cout << "random field density " << density << ": " << nodes.size() << " nodes, " << offSurface
              << " not on phi = 0 (worst |phi| " << worst << " h)\n";
    EXPECT_LT(offSurface, int(nodes.size()) / 10);
    EXPECT_LT(worst, 0.5);
  }
}
