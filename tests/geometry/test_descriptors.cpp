#include "support/Sampling.h"
#include "lsdem/geometry/Descriptors.h"
#include "lsdem/geometry/Primitives.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

using namespace lsdem::geometry;
using lsdem::test::sampled;
using lsdem::test::boxAround;

namespace {

constexpr double kPi = std::numbers::pi;



// Nodes on a closed curve given by its points in order: each weighs half of
// its two adjacent chords, so the weights sum to the polygon's perimeter.
NodeSet<2> closedCurve(const std::vector<Vec<2>>& points) {
  NodeSet<2> nodes;
  nodes.positions = points;
  const std::size_t n = points.size();
  for (std::size_t k = 0; k < n; ++k) {
    const Vec<2>& prev = points[(k + n - 1) % n];
    const Vec<2>& next = points[(k + 1) % n];
    nodes.weights.push_back(0.5 * ((points[k] - prev).norm() + (next - points[k]).norm()));
  }
  return nodes;
}

// N points of the ellipse x = c + R (a cos t, b sin t), t = 2 pi k / N (N a multiple of 4,
// so the axis ends are nodes).
NodeSet<2> ellipseNodes(const Vec<2>& c, const Mat<2>& R, double a, double b, int N) {
  std::vector<Vec<2>> p;
  for (int k = 0; k < N; ++k) {
    const double t = 2 * kPi * k / N;
    p.push_back(c + R * Vec<2>(a * std::cos(t), b * std::sin(t)));
  }
  return closedCurve(p);
}

// Fibonacci points on the unit sphere.
std::vector<Vec<3>> fibonacciSphere(int N) {
  std::vector<Vec<3>> p;
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  for (int k = 0; k < N; ++k) {
    const double z = 1.0 - (2.0 * k + 1.0) / N;
    const double r = std::sqrt(1.0 - z * z);
    p.emplace_back(r * std::cos(golden * k), r * std::sin(golden * k), z);
  }
  return p;
}

// Ramanujan's second approximation of an ellipse's perimeter (relative error ~1e-8 at a = 2b).
double ellipsePerimeter(double a, double b) {
  const double h = (a - b) * (a - b) / ((a + b) * (a + b));
  return kPi * (a + b) * (1.0 + 3.0 * h / (10.0 + std::sqrt(4.0 - 3.0 * h)));
}

}  // namespace

// Circle: circularity 1 (eq. 23), sieve size and equivalent diameter = 2R.
TEST(Descriptors, Circle) {
  const double R = 0.5;
  const Vec<2> c(0.013, -0.021);
  const Grid<2> g = sampled<2>(boxAround<2>(c, R), 0.025, [&](const Vec<2>& x) { return (x - c).norm() - R; });
  const int N = 400;
  std::vector<Vec<2>> p;
  for (int k = 0; k < N; ++k) p.push_back(c + R * Vec<2>(std::cos(2 * kPi * k / N), std::sin(2 * kPi * k / N)));
  NodeSet<2> nodes;
  nodes.positions = p;
  nodes.weights.assign(N, 2 * kPi * R / N);  // exact perimeter
  const Descriptors<2> d = computeDescriptors(g, massProperties(g), nodes);
  EXPECT_NEAR(d.circularity, 1.0, 0.01);
  EXPECT_NEAR(d.surfaceArea, 2 * kPi * R, 1e-12);
  EXPECT_NEAR(d.equivalentDiameter, 2 * R, 0.005 * 2 * R);
  EXPECT_NEAR(d.sieveSize, 2 * R, 0.005 * 2 * R);
  EXPECT_NEAR(d.aspectRatio, 1.0, 0.005);
  EXPECT_NEAR(d.bestFitSemiAxes[0], R, 0.005 * R);
  EXPECT_NEAR(d.bestFitSemiAxes[1], R, 0.005 * R);
  EXPECT_NEAR(d.intermediateAxis, 2 * R, 0.01 * R);
  std::printf("circle: circularity %.5f, sieve %.5f (2R = %.1f)\n", d.circularity, d.sieveSize, 2 * R);
}

