#include "support/Sampling.h"
#include "lsdem/geometry/MassProperties.h"
#include "lsdem/geometry/Primitives.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>

#ifdef LSDEM_HAVE_OPENMP
#include <omp.h>
#endif

using namespace lsdem::geometry;
using lsdem::test::sampled;
using lsdem::test::boxAround;

namespace {

constexpr double kPi = std::numbers::pi;



Mat<2> rotation2(double angle) {
  return Eigen::Rotation2Dd(angle).toRotationMatrix();
}

Mat<3> rotation3() {
  return Eigen::AngleAxisd(0.7, Vec<3>(1, 2, 3).normalized()).toRotationMatrix();
}

double relErr(double value, double exact) { return std::abs(value - exact) / std::abs(exact); }

// Every entry of `m` within tol * scale of `exact`.
template <int D>
void expectMatrixNear(const Mat<D>& m, const Mat<D>& exact, double tol, double scale) {
  for (int r = 0; r < D; ++r)
    for (int c = 0; c < D; ++c) EXPECT_NEAR(m(r, c), exact(r, c), tol * scale) << "entry " << r << "," << c;
}

// Columns of `axes` parallel (either sign) to the columns of `rotation`.
template <int D>
void expectAxesMatch(const Mat<D>& axes, const Mat<D>& rotation) {
  for (int c = 0; c < D; ++c) EXPECT_GT(std::abs(axes.col(c).dot(rotation.col(c))), 0.999) << "axis " << c;
  EXPECT_NEAR(axes.determinant(), 1.0, 1e-12);
}

const Vec<3> kCentre3(0.013, -0.021, 0.007);
const Vec<2> kCentre2(0.013, -0.021);

// Sphere of radius R at kCentre3, `cells` cells across the diameter.
Grid<3> sphereGrid(double R, double cells) {
  return sampled<3>(boxAround<3>(kCentre3, R), 2 * R / cells, [R](const Vec<3>& x) { return (x - kCentre3).norm() - R; });
}

Grid<2> circleGrid(double R, double cells) {
  return sampled<2>(boxAround<2>(kCentre2, R), 2 * R / cells, [R](const Vec<2>& x) { return (x - kCentre2).norm() - R; });
}

}  // namespace

TEST(SmoothedHeaviside, Eq24) {
  const double e = 0.3;
  EXPECT_EQ(smoothedHeaviside(-0.31, e), 0.0);
  EXPECT_EQ(smoothedHeaviside(0.3, e), 1.0);
  EXPECT_EQ(smoothedHeaviside(5.0, e), 1.0);
  EXPECT_DOUBLE_EQ(smoothedHeaviside(0.0, e), 0.5);
  EXPECT_NEAR(smoothedHeaviside(-0.3, e), 0.0, 1e-15);
  // H(x) + H(-x) = 1 and the closed form at x = eps/2.
  for (double x : {0.01, 0.1, 0.2, 0.29}) EXPECT_NEAR(smoothedHeaviside(x, e) + smoothedHeaviside(-x, e), 1.0, 1e-14);
  EXPECT_NEAR(smoothedHeaviside(0.15, e), 0.5 * (1.5 + 1.0 / kPi), 1e-14);
  EXPECT_THROW(smoothedHeaviside(0.0, 0.0), std::invalid_argument);
  EXPECT_THROW(smoothedHeaviside(0.0, -1.0), std::invalid_argument);
}

