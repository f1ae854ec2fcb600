#include "lsdem/geometry/Primitives.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

using namespace lsdem::geometry;

namespace {

constexpr double kPi = std::numbers::pi;

// Volume (area in 2D) by a smoothed-Heaviside sum over the nodes: sum H(-phi) h^D
// with H(x) = (1 + x/e + sin(pi x/e)/pi) / 2 on |x| < e = 1.5h. Second-order
// accurate where a plain count of phi < 0 nodes is first order (and is off by
// half a layer on surfaces that pass through nodes).
template <int D>
double smoothVolume(const Grid<D>& g) {
  const double e = 1.5 * g.spacing();
  double sum = 0.0;
  for (std::size_t n = 0; n < g.size(); ++n) {
    const double x = -double(g[n]);
    sum += x <= -e ? 0.0 : x >= e ? 1.0 : 0.5 * (1.0 + x / e + std::sin(kPi * x / e) / kPi);
  }
  return sum * std::pow(g.spacing(), D);
}

// Checks a measured volume against the exact one (relative tolerance) and prints the error.
void expectVolume(const char* what, double measured, double exact, double tolerance) {
  std::cout << what << ": volume error " << 100.0 * (measured / exact - 1.0) << " %\n";
  EXPECT_NEAR(measured / exact, 1.0, tolerance) << what;
}

// Central-difference gradient of f at x.
template <int D, class F>
Vec<D> numericGradient(F f, const Vec<D>& x, double eps = 1e-6) {
  Vec<D> g;
  for (int a = 0; a < D; ++a) {
    Vec<D> e = Vec<D>::Zero();
    e[a] = eps;
    g[a] = (f(x + e) - f(x - e)) / (2.0 * eps);
  }
  return g;
}

// Random point in [-extent, extent]^D.
template <int D>
Vec<D> randomPoint(std::mt19937_64& rng, double extent) {
  std::uniform_real_distribution<double> u(-extent, extent);
  Vec<D> x;
  for (int a = 0; a < D; ++a) x[a] = u(rng);
  return x;
}

// Distance from x to the ellipse with semi-axes (a, b) by dense sampling of the
// boundary followed by a golden-section refinement around the best sample.
double bruteForceEllipseDistance(const Vec<2>& x, double a, double b) {
  auto dist = [&](double t) { return std::hypot(a * std::cos(t) - x[0], b * std::sin(t) - x[1]); };
  const int samples = 20000;
  int best = 0;
  for (int k = 1; k < samples; ++k) {
    if (dist(2 * kPi * k / samples) < dist(2 * kPi * best / samples)) best = k;
  }
  double lo = 2 * kPi * (best - 1) / samples, hi = 2 * kPi * (best + 1) / samples;
  const double phi = 0.5 * (std::sqrt(5.0) - 1.0);
  for (int it = 0; it < 100; ++it) {
    const double m1 = hi - phi * (hi - lo), m2 = lo + phi * (hi - lo);
    (dist(m1) < dist(m2) ? hi : lo) = (dist(m1) < dist(m2) ? m2 : m1);
  }
  return dist(0.5 * (lo + hi));
}

// Distance from x to the ellipsoid with semi-axes s by a parameter-grid search
// and shrinking pattern-search refinement.
double bruteForceEllipsoidDistance(const Vec<3>& x, const Vec<3>& s) {
  auto dist = [&](double theta, double phi) {
    const Vec<3> y(s[0] * std::sin(theta) * std::cos(phi), s[1] * std::sin(theta) * std::sin(phi),
                   s[2] * std::cos(theta));
    return (y - x).norm();
  };
  double bestT = 0.0, bestP = 0.0, best = dist(0.0, 0.0);
  const int nt = 180, np = 360;
  for (int i = 0; i <= nt; ++i) {
    for (int j = 0; j < np; ++j) {
      const double t = kPi * i / nt, p = 2 * kPi * j / np;
      const double d = dist(t, p);
      if (d < best) {
        best = d;
        bestT = t;
        bestP = p;
      }
    }
  }
  for (double step = kPi / nt; step > 1e-13; step *= 0.5) {
    for (bool improved = true; improved;) {
      improved = false;
      for (const auto& [dt, dp] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}, {1, 1}, {-1, -1}, {1, -1}, {-1, 1}}) {
        const double d = dist(bestT + dt * step, bestP + dp * step);
        if (d < best) {
          best = d;
          bestT += dt * step;
          bestP += dp * step;
          improved = true;
        }
      }
    }
  }
  return best;
}