// Sphere: Wadell sphericity 1; sieve size 2R.
TEST(Descriptors, Sphere) {
  const double R = 0.5;
  const Vec<3> c(0.013, -0.021, 0.007);
  const Grid<3> g = sampled<3>(boxAround<3>(c, R), 0.05, [&](const Vec<3>& x) { return (x - c).norm() - R; });
  NodeSet<3> nodes;
  const int N = 4000;
  for (const Vec<3>& u : fibonacciSphere(N)) nodes.positions.push_back(c + R * u);
  nodes.weights.assign(N, 4 * kPi * R * R / N);
  const Descriptors<3> d = computeDescriptors(g, massProperties(g), nodes);
  EXPECT_NEAR(d.circularity, 1.0, 0.01);
  EXPECT_NEAR(d.equivalentDiameter, 2 * R, 0.005 * 2 * R);
  EXPECT_NEAR(d.sieveSize, 2 * R, 0.005 * 2 * R);
  EXPECT_NEAR(d.aspectRatio, 1.0, 0.005);
  EXPECT_NEAR(d.intermediateAxis, 2 * R, 0.01 * R);
  std::printf("sphere: sphericity %.5f, sieve %.5f\n", d.circularity, d.sieveSize);
}

// Rotated ellipse a = 2b: aspect ratio 0.5, sieve size 2b (the minor axis),
// best-fit semi-axes (a, b), circularity 4 pi (pi a b) / P^2.
TEST(Descriptors, EllipseTwoToOne) {
  const double a = 0.6, b = 0.3;
  const Vec<2> c(0.013, -0.021);
  const Mat<2> R = Eigen::Rotation2Dd(0.4).toRotationMatrix();
  const Grid<2> g = sampled<2>(boxAround<2>(c, a), 0.02, [&](const Vec<2>& x) {
    return sdfEllipsoid<2>(R.transpose() * (x - c), Vec<2>(a, b));
  });
  const Descriptors<2> d = computeDescriptors(g, massProperties(g), ellipseNodes(c, R, a, b, 800));
  EXPECT_NEAR(d.aspectRatio, 0.5, 0.005 * 0.5);
  EXPECT_NEAR(d.sieveSize, 2 * b, 0.005 * 2 * b);
  EXPECT_NEAR(d.bestFitSemiAxes[0], a, 0.005 * a);
  EXPECT_NEAR(d.bestFitSemiAxes[1], b, 0.005 * b);
  EXPECT_NEAR(d.intermediateAxis, 2 * b, 0.005 * 2 * b);
  EXPECT_NEAR(d.equivalentDiameter, 2 * std::sqrt(a * b), 0.005 * 2 * std::sqrt(a * b));
  const double P = ellipsePerimeter(a, b);
  EXPECT_NEAR(d.surfaceArea, P, 1e-4 * P);
  const double circ = 4 * kPi * kPi * a * b / (P * P);
  EXPECT_NEAR(d.circularity, circ, 0.005 * circ);
  std::printf("ellipse 2:1: aspect %.5f, sieve %.5f (2b = %.2f), circularity %.5f (exact %.5f)\n", d.aspectRatio,
              d.sieveSize, 2 * b, d.circularity, circ);
}

// A disc of radius 0.3 cells centred in a cell: every grid value is
// positive, so the line through the centroid holds no inside length, while
// the smoothed mass integral gives it a volume. Its sieve size is its
// equivalent diameter (it was 0, and such fines sat at 0 in a PSD).
TEST(Descriptors, APieceTheCentroidLineMissesTakesItsEquivalentDiameter) {
  const double h = 0.1, R = 0.3 * h;
  const Vec<2> c(0.05, 0.05);
  const Grid<2> g = sampled<2>(boxAround<2>(Vec<2>::Zero(), 4 * h), h, [&](const Vec<2>& x) { return (x - c).norm() - R; });
  ASSERT_GT(g.value(c), 0.0) << "the grid's nodes must miss the disc";
  NodeSet<2> nodes;
  for (int k = 0; k < 8; ++k) nodes.positions.push_back(c + R * Vec<2>(std::cos(kPi * k / 4), std::sin(kPi * k / 4)));
  nodes.weights.assign(8, 2 * kPi * R / 8);
  const MassProperties<2> mass = massProperties(g);
  ASSERT_GT(mass.volume, 0.0);
  const Descriptors<2> d = computeDescriptors(g, mass, nodes);
  EXPECT_GT(d.equivalentDiameter, 0.0);
  EXPECT_EQ(d.sieveSize, d.equivalentDiameter);
}