// Sphere, 20 cells across, off-centre: the extrapolated estimate is within 0.5%
// and the paper's volume bias is the predicted 0.392 (eps/R)^2.
TEST(MassProperties, SphereExtrapolatedAndPaperBias) {
  const double R = 0.5;
  const Grid<3> g = sphereGrid(R, 20);
  const double V = 4.0 / 3.0 * kPi * R * R * R;
  const double I = 0.4 * V * R * R;

  const MassProperties<3> ex = massProperties(g);
  EXPECT_LT(relErr(ex.volume, V), 0.005);
  EXPECT_LT((ex.centroid - kCentre3).norm(), 0.005 * R);
  expectMatrixNear<3>(ex.inertiaTensor(), I * Mat<3>::Identity(), 0.005, I);
  EXPECT_NEAR(ex.secondMoment.trace(), 3 * 0.2 * V * R * R, 0.005 * 0.6 * V * R * R);

  const MassProperties<3> paper = massProperties(g, MassMethod::Paper);
  const double eps = 1.5 * g.spacing();
  const double predicted = 3.0 * (1.0 / 3.0 - 2.0 / (kPi * kPi)) * (eps / R) * (eps / R);
  EXPECT_NEAR(predicted, 0.392 * (eps / R) * (eps / R), 1e-3 * predicted);
  const double bias = (paper.volume - V) / V;
  EXPECT_NEAR(bias, predicted, 0.3 * predicted);
  EXPECT_LT((paper.centroid - kCentre3).norm(), 0.005 * R);
  std::printf("sphere 20 cells: extrapolated volume error %.3e, inertia error %.3e; paper volume error %.3e (predicted %.3e)\n",
              (ex.volume - V) / V, (ex.inertiaTensor()(0, 0) - I) / I, bias, predicted);
}

// Rotated ellipsoid (0.6, 0.4, 0.3), 20 cells across the smallest axis:
// S = V/5 R diag(a^2) R^T.
TEST(MassProperties, RotatedEllipsoid) {
  const Vec<3> a(0.6, 0.4, 0.3);
  const Mat<3> rot = rotation3();
  const Grid<3> g = sampled<3>(boxAround<3>(kCentre3, 0.6), 0.03, [&](const Vec<3>& x) {
    return sdfEllipsoid<3>(rot.transpose() * (x - kCentre3), a);
  });
  const double V = 4.0 / 3.0 * kPi * a.prod();
  const Mat<3> S = V / 5.0 * rot * a.cwiseAbs2().asDiagonal() * rot.transpose();
  const MassProperties<3> mp = massProperties(g);
  EXPECT_LT(relErr(mp.volume, V), 0.005);
  EXPECT_LT((mp.centroid - kCentre3).norm(), 0.005 * a[2]);
  const Mat<3> Iexact = S.trace() * Mat<3>::Identity() - S;
  expectMatrixNear<3>(mp.inertiaTensor(), Iexact, 0.005, Iexact.diagonal().maxCoeff());
  const Vec<3> lambda = mp.principalSecondMoments();
  for (int i = 0; i < 3; ++i) EXPECT_LT(relErr(lambda[i], V / 5.0 * a[i] * a[i]), 0.005) << i;
  const Vec<3> pin = mp.principalInertia();
  EXPECT_LT(relErr(pin[0], V / 5.0 * (a[1] * a[1] + a[2] * a[2])), 0.005);
  EXPECT_LT(relErr(pin[2], V / 5.0 * (a[0] * a[0] + a[1] * a[1])), 0.005);
  expectAxesMatch<3>(mp.principalAxes(), rot);
  std::printf("ellipsoid: volume error %.3e, lambda errors %.3e %.3e %.3e\n", (mp.volume - V) / V,
              relErr(lambda[0], V / 5 * a[0] * a[0]), relErr(lambda[1], V / 5 * a[1] * a[1]),
              relErr(lambda[2], V / 5 * a[2] * a[2]));
}

// Rotated box (half extents 0.5, 0.4, 0.3): S = V/3 R diag(half^2) R^T.
TEST(MassProperties, RotatedBox) {
  const Vec<3> half(0.5, 0.4, 0.3);
  const Mat<3> rot = rotation3();
  const Grid<3> g = sampled<3>(boxAround<3>(kCentre3, half.norm()), 0.03, [&](const Vec<3>& x) {
    return sdfBox<3>(rot.transpose() * (x - kCentre3), half);
  });
  const double V = 8.0 * half.prod();
  const Mat<3> S = V / 3.0 * rot * half.cwiseAbs2().asDiagonal() * rot.transpose();
  const MassProperties<3> mp = massProperties(g);
  EXPECT_LT(relErr(mp.volume, V), 0.005);
  EXPECT_LT((mp.centroid - kCentre3).norm(), 0.005 * half[2]);
  const Mat<3> Iexact = S.trace() * Mat<3>::Identity() - S;
  expectMatrixNear<3>(mp.inertiaTensor(), Iexact, 0.005, Iexact.diagonal().maxCoeff());
  expectAxesMatch<3>(mp.principalAxes(), rot);
  std::printf("box: volume error %.3e, inertia error (max entry / max diag) %.3e\n", (mp.volume - V) / V,
              (mp.inertiaTensor() - Iexact).cwiseAbs().maxCoeff() / Iexact.diagonal().maxCoeff());
}

