#include "lsdem/geometry/RandomGrain.h"

#include "lsdem/geometry/Primitives.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <cmath>
#include <cstring>
#include <iostream>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

#ifdef LSDEM_HAVE_OPENMP
#include <omp.h>
#endif

using namespace lsdem::geometry;

namespace {

constexpr double kPi = std::numbers::pi;

// Smoothed Heaviside H(-phi) of a node, e = 1.5h: the node's share of the inside.
double insideFraction(double phi, double h) {
  const double e = 1.5 * h, x = -phi;
  return x <= -e ? 0.0 : x >= e ? 1.0 : 0.5 * (1.0 + x / e + std::sin(kPi * x / e) / kPi);
}

// Volume (area in 2D) by a smoothed-Heaviside sum over the nodes.
template <int D>
double smoothVolume(const Grid<D>& g) {
  double sum = 0.0;
  for (std::size_t n = 0; n < g.size(); ++n) sum += insideFraction(g[n], g.spacing());
  return sum * std::pow(g.spacing(), D);
}

// sqrt(largest / smallest eigenvalue) of the second moment of the inside about
// its centroid: the long/short axis ratio of an ellipse-like shape.
template <int D>
double axisRatio(const Grid<D>& g) {
  double mass = 0.0;
  Vec<D> first = Vec<D>::Zero();
  Mat<D> second = Mat<D>::Zero();
  for (std::size_t n = 0; n < g.size(); ++n) {
    const double w = insideFraction(g[n], g.spacing());
    if (w == 0.0) continue;
    const Vec<D> x = g.nodePosition(g.unlinear(n));
    mass += w;
    first += w * x;
    second += w * x * x.transpose();
  }
  const Vec<D> c = first / mass;
  const Mat<D> cov = second / mass - c * c.transpose();
  const Vec<D> lambda = Eigen::SelfAdjointEigenSolver<Mat<D>>(cov).eigenvalues();
  return std::sqrt(lambda.maxCoeff() / lambda.minCoeff());
}

// Unit directions: evenly spaced angles in 2D, a Fibonacci sphere in 3D.
template <int D>
std::vector<Vec<D>> directions(int count) {
  std::vector<Vec<D>> dirs;
  for (int k = 0; k < count; ++k) {
    if constexpr (D == 2) {
      const double t = 2.0 * kPi * (k + 0.5) / count;
      dirs.emplace_back(std::cos(t), std::sin(t));
    } else {
      const double z = 1.0 - 2.0 * (k + 0.5) / count;
      const double phi = kPi * (3.0 - std::sqrt(5.0)) * k;
      const double s = std::sqrt(1.0 - z * z);
      dirs.emplace_back(s * std::cos(phi), s * std::sin(phi), z);
    }
  }
  return dirs;
}

// Length of the ray from the centre (the origin) in direction u to the grid border.
template <int D>
double reachAlong(const Grid<D>& g, const Vec<D>& u) {
  double t = std::numeric_limits<double>::infinity();
  for (int a = 0; a < D; ++a) {
    if (u[a] != 0.0) t = std::min(t, (u[a] > 0.0 ? g.bounds().upper[a] : g.bounds().lower[a]) / u[a]);
  }
  return t;
}

// Sign changes of the interpolated level set along the ray from the centre in
// direction u, sampled every h/4 up to the grid border.
template <int D>
int signChangesAlongRay(const Grid<D>& g, const Vec<D>& u) {
  const double reach = reachAlong(g, u);
  bool inside = g.value(Vec<D>::Zero()) < 0.0;
  int changes = 0;
  for (double t = 0.25 * g.spacing(); t <= reach; t += 0.25 * g.spacing()) {
    const bool now = g.value(t * u) < 0.0;
    if (now != inside) ++changes;
    inside = now;
  }
  return changes;
}

// Radius of the zero level set along the ray in direction u (bisection on the
// interpolated values between the centre and the grid border).
template <int D>
double surfaceRadius(const Grid<D>& g, const Vec<D>& u) {
  double lo = 0.0, hi = reachAlong(g, u);
  for (int it = 0; it < 60; ++it) {
    const double mid = 0.5 * (lo + hi);
    (g.value(mid * u) < 0.0 ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// Standard deviation / mean of the surface radius over uniformly spread directions.
template <int D>
double measuredRoughness(const Grid<D>& g, int rays) {
  double sum = 0.0, sumSq = 0.0;
  for (const Vec<D>& u : directions<D>(rays)) {
    const double r = surfaceRadius(g, u);
    sum += r;
    sumSq += r * r;
  }
  const double mean = sum / rays;
  return std::sqrt(sumSq / rays - mean * mean) / mean;
}

template <int D>
bool sameBits(const Grid<D>& a, const Grid<D>& b) {
  return (a.dims() == b.dims()).all() && a.origin() == b.origin() &&
         std::memcmp(a.values().data(), b.values().data(), a.bytes()) == 0;
}

}  // namespace

TEST(RandomGrain, SameSeedSameGridOtherSeedOtherGrid) {
  RandomGrainDef def;
  def.roughness = 0.2;
  def.elongation = 1.4;
  def.seed = 42;
  EXPECT_TRUE(sameBits(randomGrainGrid<2>(def, 0.04), randomGrainGrid<2>(def, 0.04)));
  EXPECT_TRUE(sameBits(randomGrainGrid<3>(def, 0.08), randomGrainGrid<3>(def, 0.08)));
  RandomGrainDef other = def;
  other.seed = 43;
  EXPECT_FALSE(sameBits(randomGrainGrid<2>(def, 0.04), randomGrainGrid<2>(other, 0.04)));
  EXPECT_FALSE(sameBits(randomGrainGrid<3>(def, 0.08), randomGrainGrid<3>(other, 0.08)));
}

TEST(RandomGrain, BitwiseIdenticalForAnyThreadCount) {
#ifdef LSDEM_HAVE_OPENMP
  RandomGrainDef def;
  def.roughness = 0.15;
  def.seed = 7;
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const Grid<3> one = randomGrainGrid<3>(def, 0.06);
  omp_set_num_threads(std::max(2, threads));
  const Grid<3> many = randomGrainGrid<3>(def, 0.06);
  omp_set_num_threads(threads);
  EXPECT_TRUE(sameBits(one, many));
#else
  GTEST_SKIP() << "built without OpenMP";
#endif
}

// Roughness 0 and elongation 1: the circle / sphere of the equivalent diameter.
TEST(RandomGrain, SmoothRoundGrainIsTheSphere) {
  RandomGrainDef def;
  def.equivalentDiameter = 0.8;
  def.roughness = 0.0;
  const double h2 = 0.02, h3 = 0.04;
  const Grid<2> grain2 = randomGrainGrid<2>(def, h2);
  const Grid<2> circle = sphereGrid<2>(0.4, h2);
  const Grid<3> grain3 = randomGrainGrid<3>(def, h3);
  const Grid<3> sphere = sphereGrid<3>(0.4, h3);
  double worst2 = 0.0, worst3 = 0.0;
  for (std::size_t n = 0; n < grain2.size(); ++n) {
    const Vec<2> x = grain2.nodePosition(grain2.unlinear(n));
    if (std::abs(x.norm() - 0.4) < 2.0 * h2) worst2 = std::max(worst2, std::abs(grain2[n] - circle.value(x)));
  }
  for (std::size_t n = 0; n < grain3.size(); ++n) {
    const Vec<3> x = grain3.nodePosition(grain3.unlinear(n));
    if (std::abs(x.norm() - 0.4) < 2.0 * h3) worst3 = std::max(worst3, std::abs(grain3[n] - sphere.value(x)));
  }
  std::cout << "round grain vs sphereGrid within 2h: 2D " << worst2 / h2 << " h, 3D " << worst3 / h3 << " h\n";
  EXPECT_LT(worst2, 0.02 * h2);
  EXPECT_LT(worst3, 0.02 * h3);
}

// ~25 cells across: area and volume of the equivalent circle / sphere within 2%.
TEST(RandomGrain, AreaAndVolumeOfTheEquivalentDiameter) {
  const double d = 1.0, h = d / 25.0;
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    for (double elongation : {1.0, 1.8}) {
      RandomGrainDef def;
      def.equivalentDiameter = d;
      def.roughness = 0.15;
      def.elongation = elongation;
      def.seed = seed;
      const double area = smoothVolume(randomGrainGrid<2>(def, h)) / (kPi * d * d / 4.0);
      const double volume = smoothVolume(randomGrainGrid<3>(def, h)) / (kPi * d * d * d / 6.0);
      std::cout << "seed " << seed << ", elongation " << elongation << ": area ratio " << area << ", volume ratio "
                << volume << "\n";
      EXPECT_NEAR(area, 1.0, 0.02);
      EXPECT_NEAR(volume, 1.0, 0.02);
    }
  }
}

TEST(RandomGrain, ElongationIsTheSecondMomentAxisRatio) {
  for (double e : {1.5, 2.5}) {
    RandomGrainDef def;
    def.roughness = 0.05;
    def.elongation = e;
    def.seed = 11;
    const double ratio2 = axisRatio(randomGrainGrid<2>(def, 0.02));
    const double ratio3 = axisRatio(randomGrainGrid<3>(def, 0.05));
    std::cout << "elongation " << e << ": axis ratio 2D " << ratio2 << ", 3D " << ratio3 << "\n";
    EXPECT_NEAR(ratio2 / e, 1.0, 0.15);
    EXPECT_NEAR(ratio3 / e, 1.0, 0.15);
  }
}

// The profile's standard deviation of r / r0 is the roughness (measured on the
// grid along rays; the mean of r / r0 is 1).
TEST(RandomGrain, RoughnessIsTheRadiusDeviation) {
  RandomGrainDef def;
  def.roughness = 0.12;
  def.seed = 5;
  const double rough2 = measuredRoughness(randomGrainGrid<2>(def, 0.005), 2000);
  const double rough3 = measuredRoughness(randomGrainGrid<3>(def, 0.025), 4000);
  std::cout << "roughness 0.12 measured: 2D " << rough2 << ", 3D " << rough3 << "\n";
  EXPECT_NEAR(rough2, 0.12, 0.01);
  EXPECT_NEAR(rough3, 0.12, 0.01);
}

// Star-shaped about the centre: every ray from the centre leaves the grain once.
TEST(RandomGrain, StarShaped) {
  for (std::uint64_t seed : {1u, 2u, 3u, 4u}) {
    RandomGrainDef def;
    def.roughness = 0.3;
    def.elongation = 1.5;
    def.seed = seed;
    const Grid<2> g2 = randomGrainGrid<2>(def, 0.02);
    ASSERT_LT(g2.value(Vec<2>::Zero()), 0.0);
    for (const Vec<2>& u : directions<2>(720)) EXPECT_EQ(signChangesAlongRay(g2, u), 1) << "seed " << seed;
    const Grid<3> g3 = randomGrainGrid<3>(def, 0.04);
    ASSERT_LT(g3.value(Vec<3>::Zero()), 0.0);
    for (const Vec<3>& u : directions<3>(1000)) EXPECT_EQ(signChangesAlongRay(g3, u), 1) << "seed " << seed;
  }
}

TEST(RandomGrain, RejectsBadDefinitions) {
  RandomGrainDef def;
  def.equivalentDiameter = 0.0;
  EXPECT_THROW(randomGrainGrid<2>(def, 0.1), std::invalid_argument);
  def = RandomGrainDef{};
  def.elongation = 0.9;
  EXPECT_THROW(randomGrainGrid<3>(def, 0.1), std::invalid_argument);
  def = RandomGrainDef{};
  def.roughness = 0.6;
  EXPECT_THROW(randomGrainGrid<2>(def, 0.1), std::invalid_argument);
  def.roughness = -0.1;
  EXPECT_THROW(randomGrainGrid<2>(def, 0.1), std::invalid_argument);
  def = RandomGrainDef{};
  EXPECT_THROW(randomGrainGrid<2>(def, -0.1), std::invalid_argument);
  EXPECT_THROW(randomGrainGrid<3>(def, 0.1, -2), std::invalid_argument);
}