// Rectangle 1.0 x 0.6: best-fit semi-axes 2 h_i / sqrt(3), sieve size 0.6.
TEST(Descriptors, Rectangle) {
  const Vec<2> half(0.5, 0.3);
  const Grid<2> g = sampled<2>(Box<2>{-half, half}, 0.02, [&](const Vec<2>& x) { return sdfBox<2>(x, half); });
  // Perimeter points every 0.01, the side midpoints among them.
  std::vector<Vec<2>> p;
  for (int k = -50; k < 50; ++k) p.emplace_back(0.01 * k, -0.3);
  for (int k = -30; k < 30; ++k) p.emplace_back(0.5, 0.01 * k);
  for (int k = 50; k > -50; --k) p.emplace_back(0.01 * k, 0.3);
  for (int k = 30; k > -30; --k) p.emplace_back(-0.5, 0.01 * k);
  const Descriptors<2> d = computeDescriptors(g, massProperties(g), closedCurve(p));
  const double A = 4 * half.prod(), P = 4 * half.sum();
  EXPECT_NEAR(d.volume, A, 0.005 * A);
  EXPECT_NEAR(d.surfaceArea, P, 1e-12);
  EXPECT_NEAR(d.circularity, 4 * kPi * A / (P * P), 0.005);
  EXPECT_NEAR(d.bestFitSemiAxes[0], 2 * half[0] / std::sqrt(3.0), 0.005 * half[0]);
  EXPECT_NEAR(d.bestFitSemiAxes[1], 2 * half[1] / std::sqrt(3.0), 0.005 * half[1]);
  EXPECT_NEAR(d.aspectRatio, 0.6, 0.005 * 0.6);
  EXPECT_NEAR(d.sieveSize, 0.6, 0.005 * 0.6);
  EXPECT_NEAR(d.equivalentDiameter, 2 * std::sqrt(A / kPi), 0.005);
}

// Box 1.0 x 0.8 x 0.6: sphericity pi^(1/3) (6V)^(2/3) / A, best-fit semi-axes
// sqrt(5/3) h_i, intermediate axis 2 sqrt(5/3) 0.4, sieve size 0.6 (through the face centres).
TEST(Descriptors, Box) {
  const Vec<3> half(0.5, 0.4, 0.3);
  const Grid<3> g = sampled<3>(Box<3>{-half, half}, 0.03, [&](const Vec<3>& x) { return sdfBox<3>(x, half); });
  // Face nodes: an odd number of equal patches per face side, so the face centres are nodes.
  NodeSet<3> nodes;
  const int m = 21;
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    const double du = 2 * half[u] / m, dv = 2 * half[v] / m;
    for (double side : {-1.0, 1.0})
      for (int i = 0; i < m; ++i)
        for (int j = 0; j < m; ++j) {
          Vec<3> x;
          x[axis] = side * half[axis];
          x[u] = -half[u] + (i + 0.5) * du;
          x[v] = -half[v] + (j + 0.5) * dv;
          nodes.positions.push_back(x);
          nodes.weights.push_back(du * dv);
        }
  }
  const Descriptors<3> d = computeDescriptors(g, massProperties(g), nodes);
  const double V = 8 * half.prod();
  const double A = 8 * (half[0] * half[1] + half[1] * half[2] + half[0] * half[2]);
  EXPECT_NEAR(d.surfaceArea, A, 1e-9);
  const double sphericity = std::cbrt(kPi) * std::pow(6 * V, 2.0 / 3.0) / A;
  EXPECT_NEAR(d.circularity, sphericity, 0.005 * sphericity);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(d.bestFitSemiAxes[i], std::sqrt(5.0 / 3.0) * half[i], 0.005 * half[i]);
  EXPECT_NEAR(d.intermediateAxis, 2 * std::sqrt(5.0 / 3.0) * 0.4, 0.005 * 0.8);
  EXPECT_NEAR(d.aspectRatio, 0.6, 0.005 * 0.6);
  EXPECT_NEAR(d.sieveSize, 0.6, 0.005 * 0.6);
  EXPECT_NEAR(d.equivalentDiameter, std::cbrt(6 * V / kPi), 0.005);
}