// 2D: circle, rotated ellipse and rotated rectangle; area, centroid, polar moment (eq. 30).
TEST(MassProperties, Circle) {
  const double R = 0.5;
  const MassProperties<2> mp = massProperties(circleGrid(R, 20));
  const double A = kPi * R * R;
  EXPECT_LT(relErr(mp.volume, A), 0.005);
  EXPECT_LT((mp.centroid - kCentre2).norm(), 0.005 * R);
  EXPECT_LT(relErr(mp.polarMoment(), 0.5 * A * R * R), 0.005);
  expectMatrixNear<2>(mp.secondMoment, 0.25 * A * R * R * Mat<2>::Identity(), 0.005, 0.25 * A * R * R);
}

TEST(MassProperties, RotatedEllipse) {
  const Vec<2> a(0.6, 0.3);
  const Mat<2> rot = rotation2(0.4);
  const Grid<2> g = sampled<2>(boxAround<2>(kCentre2, 0.6), 0.03, [&](const Vec<2>& x) {
    return sdfEllipsoid<2>(rot.transpose() * (x - kCentre2), a);
  });
  const MassProperties<2> mp = massProperties(g);
  const double A = kPi * a.prod();
  EXPECT_LT(relErr(mp.volume, A), 0.005);
  EXPECT_LT((mp.centroid - kCentre2).norm(), 0.005 * a[1]);
  EXPECT_LT(relErr(mp.polarMoment(), A * a.squaredNorm() / 4.0), 0.005);
  const Vec<2> lambda = mp.principalSecondMoments();
  EXPECT_LT(relErr(lambda[0], A * a[0] * a[0] / 4.0), 0.005);
  EXPECT_LT(relErr(lambda[1], A * a[1] * a[1] / 4.0), 0.005);
  expectAxesMatch<2>(mp.principalAxes(), rot);
  // In 2D, principalInertia = tr(S) - S_i: the moments about the in-plane principal axes.
  EXPECT_LT(relErr(mp.principalInertia()[0], A * a[1] * a[1] / 4.0), 0.005);
}

TEST(MassProperties, RotatedRectangle) {
  const Vec<2> half(0.5, 0.3);
  const Mat<2> rot = rotation2(-0.9);
  const Grid<2> g = sampled<2>(boxAround<2>(kCentre2, half.norm()), 0.03, [&](const Vec<2>& x) {
    return sdfBox<2>(rot.transpose() * (x - kCentre2), half);
  });
  const MassProperties<2> mp = massProperties(g);
  const double A = 4.0 * half.prod();
  EXPECT_LT(relErr(mp.volume, A), 0.005);
  EXPECT_LT((mp.centroid - kCentre2).norm(), 0.005 * half[1]);
  EXPECT_LT(relErr(mp.polarMoment(), A * half.squaredNorm() / 3.0), 0.005);
  const Mat<2> S = A / 3.0 * rot * half.cwiseAbs2().asDiagonal() * rot.transpose();
  expectMatrixNear<2>(mp.secondMoment, S, 0.005, S.diagonal().maxCoeff());
  expectAxesMatch<2>(mp.principalAxes(), rot);
}

