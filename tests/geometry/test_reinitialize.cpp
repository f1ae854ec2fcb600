#include "lsdem/geometry/Reinitialize.h"

#include "lsdem/geometry/Primitives.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <iostream>
#include <limits>

#ifdef LSDEM_HAVE_OPENMP
#include <omp.h>
#endif

using namespace lsdem::geometry;

namespace {

// Fills a grid with f(node position).
template <int D, class F>
Grid<D> filled(Grid<D> g, F f) {
  for (std::size_t n = 0; n < g.size(); ++n) g[n] = float(f(g.nodePosition(g.unlinear(n))));
  return g;
}

// A grid of exactly `cells` nodes per axis, centred on the origin.
template <int D>
Grid<D> centredGrid(int cells, double h) {
  return Grid<D>(Index<D>::Constant(cells), Vec<D>::Constant(-0.5 * (cells - 1) * h), h);
}

// Error measures of a reinitialised grid against the exact signed distance, in cells.
struct Errors {
  double interface = 0.0;    // nodes with a face neighbour of the other sign
  double nearSurface = 0.0;  // |exact| < 2h
  double gradient = 0.0;     // max ||grad phi| - 1| by central differences, |exact| < 3h
  double outside = 0.0;      // every node with exact > 0 (smooth there for convex shapes)
  double all = 0.0;          // every node
  bool signsKept = true;     // sign(phi) == sign(input) at every node
};

template <int D>
Errors measure(const Grid<D>& before, const Grid<D>& after, const std::function<double(const Vec<D>&)>& exact) {
  Errors e;
  const double h = after.spacing();
  for (std::size_t n = 0; n < after.size(); ++n) {
    const Index<D> i = after.unlinear(n);
    const double ex = exact(after.nodePosition(i));
    const double err = std::abs(after[n] - ex) / h;
    e.all = std::max(e.all, err);
    if (ex > 0.0) e.outside = std::max(e.outside, err);
    if (std::abs(ex) < 2.0 * h) e.nearSurface = std::max(e.nearSurface, err);
    if ((after[n] < 0.0f) != (before[n] < 0.0f)) e.signsKept = false;
    bool interface = false;
    for (int a = 0; a < D; ++a) {
      for (int s : {-1, 1}) {
        Index<D> j = i;
        j[a] += s;
        if (before.inBounds(j) && ((before.at(j) < 0.0f) != (before[n] < 0.0f))) interface = true;
      }
    }
    if (interface) e.interface = std::max(e.interface, err);
    if (std::abs(ex) < 3.0 * h && (i > 0).all() && (i < after.dims() - 1).all()) {
      Vec<D> g;
      for (int a = 0; a < D; ++a) {
        Index<D> p = i, m = i;
        ++p[a];
        --m[a];
        g[a] = (double(after.at(p)) - double(after.at(m))) / (2.0 * h);
      }
      e.gradient = std::max(e.gradient, std::abs(g.norm() - 1.0));
    }
  }
  return e;
}

void print(const char* name, const Errors& e) {
  std::cout << name << ": interface " << e.interface << " h, |phi| < 2h " << e.nearSurface << " h, max ||grad|-1| "
            << e.gradient << ", outside " << e.outside << " h, all " << e.all << " h\n";
}

// The acceptance thresholds every smooth convex case must meet.
void expectAccurate(const Errors& e) {
  EXPECT_TRUE(e.signsKept);
  EXPECT_LT(e.interface, 0.01);
  EXPECT_LT(e.nearSurface, 0.05);
  EXPECT_LT(e.gradient, 0.02);
}

// Ellipse x^2/a^2 + y^2/b^2 - 1: right zero set, values far from distances.
Errors ellipseCase(ReinitMethod method, double h) {
  const Vec<2> axes(1.0, 0.6);
  Grid<2> input = filled(Grid<2>::covering(Box<2>{-axes, axes}, h, 6), [&](const Vec<2>& x) {
    return (x[0] / axes[0]) * (x[0] / axes[0]) + (x[1] / axes[1]) * (x[1] / axes[1]) - 1.0;
  });
  Grid<2> g = input;
  reinitialize(g, method);
  return measure<2>(input, g, [&](const Vec<2>& x) { return sdfEllipsoid<2>(x, axes); });
}

// Sphere distance times 1 + 0.5 sin(..): right zero set, gradient off by up to 50%.
Grid<3> modulatedSphere(double radius, int cells, double h) {
  return filled(centredGrid<3>(cells, h), [&](const Vec<3>& x) {
    return (x.norm() - radius) *
           (1.0 + 0.5 * std::sin(3.0 * x[0] + 1.0) * std::sin(2.0 * x[1] - 0.5) * std::cos(4.0 * x[2]));
  });
}

}  // namespace

TEST(Reinitialize, EllipseFastSweeping) {
  const Errors e = ellipseCase(ReinitMethod::FastSweeping, 0.02);
  print("ellipse, fast sweeping", e);
  expectAccurate(e);
  // Far nodes are distances too: outside the ellipse (no medial axis there)
  // and over the whole grid (the interior medial axis included).
  EXPECT_LT(e.outside, 0.1);
  EXPECT_LT(e.all, 0.5);
}

TEST(Reinitialize, EllipsePde) {
  const Errors e = ellipseCase(ReinitMethod::Pde, 0.02);
  print("ellipse, PDE", e);
  expectAccurate(e);
  EXPECT_LT(e.outside, 0.1);
  EXPECT_LT(e.all, 0.5);
}