// Rotated ellipsoid (0.6, 0.4, 0.3): intermediate axis 2b = 0.8, aspect ratio
// 0.5, sieve size 2c = 0.6 (the closest node is the end of the short axis).
TEST(Descriptors, EllipsoidIntermediateAxis) {
  const Vec<3> axes(0.6, 0.4, 0.3);
  const Vec<3> c(0.013, -0.021, 0.007);
  const Mat<3> R = Eigen::AngleAxisd(0.7, Vec<3>(1, 2, 3).normalized()).toRotationMatrix();
  const Grid<3> g = sampled<3>(boxAround<3>(c, 0.6), 0.03, [&](const Vec<3>& x) {
    return sdfEllipsoid<3>(R.transpose() * (x - c), axes);
  });
  NodeSet<3> nodes;
  for (const Vec<3>& u : fibonacciSphere(3000)) nodes.positions.push_back(c + R * axes.cwiseProduct(u));
  for (double s : {-1.0, 1.0}) nodes.positions.push_back(c + R * Vec<3>(0, 0, s * axes[2]));
  nodes.weights.assign(nodes.positions.size(), 1.0 / double(nodes.positions.size()));
  const Descriptors<3> d = computeDescriptors(g, massProperties(g), nodes);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(d.bestFitSemiAxes[i], axes[i], 0.005 * axes[i]);
  EXPECT_NEAR(d.intermediateAxis, 0.8, 0.005 * 0.8);
  EXPECT_NEAR(d.aspectRatio, 0.5, 0.005 * 0.5);
  EXPECT_NEAR(d.sieveSize, 0.6, 0.005 * 0.6);
  EXPECT_NEAR(d.equivalentDiameter, 2 * std::cbrt(axes.prod()), 0.005);
}

// An annulus: the centroid is in the hole, the closest node is on the inner
// rim, and the sieve line crosses the ring twice: 2 (r2 - r1). Same for a
// spherical shell in 3D.
TEST(Descriptors, CentroidOutsideTheShape) {
  const double r1 = 0.3, r2 = 0.5;
  const Grid<2> ring = sampled<2>(boxAround<2>(Vec<2>::Zero(), r2), 0.01, [&](const Vec<2>& x) {
    return std::abs(x.norm() - 0.5 * (r1 + r2)) - 0.5 * (r2 - r1);
  });
  NodeSet<2> nodes;
  for (int k = 0; k < 360; ++k) {
    const Vec<2> u(std::cos(2 * kPi * (k + 0.3) / 360), std::sin(2 * kPi * (k + 0.3) / 360));
    for (double r : {r1, r2}) {
      nodes.positions.push_back(r * u);
      nodes.weights.push_back(2 * kPi * r / 360);
    }
  }
  const MassProperties<2> mp = massProperties(ring);
  EXPECT_GT(ring.value(mp.centroid), 0.0);
  const Descriptors<2> d = computeDescriptors(ring, mp, nodes);
  EXPECT_NEAR(d.sieveSize, 2 * (r2 - r1), 0.005 * 2 * (r2 - r1));
  EXPECT_NEAR(d.volume, kPi * (r2 * r2 - r1 * r1), 0.005 * kPi * (r2 * r2 - r1 * r1));

  const Grid<3> shell = sampled<3>(boxAround<3>(Vec<3>::Zero(), r2), 0.025, [&](const Vec<3>& x) {
    return std::abs(x.norm() - 0.5 * (r1 + r2)) - 0.5 * (r2 - r1);
  });
  NodeSet<3> n3;
  for (const Vec<3>& u : fibonacciSphere(2000)) {
    for (double r : {r1, r2}) {
      n3.positions.push_back(r * u);
      n3.weights.push_back(4 * kPi * r * r / 2000);
    }
  }
  const Descriptors<3> d3 = computeDescriptors(shell, massProperties(shell), n3);
  EXPECT_NEAR(d3.sieveSize, 2 * (r2 - r1), 0.01 * 2 * (r2 - r1));
}