// Observed order at 10 and 20 cells across: the paper's volume error falls
// like h^2; the extrapolated error is below the paper's at both.
TEST(MassProperties, ConvergenceOrder) {
  const double R = 0.5;
  const double V = 4.0 / 3.0 * kPi * R * R * R, A = kPi * R * R;
  double paper3[2], extra3[2], paper2[2], extra2[2];
  for (int k = 0; k < 2; ++k) {
    const double cells = (k == 0) ? 10.0 : 20.0;
    const Grid<3> g3 = sphereGrid(R, cells);
    paper3[k] = relErr(massProperties(g3, MassMethod::Paper).volume, V);
    extra3[k] = relErr(massProperties(g3).volume, V);
    const Grid<2> g2 = circleGrid(R, cells);
    paper2[k] = relErr(massProperties(g2, MassMethod::Paper).volume, A);
    extra2[k] = relErr(massProperties(g2).volume, A);
    EXPECT_LT(extra3[k], paper3[k]);
    EXPECT_LT(extra2[k], paper2[k]);
  }
  const double order3 = std::log2(paper3[0] / paper3[1]);
  const double order2 = std::log2(paper2[0] / paper2[1]);
  EXPECT_GT(order3, 1.7);
  EXPECT_GT(order2, 1.7);
  std::printf("sphere volume error 10/20 cells: paper %.3e %.3e (order %.2f), extrapolated %.3e %.3e\n", paper3[0],
              paper3[1], order3, extra3[0], extra3[1]);
  std::printf("circle area error 10/20 cells: paper %.3e %.3e (order %.2f), extrapolated %.3e %.3e\n", paper2[0],
              paper2[1], order2, extra2[0], extra2[1]);
}

// The same ellipse in metres and in millimetres: volume scales as h^D,
// centroid as h, second moments as h^(D+2).
TEST(MassProperties, SpacingInvariance) {
  const Vec<2> a(0.6, 0.3);
  const Mat<2> rot = rotation2(0.4);
  auto make = [&](double unit) {
    return sampled<2>(boxAround<2>(unit * kCentre2, unit * 0.6), unit * 0.03, [&](const Vec<2>& x) {
      return unit * sdfEllipsoid<2>(rot.transpose() * (x / unit - kCentre2), a);
    });
  };
  for (MassMethod method : {MassMethod::Paper, MassMethod::Extrapolated}) {
    const MassProperties<2> m = massProperties(make(1.0), method);
    const MassProperties<2> mm = massProperties(make(1000.0), method);
    EXPECT_NEAR(mm.volume / 1e6, m.volume, 1e-6 * m.volume);
    EXPECT_LT((mm.centroid / 1e3 - m.centroid).norm(), 1e-6);
    expectMatrixNear<2>(mm.secondMoment / 1e12, m.secondMoment, 1e-6, m.secondMoment.norm());
  }
  const Grid<3> s = sphereGrid(0.5, 12);
  Grid<3> smm(s.dims(), 1000.0 * s.origin(), 1000.0 * s.spacing());
  for (std::size_t n = 0; n < s.size(); ++n) smm[n] = 1000.0f * s[n];
  const MassProperties<3> m = massProperties(s), mm = massProperties(smm);
  EXPECT_NEAR(mm.volume / 1e9, m.volume, 1e-6 * m.volume);
  EXPECT_LT((mm.centroid / 1e3 - m.centroid).norm(), 1e-6);
  expectMatrixNear<3>(mm.secondMoment / 1e15, m.secondMoment, 1e-6, m.secondMoment.norm());
}

// Principal axes: a right-handed frame, descending second moments, signs fixed.
TEST(MassProperties, PrincipalAxesConventions) {
  MassProperties<3> mp;
  mp.volume = 1.0;
  const Mat<3> rot = rotation3();
  mp.secondMoment = rot * Vec<3>(1.0, 3.0, 2.0).asDiagonal() * rot.transpose();
  const Mat<3> axes = mp.principalAxes();
  const Vec<3> lambda = mp.principalSecondMoments();
  EXPECT_NEAR(lambda[0], 3.0, 1e-12);
  EXPECT_NEAR(lambda[1], 2.0, 1e-12);
  EXPECT_NEAR(lambda[2], 1.0, 1e-12);
  EXPECT_NEAR(axes.determinant(), 1.0, 1e-12);
  EXPECT_LT((axes.transpose() * axes - Mat<3>::Identity()).norm(), 1e-12);
  EXPECT_LT((axes.transpose() * mp.secondMoment * axes - Mat<3>(lambda.asDiagonal())).norm(), 1e-12);
  for (int c = 0; c < 2; ++c) {
    Eigen::Index big;
    axes.col(c).cwiseAbs().maxCoeff(&big);
    EXPECT_GT(axes(big, c), 0.0);
  }
  // The same S negated-and-restored gives the same axes (deterministic signs).
  MassProperties<3> copy = mp;
  copy.secondMoment = -(-mp.secondMoment);
  EXPECT_EQ(copy.principalAxes(), axes);
  const Vec<3> pin = mp.principalInertia();
  EXPECT_NEAR(pin[0], 6.0 - 3.0, 1e-12);
  EXPECT_NEAR(pin[2], 6.0 - 1.0, 1e-12);
  EXPECT_NEAR(mp.polarMoment(), 6.0, 1e-12);
  // 2D: the second column is the first turned by +90 degrees.
  MassProperties<2> m2;
  m2.secondMoment = rotation2(2.5) * Vec<2>(4.0, 1.0).asDiagonal() * rotation2(2.5).transpose();
  const Mat<2> a2 = m2.principalAxes();
  EXPECT_NEAR(a2.determinant(), 1.0, 1e-12);
  EXPECT_NEAR(std::abs(a2.col(0).dot(rotation2(2.5).col(0))), 1.0, 1e-12);
  EXPECT_NEAR(m2.principalSecondMoments()[0], 4.0, 1e-12);
}