// The error near the surface falls at second order with the spacing.
TEST(Reinitialize, SecondOrderNearTheSurface) {
  const double coarse = ellipseCase(ReinitMethod::FastSweeping, 0.04).nearSurface * 0.04;
  const double fine = ellipseCase(ReinitMethod::FastSweeping, 0.02).nearSurface * 0.02;
  const double finer = ellipseCase(ReinitMethod::FastSweeping, 0.01).nearSurface * 0.01;
  const double order1 = std::log2(coarse / fine), order2 = std::log2(fine / finer);
  std::cout << "world-unit errors within 2h: " << coarse << ", " << fine << ", " << finer << "; orders " << order1
            << ", " << order2 << "\n";
  EXPECT_GT(order1, 1.7);
  EXPECT_GT(order2, 1.7);
}

TEST(Reinitialize, ModulatedSphereFastSweeping64Cubed) {
  const double radius = 0.5, h = 1.0 / 56.0;  // 28 cells of radius, 64^3 nodes
  const Grid<3> input = modulatedSphere(radius, 64, h);
  Grid<3> g = input;
  const auto start = std::chrono::steady_clock::now();
  reinitializeFastSweeping(g);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  std::cout << "fast sweeping on 64^3: " << ms << " ms\n";
  const Errors e = measure<3>(input, g, [&](const Vec<3>& x) { return x.norm() - radius; });
  print("modulated sphere, fast sweeping", e);
  expectAccurate(e);
  EXPECT_LT(e.outside, 0.1);
}

TEST(Reinitialize, ModulatedSpherePde) {
  const double radius = 0.5, h = 1.0 / 40.0;
  const Grid<3> input = modulatedSphere(radius, 48, h);
  Grid<3> g = input;
  reinitializePde(g);
  const Errors e = measure<3>(input, g, [&](const Vec<3>& x) { return x.norm() - radius; });
  print("modulated sphere, PDE", e);
  expectAccurate(e);
  EXPECT_LT(e.outside, 0.1);
}

TEST(Reinitialize, QuadraticEllipsoidBothMethods) {
  const Vec<3> axes(0.6, 0.45, 0.35);
  const double h = 0.6 / 24.0;
  const Grid<3> input = filled(Grid<3>::covering(Box<3>{-axes, axes}, h, 5), [&](const Vec<3>& x) {
    return (x.array() / axes.array()).matrix().squaredNorm() - 1.0;
  });
  for (ReinitMethod method : {ReinitMethod::FastSweeping, ReinitMethod::Pde}) {
    Grid<3> g = input;
    reinitialize(g, method);
    const Errors e = measure<3>(input, g, [&](const Vec<3>& x) { return sdfEllipsoid<3>(x, axes); });
    print(method == ReinitMethod::Pde ? "ellipsoid, PDE" : "ellipsoid, fast sweeping", e);
    expectAccurate(e);
  }
}

// A field that already is a signed distance hardly changes.
TEST(Reinitialize, SignedDistanceIsAlmostAFixedPoint) {
  const Grid<2> input = sphereGrid<2>(0.5, 0.02);
  Grid<2> g = input;
  reinitialize(g);
  double maxNear = 0.0;
  for (std::size_t n = 0; n < g.size(); ++n) {
    if (std::abs(input[n]) < 3.0 * 0.02) maxNear = std::max(maxNear, double(std::abs(g[n] - input[n])));
  }
  EXPECT_LT(maxNear, 0.005 * 0.02);
}

// Thread count does not change a single bit (the PDE updates run in parallel).
TEST(Reinitialize, BitwiseIdenticalForAnyThreadCount) {
#ifdef LSDEM_HAVE_OPENMP
  const Grid<3> input = modulatedSphere(0.5, 40, 1.0 / 30.0);
  const int threads = omp_get_max_threads();
  Grid<3> one = input, many = input;
  omp_set_num_threads(1);
  reinitializePde(one, 30);
  reinitializeFastSweeping(one);
  omp_set_num_threads(std::max(2, threads));
  reinitializePde(many, 30);
  reinitializeFastSweeping(many);
  omp_set_num_threads(threads);
  EXPECT_EQ(0, std::memcmp(one.values().data(), many.values().data(), one.bytes()));
#else
  GTEST_SKIP() << "built without OpenMP";
#endif
}

TEST(Reinitialize, RejectsBadInput) {
  // All one sign: no zero level set to keep.
  Grid<2> outside(Index<2>(8, 8), Vec<2>::Zero(), 0.1, 1.0f);
  EXPECT_THROW(reinitialize(outside), std::invalid_argument);
  Grid<2> inside(Index<2>(8, 8), Vec<2>::Zero(), 0.1, -1.0f);
  EXPECT_THROW(reinitialize(inside, ReinitMethod::Pde), std::invalid_argument);
  // Non-finite values.
  Grid<2> g = sphereGrid<2>(0.3, 0.05);
  g[3] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(reinitializeFastSweeping(g), std::invalid_argument);
  // PDE parameters.
  Grid<2> ok = sphereGrid<2>(0.3, 0.05);
  EXPECT_THROW(reinitializePde(ok, -1), std::invalid_argument);
  EXPECT_THROW(reinitializePde(ok, 0, 0.0), std::invalid_argument);
  EXPECT_THROW(reinitializePde(ok, 0, 0.9), std::invalid_argument);
}

// phi == 0 counts as outside: a node exactly on the surface stays at 0.
TEST(Reinitialize, ZeroIsOutsideAndStaysPut) {
  Grid<2> g = filled(Grid<2>(Index<2>(21, 21), Vec<2>(-1.0, -1.0), 0.1), [](const Vec<2>& x) { return 3.0 * x[0]; });
  reinitialize(g);
  for (std::size_t n = 0; n < g.size(); ++n) {
    const double x = g.nodePosition(g.unlinear(n))[0];
    EXPECT_NEAR(g[n], x, 1e-6);
    if (std::abs(x) < 1e-12) {
      EXPECT_EQ(g[n], 0.0f);
    }
  }
}