// A concave C-shape: the sieve line crosses the shape more than once; the
// total inside length is the sum of the pieces (checked against a fine march).
TEST(Descriptors, ConcaveShapeSumsAllIntervals) {
  // A thick "C": a ring of radii 0.3 / 0.5 with the sector |angle| < 40 degrees (opening +x) removed.
  const double r1 = 0.3, r2 = 0.5;
  const double opening = 40.0 * kPi / 180.0;
  auto sdf = [&](const Vec<2>& x) {
    const double ring = std::abs(x.norm() - 0.4) - 0.1;
    // Wedge |angle| < opening as an intersection of two half-planes (exact enough near the cut).
    const double wedge = std::max(-std::sin(opening) * x[0] + std::cos(opening) * x[1],
                                  -std::sin(opening) * x[0] - std::cos(opening) * x[1]);
    return std::max(ring, -wedge);
  };
  const Grid<2> g = sampled<2>(boxAround<2>(Vec<2>::Zero(), r2), 0.01, sdf);
  const MassProperties<2> mp = massProperties(g);
  // Nodes on the inner rim only near the back (-x), so the line runs along x through the back wall.
  NodeSet<2> nodes;
  nodes.positions = {Vec<2>(-r1, 0.0), Vec<2>(-r2, 0.0), Vec<2>(0.0, r2)};
  nodes.weights = {1.0, 1.0, 1.0};
  const Descriptors<2> d = computeDescriptors(g, mp, nodes);
  // Along the x axis through the centroid (on the axis by symmetry): the back wall [-0.5, -0.3] only,
  // since the opening removes the front wall.
  EXPECT_NEAR(mp.centroid[1], 0.0, 1e-6);
  EXPECT_NEAR(d.sieveSize, r2 - r1, 0.005);
  // Closing the opening puts the front wall back on the line: twice the length.
  const Grid<2> closed = sampled<2>(boxAround<2>(Vec<2>::Zero(), r2), 0.01,
                                    [&](const Vec<2>& x) { return std::abs(x.norm() - 0.4) - 0.1; });
  const Descriptors<2> dc = computeDescriptors(closed, massProperties(closed), nodes);
  EXPECT_NEAR(dc.sieveSize, 2 * (r2 - r1), 0.005);
}

TEST(Descriptors, RejectsBadInput) {
  const Grid<2> g = sampled<2>(boxAround<2>(Vec<2>::Zero(), 0.5), 0.05, [](const Vec<2>& x) { return x.norm() - 0.5; });
  const MassProperties<2> mp = massProperties(g);
  NodeSet<2> nodes;
  EXPECT_THROW(computeDescriptors(g, mp, nodes), std::invalid_argument);
  nodes.positions = {Vec<2>(0.5, 0.0)};
  EXPECT_THROW(computeDescriptors(g, mp, nodes), std::invalid_argument);  // no weights
  nodes.weights = {0.0};
  EXPECT_THROW(computeDescriptors(g, mp, nodes), std::invalid_argument);  // zero surface
  nodes.weights = {1.0};
  MassProperties<2> none = mp;
  none.volume = 0.0;
  EXPECT_THROW(computeDescriptors(g, none, nodes), std::invalid_argument);
  none.volume = -1.0;
  EXPECT_THROW(computeDescriptors(g, none, nodes), std::invalid_argument);
  EXPECT_NO_THROW(computeDescriptors(g, mp, nodes));
}