// Bitwise identical results for 1 and 2 threads.
TEST(MassProperties, DeterministicAcrossThreadCounts) {
  const Grid<3> g = sphereGrid(0.5, 16);
#ifdef LSDEM_HAVE_OPENMP
  const int saved = omp_get_max_threads();
  omp_set_num_threads(1);
#endif
  const MassProperties<3> one = massProperties(g);
#ifdef LSDEM_HAVE_OPENMP
  omp_set_num_threads(2);
#endif
  const MassProperties<3> two = massProperties(g);
#ifdef LSDEM_HAVE_OPENMP
  omp_set_num_threads(saved);
#endif
  EXPECT_EQ(std::memcmp(&one.volume, &two.volume, sizeof(double)), 0);
  EXPECT_TRUE(one.centroid == two.centroid);
  EXPECT_TRUE(one.secondMoment == two.secondMoment);
}

// A fragment smaller than the smoothing band still gets positive, finite
// properties (the extrapolation falls back to the paper's estimate).
TEST(MassProperties, TinyShapeStaysPhysical) {
  for (double R : {0.2, 0.5, 1.0}) {  // radius in cells
    const Grid<3> g = sampled<3>(boxAround<3>(kCentre3, 0.1), 0.1 / R, [R](const Vec<3>& x) {
      return (x - kCentre3).norm() - 0.1;
    });
    const MassProperties<3> mp = massProperties(g);
    EXPECT_GT(mp.volume, 0.0) << R;
    EXPECT_TRUE(mp.secondMoment.allFinite());
    EXPECT_GT(mp.principalSecondMoments()[2], 0.0) << R;
    EXPECT_LT((mp.centroid - kCentre3).norm(), 0.1 / R) << R;
  }
}

TEST(MassProperties, RejectsBadInput) {
  EXPECT_THROW(massProperties(Grid<3>()), std::invalid_argument);
  Grid<2> outside(Index<2>(10, 10), Vec<2>::Zero(), 0.1, 1.0f);
  EXPECT_THROW(massProperties(outside), std::invalid_argument);
  const Grid<2> c = circleGrid(0.5, 10);
  EXPECT_THROW(massProperties(c, MassMethod::Extrapolated, 0.0), std::invalid_argument);
  EXPECT_THROW(massProperties(c, MassMethod::Paper, -1.0), std::invalid_argument);
  Grid<2> nan = c;
  nan[nan.size() / 2] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(massProperties(nan), std::invalid_argument);
}

// Cost of one evaluation on a 64^3 grid (reported, not asserted).
TEST(MassProperties, Timing64Cubed) {
  const Grid<3> g = sampled<3>(boxAround<3>(Vec<3>::Zero(), 0.5), 1.0 / 55.0,
                               [](const Vec<3>& x) { return x.norm() - 0.5; });
  ASSERT_GE(g.dims()[0], 63);
  const auto t0 = std::chrono::steady_clock::now();
  const int reps = 5;
  double v = 0.0;
  for (int r = 0; r < reps; ++r) v += massProperties(g).volume;
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count() / reps;
  EXPECT_GT(v, 0.0);
  std::printf("massProperties on %dx%dx%d: %.2f ms\n", g.dims()[0], g.dims()[1], g.dims()[2], ms);
}