// Volume of the superellipsoid (|x/a|^n2 + |y/b|^n2)^(n1/n2) + |z/c|^n1 <= 1:
// 2abc e1 e2 B(e1/2 + 1, e1) B(e2/2, e2/2) with e1 = 2/n1, e2 = 2/n2.
double superellipsoidVolume(const Vec<3>& s, double n1, double n2) {
  auto beta = [](double p, double q) { return std::tgamma(p) * std::tgamma(q) / std::tgamma(p + q); };
  const double e1 = 2.0 / n1, e2 = 2.0 / n2;
  return 2.0 * s.prod() * e1 * e2 * beta(e1 / 2 + 1, e1) * beta(e2 / 2, e2 / 2);
}

}  // namespace

// ---- analytic distances ------------------------------------------------------

TEST(Primitives, SphereKnownValues) {
  EXPECT_DOUBLE_EQ(sdfSphere<2>(Vec<2>(0, 0), 0.5), -0.5);
  EXPECT_DOUBLE_EQ(sdfSphere<2>(Vec<2>(0.3, 0.4), 0.5), 0.0);
  EXPECT_DOUBLE_EQ(sdfSphere<3>(Vec<3>(0, 3, 4), 2.0), 3.0);
  EXPECT_DOUBLE_EQ(sdfSphere<3>(Vec<3>(0, 0, 0.5), 2.0), -1.5);
  EXPECT_THROW(sdfSphere<3>(Vec<3>::Zero(), 0.0), std::invalid_argument);
  EXPECT_THROW(sdfSphere<2>(Vec<2>::Zero(), std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
}

TEST(Primitives, BoxKnownValues) {
  const Vec<2> h2(2.0, 1.0);
  EXPECT_DOUBLE_EQ(sdfBox<2>(Vec<2>(0, 0), h2), -1.0);      // centre: nearest faces y = +-1
  EXPECT_DOUBLE_EQ(sdfBox<2>(Vec<2>(1.8, 0.0), h2), -0.2);  // inside near the x face
  EXPECT_DOUBLE_EQ(sdfBox<2>(Vec<2>(2.0, 1.0), h2), 0.0);   // on the corner
  EXPECT_DOUBLE_EQ(sdfBox<2>(Vec<2>(5.0, 5.0), h2), 5.0);   // outside the corner: |(3, 4)|
  EXPECT_DOUBLE_EQ(sdfBox<2>(Vec<2>(-2.5, 0.3), h2), 0.5);  // outside a face
  const Vec<3> h3(1.0, 2.0, 3.0);
  EXPECT_DOUBLE_EQ(sdfBox<3>(Vec<3>(0, 0, 0), h3), -1.0);
  EXPECT_DOUBLE_EQ(sdfBox<3>(Vec<3>(3, 4, 3), h3), std::sqrt(8.0));  // outside the edge at x = 1, y = 2
  EXPECT_DOUBLE_EQ(sdfBox<3>(Vec<3>(2, 3, 4), h3), std::sqrt(3.0));  // outside the corner
  EXPECT_NEAR(sdfBox<3>(Vec<3>(0.5, -1.9, 0.0), h3), -0.1, 1e-15);
}

TEST(Primitives, RoundedBoxKnownValues) {
  const Vec<2> h2(2.0, 1.0);
  const double r = 0.5;
  // Faces keep the outer half extents.
  EXPECT_DOUBLE_EQ(sdfBox<2>(Vec<2>(2.0, 0.0), h2, r), 0.0);
  EXPECT_DOUBLE_EQ(sdfBox<2>(Vec<2>(0.0, -1.0), h2, r), 0.0);
  EXPECT_DOUBLE_EQ(sdfBox<2>(Vec<2>(0.0, 0.0), h2, r), -1.0);
  // The sharp corner is now outside by (sqrt(2) - 1) r; the rounded corner's
  // centre is r inside.
  EXPECT_NEAR(sdfBox<2>(Vec<2>(2.0, 1.0), h2, r), (std::sqrt(2.0) - 1.0) * r, 1e-15);
  EXPECT_NEAR(sdfBox<2>(Vec<2>(1.5, 0.5), h2, r), -r, 1e-15);
  EXPECT_NEAR(sdfBox<2>(Vec<2>(1.5 + 0.3, 0.5 + 0.4), h2, r), 0.0, 1e-15);
  // 3D: corner and edge rounding; full rounding of the shortest axis.
  const Vec<3> h3(1.0, 1.0, 1.0);
  EXPECT_NEAR(sdfBox<3>(Vec<3>(1, 1, 1), h3, 0.2), (std::sqrt(3.0) - 1.0) * 0.2, 1e-15);
  EXPECT_NEAR(sdfBox<3>(Vec<3>(1, 1, 0), h3, 0.2), (std::sqrt(2.0) - 1.0) * 0.2, 1e-15);
  EXPECT_NEAR(sdfBox<3>(Vec<3>(2, 0, 0), h3, 1.0), 1.0, 1e-15);  // r = half extent: a sphere
  EXPECT_NEAR(sdfBox<3>(Vec<3>(1, 1, 1), h3, 1.0), std::sqrt(3.0) - 1.0, 1e-15);
  // Invalid rounding and extents.
  EXPECT_THROW(sdfBox<2>(Vec<2>::Zero(), h2, 1.5), std::invalid_argument);
  EXPECT_THROW(sdfBox<2>(Vec<2>::Zero(), h2, -0.1), std::invalid_argument);
  EXPECT_THROW(sdfBox<3>(Vec<3>::Zero(), Vec<3>(1, 0, 1)), std::invalid_argument);
}

TEST(Primitives, EllipsoidSpecialPoints) {
  const Vec<2> s2(1.0, 0.6);
  // Centre and points on the axes.
  EXPECT_DOUBLE_EQ(sdfEllipsoid<2>(Vec<2>(0, 0), s2), -0.6);
  EXPECT_NEAR(sdfEllipsoid<2>(Vec<2>(0, 0.5), s2), -0.1, 1e-14);
  EXPECT_NEAR(sdfEllipsoid<2>(Vec<2>(0, -2.0), s2), 1.4, 1e-14);
  EXPECT_NEAR(sdfEllipsoid<2>(Vec<2>(3.0, 0), s2), 2.0, 1e-14);
  EXPECT_NEAR(sdfEllipsoid<2>(Vec<2>(1.0, 0), s2), 0.0, 1e-14);
  // Inside on the major axis near the centre: the closest point leaves the axis
  // (x = a^2 p / (a^2 - b^2)).
  const double p = 0.2, xc = p / (1.0 - 0.36), yc = 0.6 * std::sqrt(1.0 - xc * xc);
  EXPECT_NEAR(sdfEllipsoid<2>(Vec<2>(p, 0), s2), -std::hypot(xc - p, yc), 1e-14);
  // Deep inside on the major axis beyond the evolute cusp: the axis end is closest.
  EXPECT_NEAR(sdfEllipsoid<2>(Vec<2>(0.8, 0), s2), -0.2, 1e-14);
  // A sphere as an ellipsoid; the 3D centre and axes.
  EXPECT_NEAR(sdfEllipsoid<3>(Vec<3>(0.3, -0.4, 1.2), Vec<3>::Constant(0.5)), 0.8, 1e-14);
  EXPECT_DOUBLE_EQ(sdfEllipsoid<3>(Vec<3>::Zero(), Vec<3>(0.6, 0.45, 0.35)), -0.35);
  EXPECT_NEAR(sdfEllipsoid<3>(Vec<3>(0, 0.45, 0), Vec<3>(0.6, 0.45, 0.35)), 0.0, 1e-14);
  EXPECT_THROW(sdfEllipsoid<2>(Vec<2>::Zero(), Vec<2>(1.0, -1.0)), std::invalid_argument);
}

TEST(Primitives, EllipseMatchesBruteForce) {
  const double a = 1.0, b = 0.6;
  std::mt19937_64 rng(3);
  double worst = 0.0;
  std::vector<Vec<2>> points{Vec<2>(0.3, 0.0),    Vec<2>(0.0, 0.2), Vec<2>(-0.5, 0.0),
                             Vec<2>(0.999, 0.01), Vec<2>(2.0, 0.0), Vec<2>(0.0, -1.0)};
  for (int k = 0; k < 60; ++k) points.push_back(randomPoint<2>(rng, 1.6));
  for (const Vec<2>& x : points) {
    const double exact = sdfEllipsoid<2>(x, Vec<2>(a, b));
    const bool inside = (x[0] / a) * (x[0] / a) + (x[1] / b) * (x[1] / b) < 1.0;
    const double brute = (inside ? -1.0 : 1.0) * bruteForceEllipseDistance(x, a, b);
    worst = std::max(worst, std::abs(exact - brute));
    EXPECT_NEAR(exact, brute, 1e-9) << x.transpose();
  }
  std::cout << "ellipse vs brute force: max difference " << worst << "\n";
}

TEST(Primitives, EllipsoidMatchesBruteForce) {
  const Vec<3> s(0.6, 0.45, 0.35);
  std::mt19937_64 rng(5);
  std::vector<Vec<3>> points{Vec<3>(0.1, 0, 0), Vec<3>(0, 0.1, 0), Vec<3>(0.05, 0.05, 0), Vec<3>(0, 0, 0.2)};
  for (int k = 0; k < 16; ++k) points.push_back(randomPoint<3>(rng, 0.9));
  for (const Vec<3>& x : points) {
    const double exact = sdfEllipsoid<3>(x, s);
    const bool inside = (x.array() / s.array()).matrix().squaredNorm() < 1.0;
    const double brute = (inside ? -1.0 : 1.0) * bruteForceEllipsoidDistance(x, s);
    EXPECT_NEAR(exact, brute, 1e-9) << x.transpose();
  }
}

TEST(Primitives, GradientNormIsOne) {
  std::mt19937_64 rng(9);
  for (int k = 0; k < 300; ++k) {
    const Vec<2> x2 = randomPoint<2>(rng, 2.0);
    const Vec<3> x3 = randomPoint<3>(rng, 2.0);
    const std::vector<Vec<2>> l{{0, 0}, {1.5, 0}, {1.5, 0.7}, {0.6, 0.7}, {0.6, 1.4}, {0, 1.4}};
    EXPECT_NEAR(numericGradient<2>([](const Vec<2>& y) { return sdfBox<2>(y, Vec<2>(1.0, 0.7), 0.2); }, x2).norm(), 1.0,
                1e-6);
    EXPECT_NEAR(numericGradient<3>([](const Vec<3>& y) { return sdfBox<3>(y, Vec<3>(1.0, 0.7, 0.4), 0.1); }, x3).norm(),
                1.0, 1e-6);
    EXPECT_NEAR(numericGradient<2>([](const Vec<2>& y) { return sdfEllipsoid<2>(y, Vec<2>(1.0, 0.6)); }, x2).norm(),
                1.0, 1e-6);
    EXPECT_NEAR(
        numericGradient<3>([](const Vec<3>& y) { return sdfEllipsoid<3>(y, Vec<3>(0.6, 0.45, 0.35)); }, x3).norm(), 1.0,
        1e-6);
    EXPECT_NEAR(numericGradient<2>([&](const Vec<2>& y) { return sdfPolygon(y, l); }, x2).norm(), 1.0, 1e-6);
  }
}

TEST(Primitives, PolygonSquareEqualsBox) {
  const std::vector<Vec<2>> ccw{{-1, -0.5}, {1, -0.5}, {1, 0.5}, {-1, 0.5}};
  const std::vector<Vec<2>> cw{ccw.rbegin(), ccw.rend()};
  std::mt19937_64 rng(1);
  for (int k = 0; k < 200; ++k) {
    const Vec<2> x = randomPoint<2>(rng, 2.0);
    const double box = sdfBox<2>(x, Vec<2>(1.0, 0.5));
    EXPECT_NEAR(sdfPolygon(x, ccw), box, 1e-14);
    EXPECT_NEAR(sdfPolygon(x, cw), box, 1e-14);
  }
}

TEST(Primitives, ConcavePolygonKnownPoints) {
  // L-shape: the unit notch at (1..2, 1..2) is missing from the 2 x 2 square.
  const std::vector<Vec<2>> l{{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}};
  const std::vector<Vec<2>> reversed{l.rbegin(), l.rend()};
  for (const auto* poly : {&l, &reversed}) {
    EXPECT_NEAR(sdfPolygon(Vec<2>(0.5, 0.5), *poly), -0.5, 1e-15);
    EXPECT_NEAR(sdfPolygon(Vec<2>(1.5, 0.75), *poly), -0.25, 1e-15);            // under the notch
    EXPECT_NEAR(sdfPolygon(Vec<2>(0.75, 1.5), *poly), -0.25, 1e-15);            // beside the notch
    EXPECT_NEAR(sdfPolygon(Vec<2>(1.5, 1.5), *poly), 0.5, 1e-15);               // in the notch
    EXPECT_NEAR(sdfPolygon(Vec<2>(0.8, 0.8), *poly), -std::sqrt(0.08), 1e-15);  // nearest: the reflex vertex
    EXPECT_NEAR(sdfPolygon(Vec<2>(1.9, 1.2), *poly), 0.2, 1e-15);               // in the notch near its floor
    EXPECT_NEAR(sdfPolygon(Vec<2>(3.0, 0.5), *poly), 1.0, 1e-15);
    EXPECT_NEAR(sdfPolygon(Vec<2>(-3.0, -4.0), *poly), 5.0, 1e-15);
    EXPECT_EQ(sdfPolygon(Vec<2>(1.0, 1.0), *poly), 0.0);  // on the boundary: 0, outside
    EXPECT_EQ(sdfPolygon(Vec<2>(2.0, 0.5), *poly), 0.0);
  }
}

TEST(Primitives, PolygonValidation) {
  EXPECT_THROW(sdfPolygon(Vec<2>::Zero(), {{0, 0}, {1, 0}}), std::invalid_argument);
  EXPECT_THROW(sdfPolygon(Vec<2>::Zero(), {{0, 0}, {1, 1}, {2, 2}}), std::invalid_argument);       // zero area
  EXPECT_THROW(validatePolygon({{0, 0}, {2, 2}, {2, 0}, {0, 1}}), std::invalid_argument);          // bow tie
  EXPECT_THROW(validatePolygon({{0, 0}, {1, 0}, {1, 0}, {0, 1}}), std::invalid_argument);          // repeated vertex
  EXPECT_THROW(validatePolygon({{0, 0}, {2, 0}, {1, 0}, {1, 1}}), std::invalid_argument);          // folds back
  EXPECT_THROW(validatePolygon({{0, 0}, {2, 0}, {2, 2}, {1, 0}, {0, 2}}), std::invalid_argument);  // vertex on an edge
  EXPECT_THROW(polygonGrid({{0, 0}, {2, 2}, {2, 0}, {0, 1}}, 0.1), std::invalid_argument);
  EXPECT_THROW(validatePolygon({{0, 0}, {1, 0}, {std::numeric_limits<double>::infinity(), 1}}), std::invalid_argument);
  EXPECT_NO_THROW(validatePolygon({{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}}));
}

// ---- half-spaces (eq. 18-20) ----------------------------------------------------

TEST(Primitives, HalfSpaceThroughTwoPoints) {
  // Left of p1 -> p2 is inside.
  const HalfSpace<2> h = HalfSpace<2>::throughPoints(Vec<2>(0, 0), Vec<2>(1, 0));
  EXPECT_DOUBLE_EQ(h.distance(Vec<2>(5, 1)), -1.0);
  EXPECT_DOUBLE_EQ(h.distance(Vec<2>(-5, -2)), 2.0);
  // eq. 18 at random points and lines.
  std::mt19937_64 rng(2);
  for (int k = 0; k < 100; ++k) {
    const Vec<2> p1 = randomPoint<2>(rng, 3), p2 = randomPoint<2>(rng, 3), x = randomPoint<2>(rng, 3);
    const HalfSpace<2> line = HalfSpace<2>::throughPoints(p1, p2);
    const double eq18 =
        ((p2[1] - p1[1]) * x[0] - (p2[0] - p1[0]) * x[1] + p2[0] * p1[1] - p2[1] * p1[0]) / (p2 - p1).norm();
    EXPECT_NEAR(line.distance(x), eq18, 1e-12);
    EXPECT_NEAR(line.distance(p1), 0.0, 1e-12);
    EXPECT_NEAR(line.distance(p2), 0.0, 1e-12);
    EXPECT_NEAR(line.normal.norm(), 1.0, 1e-15);
  }
  // Tiny but distinct points are fine; coincident ones are not.
  EXPECT_NO_THROW(HalfSpace<2>::throughPoints(Vec<2>(1e-9, 0), Vec<2>(2e-9, 0)));
  EXPECT_THROW(HalfSpace<2>::throughPoints(Vec<2>(1, 2), Vec<2>(1, 2)), std::invalid_argument);
  EXPECT_THROW(HalfSpace<2>::throughPoints(Vec<2>(1e6, 0), Vec<2>(1e6 + 1e-8, 0)), std::invalid_argument);
}

TEST(Primitives, HalfSpaceThroughThreePoints) {
  const HalfSpace<3> h = HalfSpace<3>::throughPoints(Vec<3>(0, 0, 1), Vec<3>(1, 0, 1), Vec<3>(0, 1, 1));
  EXPECT_DOUBLE_EQ(h.distance(Vec<3>(4, -3, 3)), 2.0);  // n = (0, 0, 1), plane z = 1
  EXPECT_DOUBLE_EQ(h.distance(Vec<3>(0, 0, 0)), -1.0);
  // eq. 19-20 at random points and planes.
  std::mt19937_64 rng(4);
  for (int k = 0; k < 100; ++k) {
    const Vec<3> p1 = randomPoint<3>(rng, 3), p2 = randomPoint<3>(rng, 3), p3 = randomPoint<3>(rng, 3);
    const Vec<3> x = randomPoint<3>(rng, 3);
    const HalfSpace<3> plane = HalfSpace<3>::throughPoints(p1, p2, p3);
    const Vec<3> n = (p2 - p1).cross(p3 - p1);
    EXPECT_NEAR(plane.distance(x), (n.dot(x) - n.dot(p1)) / n.norm(), 1e-12);
    EXPECT_NEAR(plane.distance(p2), 0.0, 1e-12);
    EXPECT_NEAR(plane.distance(p3), 0.0, 1e-12);
  }
  EXPECT_THROW(HalfSpace<3>::throughPoints(Vec<3>(0, 0, 0), Vec<3>(1, 1, 1), Vec<3>(2, 2, 2)), std::invalid_argument);
  EXPECT_THROW(HalfSpace<3>::throughPoints(Vec<3>(0, 0, 0), Vec<3>(0, 0, 0), Vec<3>(0, 1, 0)), std::invalid_argument);
  EXPECT_THROW(HalfSpace<3>::throughPoints(Vec<3>(0, 0, 0), Vec<3>(1, 0, 0), Vec<3>(2, 1e-14, 0)),
               std::invalid_argument);
}

// ---- grids -------------------------------------------------------------------------

TEST(Primitives, GridsHoldTheDistancesAndVolumes) {
  const double h = 0.02;
  // Sphere / circle: values at nodes, crude area and volume.
  const Grid<2> circle = sphereGrid<2>(0.5, h);
  for (std::size_t n = 0; n < circle.size(); n += 7) {
    EXPECT_NEAR(circle[n], circle.nodePosition(circle.unlinear(n)).norm() - 0.5, 1e-6);
  }
  expectVolume("circle", smoothVolume(circle), kPi * 0.25, 0.01);
  expectVolume("sphere", smoothVolume(sphereGrid<3>(0.5, 0.025)), 4.0 / 3.0 * kPi * 0.125, 0.01);
  // Padding: the border is at least paddingCells cells from the shape.
  EXPECT_GE(circle.bounds().upper[0], 0.5 + kDefaultPaddingCells * h - 1e-12);
  // Rounded box: inner box (A x B) grown by r.
  const double r = 0.1;
  const Vec<2> he2(0.5, 0.3);
  const double A = 2 * (he2[0] - r), B = 2 * (he2[1] - r);
  expectVolume("rounded rectangle", smoothVolume(boxGrid<2>(he2, r, h)), A * B + 2 * r * (A + B) + kPi * r * r, 0.01);
  const Vec<3> he3(0.5, 0.3, 0.2);
  const double a = 2 * (he3[0] - r), b = 2 * (he3[1] - r), c = 2 * (he3[2] - r);
  const double boxVolume =
      a * b * c + 2 * r * (a * b + b * c + c * a) + kPi * r * r * (a + b + c) + 4.0 / 3.0 * kPi * r * r * r;
  expectVolume("rounded box", smoothVolume(boxGrid<3>(he3, r, h)), boxVolume, 0.01);
  // Ellipse / ellipsoid.
  expectVolume("ellipse", smoothVolume(ellipsoidGrid<2>(Vec<2>(1.0, 0.6), h)), kPi * 0.6, 0.01);
  const Vec<3> s(0.6, 0.45, 0.35);
  expectVolume("ellipsoid", smoothVolume(ellipsoidGrid<3>(s, h)), 4.0 / 3.0 * kPi * s.prod(), 0.01);
  // L-shaped polygon (area 3).
  const Grid<2> l = polygonGrid({{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}}, h);
  expectVolume("L polygon", smoothVolume(l), 3.0, 0.01);
}

TEST(Primitives, SuperellipseWithExponentTwoIsTheEllipse) {
  const double h = 0.02;
  const Vec<2> s2(1.0, 0.6);
  const Grid<2> super2 = superellipsoidGrid<2>(s2, {2.0}, h);
  const Grid<2> ellipse = ellipsoidGrid<2>(s2, h);
  ASSERT_TRUE((super2.dims() == ellipse.dims()).all());
  double worst = 0.0;
  for (std::size_t n = 0; n < ellipse.size(); ++n) {
    if (std::abs(ellipse[n]) < 2.0 * h) worst = std::max(worst, double(std::abs(super2[n] - ellipse[n])));
  }
  std::cout << "superellipse n = 2 vs ellipse within 2h: " << worst / h << " h\n";
  EXPECT_LT(worst, 0.1 * h);

  const Vec<3> s3(0.6, 0.45, 0.35);
  const double h3 = 0.03;
  const Grid<3> super3 = superellipsoidGrid<3>(s3, {2.0, 2.0}, h3);
  const Grid<3> ellipsoid = ellipsoidGrid<3>(s3, h3);
  ASSERT_TRUE((super3.dims() == ellipsoid.dims()).all());
  worst = 0.0;
  for (std::size_t n = 0; n < ellipsoid.size(); ++n) {
    if (std::abs(ellipsoid[n]) < 2.0 * h3) worst = std::max(worst, double(std::abs(super3[n] - ellipsoid[n])));
  }
  std::cout << "superellipsoid n = 2 vs ellipsoid within 2h: " << worst / h3 << " h\n";
  EXPECT_LT(worst, 0.1 * h3);
}

TEST(Primitives, SuperellipseAreasAndTheBoxLimit) {
  const double h = 0.01;
  const Vec<2> s(1.0, 0.6);
  for (double n : {1.5, 4.0, 10.0, 40.0}) {
    // Area 4ab Gamma(1 + 1/n)^2 / Gamma(1 + 2/n).
    const double exact = 4.0 * s.prod() * std::pow(std::tgamma(1.0 + 1.0 / n), 2) / std::tgamma(1.0 + 2.0 / n);
    const Grid<2> g = superellipsoidGrid<2>(s, {n}, h);
    expectVolume(("superellipse n = " + std::to_string(n)).c_str(), smoothVolume(g), exact, 0.01);
    if (n == 40.0) {
      EXPECT_NEAR(smoothVolume(g) / (4.0 * s.prod()), 1.0, 0.02);  // nearly the box
    }
    // The values are distances: |grad| = 1 by central differences in the band
    // 0 <= phi < 3h outside the shape (smooth there for a convex shape with
    // round corners, n >= 2).
    if (n < 2.0) continue;
    double worst = 0.0;
    for (std::size_t k = 0; k < g.size(); ++k) {
      const Index<2> i = g.unlinear(k);
      if ((i < 1).any() || (i >= g.dims() - 1).any() || g[k] < 0.0f || g[k] > 3 * h) continue;
      const double gx = (g.at(Index<2>(i[0] + 1, i[1])) - g.at(Index<2>(i[0] - 1, i[1]))) / (2 * h);
      const double gy = (g.at(Index<2>(i[0], i[1] + 1)) - g.at(Index<2>(i[0], i[1] - 1))) / (2 * h);
      worst = std::max(worst, std::abs(std::hypot(gx, gy) - 1.0));
    }
    std::cout << "superellipse n = " << n << ": max ||grad| - 1| outside within 3h " << worst << "\n";
    EXPECT_LT(worst, 0.05) << "n = " << n;
  }
  // 3D: volume formula with two exponents, and the box limit.
  const Vec<3> s3(0.6, 0.45, 0.35);
  for (const auto& [n1, n2] : {std::pair{2.0, 4.0}, {6.0, 3.0}, {20.0, 20.0}}) {
    const Grid<3> g = superellipsoidGrid<3>(s3, {n1, n2}, 0.025);
    expectVolume(("superellipsoid " + std::to_string(n1) + ", " + std::to_string(n2)).c_str(), smoothVolume(g),
                 superellipsoidVolume(s3, n1, n2), 0.01);
  }
  EXPECT_GT(superellipsoidVolume(s3, 20.0, 20.0) / (8.0 * s3.prod()), 0.9);
}

TEST(Primitives, GridParametersAreValidated) {
  EXPECT_THROW(sphereGrid<2>(-1.0, 0.1), std::invalid_argument);
  EXPECT_THROW(sphereGrid<3>(1.0, 0.0), std::invalid_argument);
  EXPECT_THROW(sphereGrid<3>(1.0, 0.1, -1), std::invalid_argument);
  EXPECT_THROW(sphereGrid<2>(1.0, 1e-9), std::invalid_argument);  // absurd node count
  EXPECT_THROW(boxGrid<2>(Vec<2>(1, 1), 2.0, 0.1), std::invalid_argument);
  EXPECT_THROW(ellipsoidGrid<3>(Vec<3>(1, 0, 1), 0.1), std::invalid_argument);
  EXPECT_THROW(superellipsoidGrid<2>(Vec<2>(1, 1), {2.0, 2.0}, 0.1), std::invalid_argument);
  EXPECT_THROW(superellipsoidGrid<3>(Vec<3>(1, 1, 1), {2.0}, 0.1), std::invalid_argument);
  EXPECT_THROW(superellipsoidGrid<2>(Vec<2>(1, 1), {0.0}, 0.1), std::invalid_argument);
  EXPECT_THROW(superellipsoidGrid<2>(Vec<2>(1, 1), {std::numeric_limits<double>::infinity()}, 0.1),
               std::invalid_argument);
  // An exception from the distance callable leaves sampleGrid cleanly.
  EXPECT_THROW(sampleGrid<2>(Box<2>{Vec<2>::Zero(), Vec<2>::Ones()}, 0.1, 2,
                             [](const Vec<2>& x) -> double {
                               if (x[0] > 0.5) throw std::runtime_error("bad node");
                               return 0.0;
                             }),
               std::runtime_error);
  EXPECT_THROW(sampleGrid<2>(Box<2>{Vec<2>::Ones(), Vec<2>::Zero()}, 0.1, 2, [](const Vec<2>&) { return 0.0; }),
               std::invalid_argument);
}
