#include "lsdem/dynamics/Motion.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <string>

using namespace lsdem;
using namespace lsdem::dynamics;

namespace {

constexpr double kPi = std::numbers::pi;

// Rotation vector (axis x angle) of a unit quaternion, shortest arc.
Vec<3> rotationVector(Eigen::Quaterniond q) {
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  const double s = q.vec().norm();
  return s == 0.0 ? Vec<3>::Zero() : Vec<3>((2.0 * std::atan2(s, q.w()) / s) * q.vec());
}

// Angle between two orientations, rad.
double angleBetween(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return rotationVector(a * b.conjugate()).norm();
}

// World angular velocity by central differences of the orientation.
Spin<2> spinByDifference(double before, double after, double h) { return (after - before) / (2 * h); }
Spin<3> spinByDifference(const Eigen::Quaterniond& before, const Eigen::Quaterniond& after, double h) {
  return rotationVector(after * before.conjugate()) / (2 * h);
}

double norm(double v) { return std::abs(v); }
double norm(const Vec<3>& v) { return v.norm(); }

// The velocity and angular velocity a motion reports equal the central
// differences of its pose, relative 1e-6 of the motion's speed scale, at each time.
template <int D, class M>
void expectVelocitiesAreDerivatives(const M& motion, const std::vector<double>& times, double h, double speedScale,
                                    double spinScale) {
  for (double t : times) {
    const KinematicState<D> s = evaluate(motion, t);
    const KinematicState<D> a = evaluate(motion, t - h);
    const KinematicState<D> b = evaluate(motion, t + h);
    const Vec<D> v = (b.position - a.position) / (2 * h);
    const Spin<D> w = spinByDifference(a.orientation, b.orientation, h);
    EXPECT_LE((v - s.velocity).norm(), 1e-6 * std::max(s.velocity.norm(), speedScale)) << "t = " << t;
    EXPECT_LE(norm(w - s.angularVelocity), 1e-6 * std::max(norm(s.angularVelocity), spinScale)) << "t = " << t;
  }
}

std::vector<double> sampleTimes(double t0, double t1, int n) {
  std::vector<double> t;
  for (int i = 0; i < n; ++i) t.push_back(t0 + (t1 - t0) * (i + 0.5) / n);
  return t;
}

Eigen::Quaterniond axisAngle(double angle, const Vec<3>& axis) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, axis.normalized()));
}

// Expects a one-line std::invalid_argument whose message names `name`.
template <class F>
void expectInvalid(F&& f, const std::string& name) {
  try {
    f();
    ADD_FAILURE() << "no exception for " << name;
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(name), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
}

}  // namespace

// ---------------------------------------------------------------------------
// ConstantVelocity
// ---------------------------------------------------------------------------

TEST(Motion, ConstantVelocityIsExactAndConsistent2D) {
  ConstantVelocity<2> m;
  m.position = Vec<2>(1.0, -2.0);
  m.orientation = 0.3;
  m.velocity = Vec<2>(0.5, 0.25);
  m.angularVelocity = -1.5;
  validate(m);
  const KinematicState<2> s = evaluate(m, 2.0);
  EXPECT_NEAR((s.position - Vec<2>(2.0, -1.5)).norm(), 0.0, 1e-15);
  EXPECT_NEAR(s.orientation, 0.3 - 3.0, 1e-15);
  expectVelocitiesAreDerivatives<2>(m, sampleTimes(-1.0, 3.0, 50), 1e-5, 0.5, 1.5);
}

TEST(Motion, ConstantVelocityIsExactAndConsistent3D) {
  ConstantVelocity<3> m;
  m.position = Vec<3>(1.0, -2.0, 0.5);
  m.orientation = axisAngle(0.7, Vec<3>(1, 2, 3));
  m.velocity = Vec<3>(0.5, 0.25, -1.0);
  m.angularVelocity = Vec<3>(0.3, -0.4, 1.2);
  validate(m);
  const double t = 1.7;
  const KinematicState<3> s = evaluate(m, t);
  EXPECT_NEAR((s.position - (m.position + t * m.velocity)).norm(), 0.0, 1e-14);
  // The body turned by |w| t about w, in the world frame.
  const Vec<3> turned = rotationVector(s.orientation * m.orientation.conjugate());
  EXPECT_NEAR((turned - t * m.angularVelocity).norm(), 0.0, 1e-12);
  expectVelocitiesAreDerivatives<3>(m, sampleTimes(-1.0, 3.0, 50), 1e-5, 1.0, 1.0);
}

// ---------------------------------------------------------------------------
// Swing
// ---------------------------------------------------------------------------

TEST(Motion, SwingAmplitudePeriodAndDerivatives2D) {
  Swing<2> m;
  m.pivot = Vec<2>(0.0, 1.0);
  m.position = Vec<2>(0.0, 0.0);  // hangs 1 m below the pivot
  m.orientation = 0.2;
  m.meanAngle = 0.1;
  m.amplitude = 0.3;
  m.frequency = 2.5;
  m.phase = 0.4;
  validate(m);
  const double period = 1.0 / m.frequency;

  // Extremes exactly at the sine's peaks; the reference point stays on the arc.
  const double tPeak = (kPi / 2 - m.phase) / (2 * kPi * m.frequency);
  const double tTrough = tPeak + period / 2;
  EXPECT_NEAR(evaluate(m, tPeak).orientation - m.orientation, m.meanAngle + m.amplitude, 1e-15);
  EXPECT_NEAR(evaluate(m, tTrough).orientation - m.orientation, m.meanAngle - m.amplitude, 1e-15);
  EXPECT_NEAR(std::abs(evaluate(m, tPeak).angularVelocity), 0.0, 1e-14);
  double lo = 1e9, hi = -1e9;
  for (double t : sampleTimes(0.0, period, 4000)) {
    const KinematicState<2> s = evaluate(m, t);
    lo = std::min(lo, s.orientation - m.orientation);
    hi = std::max(hi, s.orientation - m.orientation);
    EXPECT_NEAR((s.position - m.pivot).norm(), 1.0, 1e-14);
    // Periodic with period 1 / f.
    const KinematicState<2> later = evaluate(m, t + 3 * period);
    EXPECT_NEAR((later.position - s.position).norm(), 0.0, 1e-13);
    EXPECT_NEAR(later.orientation - s.orientation, 0.0, 1e-13);
  }
  EXPECT_GE(lo, m.meanAngle - m.amplitude - 1e-15);
  EXPECT_LE(hi, m.meanAngle + m.amplitude + 1e-15);
  EXPECT_NEAR(hi - lo, 2 * m.amplitude, 1e-6);

  const double spinScale = m.amplitude * 2 * kPi * m.frequency;
  expectVelocitiesAreDerivatives<2>(m, sampleTimes(0.0, 2 * period, 200), 1e-6, spinScale, spinScale);
}

TEST(Motion, SwingAboutAnAxisIn3D) {
  Swing<3> m;
  m.pivot = Vec<3>(1.0, 2.0, 3.0);
  m.axis = Vec<3>(1.0, 1.0, 0.0);  // normalised on use
  m.position = Vec<3>(1.0, 2.0, 2.0);
  m.orientation = axisAngle(0.5, Vec<3>(0, 1, 1));
  m.meanAngle = -0.2;
  m.amplitude = 0.6;
  m.frequency = 0.75;
  validate(m);
  const double period = 1.0 / m.frequency;
  const Vec<3> axis = m.axis.normalized();

  for (double t : sampleTimes(0.0, period, 500)) {
    const KinematicState<3> s = evaluate(m, t);
    // The body is the pose at angle 0 turned by angle(t) about the axis.
    const double angle = m.meanAngle + m.amplitude * std::sin(2 * kPi * m.frequency * t);
    const Vec<3> turned = rotationVector(s.orientation * m.orientation.conjugate());
    EXPECT_NEAR((turned - angle * axis).norm(), 0.0, 1e-12);
    EXPECT_NEAR((s.position - m.pivot).norm(), 1.0, 1e-14);
    EXPECT_NEAR(axis.dot(s.position - m.position), 0.0, 1e-14);  // the arc lies in a plane normal to the axis
    // The angular velocity is along the axis.
    EXPECT_NEAR(s.angularVelocity.cross(axis).norm(), 0.0, 1e-14);
    const KinematicState<3> later = evaluate(m, t + period);
    EXPECT_NEAR((later.position - s.position).norm(), 0.0, 1e-13);
    EXPECT_NEAR(angleBetween(later.orientation, s.orientation), 0.0, 1e-12);
  }
  const double spinScale = m.amplitude * 2 * kPi * m.frequency;
  expectVelocitiesAreDerivatives<3>(m, sampleTimes(0.0, 2 * period, 200), 1e-6, spinScale, spinScale);
}

// ---------------------------------------------------------------------------
// JawCrusher
// ---------------------------------------------------------------------------

namespace {

// The swing jaw's face ends recovered from its body pose (see JawCrusher).
template <int D>
void jawFaceFromPose(const JawCrusher<D>& j, const KinematicState<D>& s, Vec<D>& top, Vec<D>& bottom) {
  Vec<D> x = Vec<D>::Zero(), y = Vec<D>::Zero();
  x[0] = 0.5 * j.jawLength;
  y[1] = 0.5 * j.jawThickness;
  top = s.toWorld(x + y);
  bottom = s.toWorld(-x + y);
}

template <int D>
void checkJawCrusher(const JawCrusher<D>& j) {
  validate(j);
  const double period = crusherPeriod(j);
  EXPECT_NEAR(period, 60.0 / j.rpm, 1e-15);
  const double css = j.closedSideSetting, oss = css + j.eccentricThrow;
  const double nip = j.nipAngleDegrees * kPi / 180, dnip = j.nipAngleVariationDegrees * kPi / 180;

  // Stationary face: a line through stationaryBottom with direction up; the chamber on the side `across`.
  const double a = j.stationaryAngleDegrees * kPi / 180;
  Vec<D> up = Vec<D>::Zero(), across = Vec<D>::Zero();
  up[0] = std::cos(a);
  up[1] = std::sin(a);
  across[0] = up[1];
  across[1] = -up[0];
  const Vec<D> shaft = shaftCentre(j);
  const double r = eccentricRadius(j);

  // Exact extremes: OSS at psi = 0, CSS at psi = pi.
  const double tOpen = -j.phase / (2 * kPi * j.rpm / 60);
  EXPECT_NEAR(dischargeGap(j, tOpen), oss, 1e-12);
  EXPECT_NEAR(dischargeGap(j, tOpen + period / 2), css, 1e-12);
  EXPECT_NEAR(nipAngle(j, tOpen), nip + dnip, 1e-14);
  EXPECT_NEAR(nipAngle(j, tOpen + period / 2), nip - dnip, 1e-14);
  // At the CSS the jaw moves straight down (the usual sense of the eccentric), at the OSS straight up.
  const double rate = 2 * kPi * j.rpm / 60;
  const KinematicState<D> closed = evaluate(j, tOpen + period / 2), open = evaluate(j, tOpen);
  EXPECT_NEAR((closed.velocityAt(swingJawTop(j, tOpen + period / 2)) + r * rate * up).norm(), 0.0, 1e-12);
  EXPECT_NEAR((open.velocityAt(swingJawTop(j, tOpen)) - r * rate * up).norm(), 0.0, 1e-12);

  double gapLo = 1e9, gapHi = -1e9, nipLo = 1e9, nipHi = -1e9;
  for (double t : sampleTimes(0.0, period, 2000)) {
    const KinematicState<D> s = evaluate(j, t);
    Vec<D> top, bottom;
    jawFaceFromPose(j, s, top, bottom);
    // The pose's face ends are the helpers' T and B; the gap is B's distance to the stationary line.
    EXPECT_NEAR((top - swingJawTop(j, t)).norm(), 0.0, 1e-12);
    EXPECT_NEAR((bottom - swingJawBottom(j, t)).norm(), 0.0, 1e-12);
    const double gap = across.dot(bottom - j.stationaryBottom);
    EXPECT_NEAR(gap, dischargeGap(j, t), 1e-12);
    // The nip angle is the angle between the faces.
    const double beta = std::acos(std::clamp(up.dot((top - bottom).normalized()), -1.0, 1.0));
    EXPECT_NEAR(beta, nipAngle(j, t), 1e-9);
    // The eccentric pin moves on its circle about the shaft.
    EXPECT_NEAR((top - shaft).norm(), r, 1e-12);
    if constexpr (D == 3) {
      EXPECT_NEAR(s.position[2], j.stationaryBottom[2], 1e-15);
    }
    // Periodic.
    EXPECT_NEAR(dischargeGap(j, t + 2 * period), gap, 1e-12);
    // The pin passes over the shaft while closing (psi in (0, pi)) and under it while opening.
    const double psi = std::remainder(eccentricAngle(j, t), 2 * kPi);
    const double pinHeight = up.dot(top - shaft);
    if (psi > 0.01 && psi < kPi - 0.01) {
      EXPECT_GT(pinHeight, 0.0);
    }
    if (psi < -0.01 && psi > -kPi + 0.01) {
      EXPECT_LT(pinHeight, 0.0);
    }
    gapLo = std::min(gapLo, gap);
    gapHi = std::max(gapHi, gap);
    nipLo = std::min(nipLo, beta);
    nipHi = std::max(nipHi, beta);
  }
  EXPECT_GE(gapLo, css - 1e-12);
  EXPECT_LE(gapHi, oss + 1e-12);
  EXPECT_NEAR(gapLo, css, 1e-5);
  EXPECT_NEAR(gapHi, oss, 1e-5);
  EXPECT_GE(nipLo, nip - dnip - 1e-9);
  EXPECT_LE(nipHi, nip + dnip + 1e-9);
  EXPECT_NEAR(nipHi - nipLo, 2 * dnip, 1e-6);

  // Velocities are the exact derivatives of the pose.
  expectVelocitiesAreDerivatives<D>(j, sampleTimes(0.0, period, 200), 1e-7, r * rate, dnip * rate);

  // The stationary plate: its face side (body y = +thickness/2) holds the stationary face,
  // its body y is the face's normal into the chamber, and it is at rest.
  const KinematicState<D> fixed = stationaryJawState(j);
  Vec<D> x = Vec<D>::Zero(), y = Vec<D>::Zero();
  x[0] = 0.5 * j.jawLength;
  y[1] = 0.5 * j.jawThickness;
  EXPECT_NEAR((fixed.toWorld(x + y) - j.stationaryBottom).norm(), 0.0, 1e-12);
  EXPECT_NEAR((fixed.toWorld(-x + y) - (j.stationaryBottom + j.jawLength * up)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((fixed.toWorld(2 * y) - fixed.toWorld(y) - 0.5 * j.jawThickness * across).norm(), 0.0, 1e-12);
  EXPECT_EQ(fixed.velocity.norm(), 0.0);
}

}  // namespace

// Table 1 settings (300 rpm, 50 mm throw, 22 +/- 1.7 degrees), CSS 50 mm.
TEST(Motion, JawCrusherTable1GapAndNipAngle2D) {
  JawCrusher<2> j;
  EXPECT_NEAR(crusherPeriod(j), 0.2, 1e-15);
  checkJawCrusher(j);
  // Without nip-angle variation the eccentric radius is half the throw.
  j.nipAngleVariationDegrees = 0.0;
  EXPECT_NEAR(eccentricRadius(j), 0.025, 1e-15);
  checkJawCrusher(j);
}

TEST(Motion, JawCrusherOtherSettingsAndOrientation) {
  JawCrusher<2> j;
  j.closedSideSetting = 0.1;
  j.rpm = 250;
  j.jawLength = 1.4;
  j.stationaryAngleDegrees = 97.0;
  j.stationaryBottom = Vec<2>(0.3, -0.2);
  j.phase = 1.1;
  checkJawCrusher(j);

  // 3D: the same motion in the xy plane, extruded along z (in the jaw's own
  // body frame, which the checks read: a plate's principal frame is turned
  // into it by default, below).
  JawCrusher<3> k;
  EXPECT_TRUE(k.plateFrame.isApprox(plateFrame3D()));
  k.plateFrame = Rotation<3>::identity();
  k.closedSideSetting = 0.08;
  k.stationaryAngleDegrees = 85.0;
  k.stationaryBottom = Vec<3>(0.1, 0.2, 0.5);
  checkJawCrusher(k);
  JawCrusher<2> flat;
  flat.closedSideSetting = 0.08;
  flat.stationaryAngleDegrees = 85.0;
  flat.stationaryBottom = Vec<2>(0.1, 0.2);
  for (double t : sampleTimes(0.0, 0.2, 20)) EXPECT_NEAR(dischargeGap(k, t), dischargeGap(flat, t), 1e-15);

  // A 3D plate (principal frame: length x, width y, thickness z) posed with
  // plateFrame3D: its thickness axis is the jaw's face normal, its width
  // out of the plane, its length along the face, at every time; the centre
  // and the velocities are the jaw's. (Without it the width stood where the
  // thickness belongs.)
  JawCrusher<3> plate = k;
  plate.plateFrame = plateFrame3D();
  for (double t : sampleTimes(0.0, 0.2, 20)) {
    const KinematicState<3> jaw = evaluate(k, t), p = evaluate(plate, t);
    const geometry::Mat<3> J = Rotation<3>::matrix(jaw.orientation), P = Rotation<3>::matrix(p.orientation);
    EXPECT_NEAR((P.col(0) - J.col(0)).norm(), 0.0, 1e-12);  // length along the face
    EXPECT_NEAR((P.col(2) - J.col(1)).norm(), 0.0, 1e-12);  // thickness: the face normal
    EXPECT_NEAR(std::abs(P.col(1).dot(Vec<3>::UnitZ())), 1.0, 1e-12);  // width out of the plane
    EXPECT_EQ(p.position, jaw.position);
    EXPECT_EQ(p.velocity, jaw.velocity);
    EXPECT_EQ(p.angularVelocity, jaw.angularVelocity);
  }
}

// ---------------------------------------------------------------------------
// KeyFramed
// ---------------------------------------------------------------------------

TEST(Motion, KeyFramedPassesThroughFramesIsC1AndHolds2D) {
  KeyFramed<2> m;
  m.frames = {{0.0, Vec<2>(0, 0), 0.0},
              {0.5, Vec<2>(1, 0.5), 0.4},
              {1.7, Vec<2>(1.5, -1), -0.3},
              {2.0, Vec<2>(3, 0), 6.0},
              {3.1, Vec<2>(3, 2), 6.5}};
  validate(m);
  for (const auto& f : m.frames) {
    const KinematicState<2> s = evaluate(m, f.time);
    EXPECT_EQ((s.position - f.position).norm(), 0.0) << f.time;
    EXPECT_EQ(s.orientation, f.orientation) << f.time;
  }
  // Holds: before the first frame and after the last, at rest.
  const KinematicState<2> before = evaluate(m, -4.0), after = evaluate(m, 10.0);
  EXPECT_EQ((before.position - m.frames.front().position).norm(), 0.0);
  EXPECT_EQ((after.position - m.frames.back().position).norm(), 0.0);
  EXPECT_EQ(after.orientation, m.frames.back().orientation);
  EXPECT_EQ(after.velocity.norm() + std::abs(after.angularVelocity), 0.0);
  EXPECT_EQ(before.velocity.norm() + std::abs(before.angularVelocity), 0.0);

  // C1: position and velocity continuous across every frame (including the ends).
  const double eps = 1e-9;
  for (const auto& f : m.frames) {
    const KinematicState<2> l = evaluate(m, f.time - eps), r = evaluate(m, f.time + eps);
    EXPECT_LT((l.position - r.position).norm(), 1e-7);
    EXPECT_LT((l.velocity - r.velocity).norm(), 1e-6) << f.time;
  }
  // Velocities are derivatives (away from the frames, where the spin jumps).
  std::vector<double> times;
  for (double t : sampleTimes(0.0, 3.1, 300)) {
    bool nearFrame = false;
    for (const auto& f : m.frames) nearFrame |= std::abs(t - f.time) < 1e-3;
    if (!nearFrame) times.push_back(t);
  }
  expectVelocitiesAreDerivatives<2>(m, times, 1e-6, 1.0, 1.0);
}

// The inner tangents are the slopes of the parabola through three frames: for
// frames sampled from a quadratic path at uneven times, the velocity at an inner
// frame is the path's exact derivative.
TEST(Motion, KeyFramedInnerTangentsAreExactForQuadratics) {
  const auto path = [](double t) { return Vec<3>(1 + 2 * t - 3 * t * t, -t + 0.5 * t * t, 4.0); };
  const auto slope = [](double t) { return Vec<3>(2 - 6 * t, -1 + t, 0.0); };
  KeyFramed<3> m;
  for (double t : {0.0, 0.3, 1.0, 1.2, 2.5, 2.6}) m.frames.push_back({t, path(t), Eigen::Quaterniond::Identity()});
  validate(m);
  for (std::size_t k = 1; k + 1 < m.frames.size(); ++k) {
    const double t = m.frames[k].time;
    EXPECT_LT((evaluate(m, t).velocity - slope(t)).norm(), 1e-13) << t;
  }
  // The ends start and stop at rest.
  EXPECT_EQ(evaluate(m, 0.0).velocity.norm(), 0.0);
  EXPECT_LT(evaluate(m, 2.6 - 1e-12).velocity.norm(), 1e-9);
}

TEST(Motion, KeyFramedSlerpIn3D) {
  KeyFramed<3> m;
  const Vec<3> axis = Vec<3>(1, -2, 0.5).normalized();
  m.frames = {{1.0, Vec<3>(0, 0, 0), axisAngle(0.2, Vec<3>(0, 0, 1))},
              {2.0, Vec<3>(1, 0, 0), axisAngle(1.4, axis) * axisAngle(0.2, Vec<3>(0, 0, 1))},
              {4.0, Vec<3>(1, 2, 0), axisAngle(-0.5, Vec<3>(1, 0, 0))},
              {4.5, Vec<3>(0, 2, 1), axisAngle(2.5, Vec<3>(0, 1, 0))}};
  validate(m);
  for (const auto& f : m.frames) {
    const KinematicState<3> s = evaluate(m, f.time);
    EXPECT_LT((s.position - f.position).norm(), 1e-15);
    EXPECT_LT(angleBetween(s.orientation, f.orientation), 1e-12);
  }
  // Slerp: a quarter of the way through the first interval the body has turned a quarter of 1.4 rad about `axis`.
  const KinematicState<3> q = evaluate(m, 1.25);
  EXPECT_NEAR((rotationVector(q.orientation * m.frames[0].orientation.conjugate()) - 0.35 * axis).norm(), 0.0, 1e-12);
  EXPECT_NEAR((q.angularVelocity - 1.4 * axis).norm(), 0.0, 1e-12);
  // Hold after the end.
  const KinematicState<3> after = evaluate(m, 9.0);
  EXPECT_LT(angleBetween(after.orientation, m.frames.back().orientation), 1e-15);
  EXPECT_EQ(after.angularVelocity.norm() + after.velocity.norm(), 0.0);
  // C1 in position.
  for (const auto& f : m.frames) {
    const KinematicState<3> l = evaluate(m, f.time - 1e-9), r = evaluate(m, f.time + 1e-9);
    EXPECT_LT((l.velocity - r.velocity).norm(), 1e-6) << f.time;
  }
  std::vector<double> times;
  for (double t : sampleTimes(1.0, 4.5, 300)) {
    bool nearFrame = false;
    for (const auto& f : m.frames) nearFrame |= std::abs(t - f.time) < 1e-3;
    if (!nearFrame) times.push_back(t);
  }
  expectVelocitiesAreDerivatives<3>(m, times, 1e-6, 1.0, 1.0);
}

// ---------------------------------------------------------------------------
// Platen
// ---------------------------------------------------------------------------

TEST(Motion, PlatenStopsAtTheTargetWithinOneStep) {
  // Table 2's wall rate 0.08 mm/s; 0.1 mm of travel.
  Platen<2> m;
  m.position = Vec<2>(0.0, 0.01);
  m.speed = 8e-5;
  m.travel = 1e-4;
  m.startTime = 0.01;
  validate(m);
  const double dt = 2.2e-4;
  const double tStop = m.startTime + m.travel / m.speed;
  double firstStopped = -1.0;
  for (int n = 0; n * dt < 2 * tStop; ++n) {
    const double t = n * dt;
    const KinematicState<2> s = evaluate(m, t);
    const double moved = m.position[1] - s.position[1];
    EXPECT_LE(moved, m.travel * (1 + 1e-15));
    EXPECT_NEAR(s.position[0], 0.0, 1e-15);
    if (t < m.startTime) {
      EXPECT_EQ(moved, 0.0);
    }
    if (t >= m.startTime && t < tStop) {
      EXPECT_NEAR(moved, m.speed * (t - m.startTime), 1e-15);
      EXPECT_NEAR(s.velocity[1], -m.speed, 1e-18);
    }
    if (moved >= m.travel * (1 - 1e-12) && firstStopped < 0) firstStopped = t;
    if (firstStopped >= 0) {
      EXPECT_NEAR(moved, m.travel, 1e-17);
      EXPECT_EQ(s.velocity.norm(), 0.0);
    }
  }
  ASSERT_GE(firstStopped, tStop);
  EXPECT_LT(firstStopped - tStop, dt);
  expectVelocitiesAreDerivatives<2>(m, sampleTimes(0.02, 1.2, 50), 1e-6, m.speed, 1.0);
}

// A servo platen against a linear spring load F = k (x - gap) reaches the
// target force: at the speed limit while approaching, then geometrically.
TEST(Motion, ServoConvergesOnALinearSpring) {
  const double k = 1e6, gap = 2e-3, dt = 1e-4, target = 1e3;
  for (double gainFactor : {0.5, 1.5}) {  // gain k dt: monotone and oscillating convergence
    ServoPlatenDef<3> def;
    def.position = Vec<3>(0, 0, 1);
    def.direction = Vec<3>(0, 0, -2);  // normalised
    def.targetForce = target;
    def.gain = gainFactor / (k * dt);
    def.maxSpeed = 0.01;
    Motion<3> motion = ServoPlaten<3>(def);
    auto& servo = std::get<ServoPlaten<3>>(motion);
    validate(motion);
    double force = 0.0;
    // 3 mm at 1 um per step, then the geometric convergence.
    for (int n = 0; n < 4000; ++n) {
      servo.update(force, dt);
      const KinematicState<3> s = evaluate(motion, n * dt);
      EXPECT_LE(s.velocity.norm(), def.maxSpeed * (1 + 1e-15));
      if (n < 100) {
        EXPECT_NEAR(s.velocity[2], -def.maxSpeed, 1e-18);  // approaching at the limit
      }
      force = k * std::max(0.0, (1.0 - s.position[2]) - gap);
    }
    EXPECT_NEAR(force, target, 1e-9 * target) << gainFactor;
    EXPECT_NEAR(servo.displacement(), gap + target / k, 1e-12);
    EXPECT_NEAR(servo.speed(), 0.0, 1e-12);

    // A new target: it follows.
    servo.setTargetForce(2 * target);
    for (int n = 0; n < 1500; ++n) {
      servo.update(force, dt);
      force = k * std::max(0.0, servo.displacement() - gap);
    }
    EXPECT_NEAR(force, 2 * target, 1e-9 * target);
  }
}

// ---------------------------------------------------------------------------
// Bad input
// ---------------------------------------------------------------------------

TEST(Motion, InvalidParametersThrowOneLineMessages) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  JawCrusher<2> jaw;
  jaw.rpm = -300;
  expectInvalid([&] { validate(jaw); }, "rpm");
  jaw = {};
  jaw.closedSideSetting = 0.0;
  expectInvalid([&] { validate(jaw); }, "closedSideSetting");
  jaw = {};
  jaw.nipAngleVariationDegrees = 25.0;
  expectInvalid([&] { validate(jaw); }, "nipAngleDegrees");
  jaw = {};
  jaw.jawLength = 100.0;
  expectInvalid([&] { validate(jaw); }, "jawLength");
  jaw = {};
  jaw.eccentricThrow = nan;
  expectInvalid([&] { validate(Motion<2>(jaw)); }, "eccentricThrow");

  Swing<3> swing;
  swing.frequency = 0.0;
  expectInvalid([&] { validate(swing); }, "frequency");
  swing = {};
  swing.amplitude = nan;
  expectInvalid([&] { validate(swing); }, "amplitude");
  swing = {};
  swing.axis = Vec<3>::Zero();
  expectInvalid([&] { validate(swing); }, "axis");

  KeyFramed<2> keys;
  expectInvalid([&] { validate(keys); }, "key frame");
  expectInvalid([&] { evaluate(keys, 0.0); }, "key frame");
  keys.frames = {{0.0, Vec<2>::Zero(), 0.0}, {1.0, Vec<2>::Zero(), 0.0}, {1.0, Vec<2>::Zero(), 0.0}};
  expectInvalid([&] { validate(keys); }, "times");
  keys.frames = {{0.0, Vec<2>::Zero(), 0.0}, {nan, Vec<2>::Zero(), 0.0}};
  expectInvalid([&] { validate(keys); }, "time");
  KeyFramed<3> keys3;
  keys3.frames = {{0.0, Vec<3>::Zero(), Eigen::Quaterniond(0, 0, 0, 0)}};
  expectInvalid([&] { validate(keys3); }, "orientation");

  Platen<2> platen;
  platen.speed = nan;
  expectInvalid([&] { validate(platen); }, "speed");
  platen = {};
  platen.direction = Vec<2>::Zero();
  expectInvalid([&] { validate(platen); }, "direction");
  platen = {};
  platen.travel = -1.0;
  expectInvalid([&] { validate(platen); }, "travel");

  ServoPlatenDef<2> servo;
  servo.gain = 0.0;
  expectInvalid([&] { ServoPlaten<2>{servo}; }, "gain");
  servo = {};
  servo.targetForce = -5.0;
  expectInvalid([&] { ServoPlaten<2>{servo}; }, "targetForce");
  ServoPlaten<2> ok;
  expectInvalid([&] { ok.update(nan, 1e-3); }, "measuredForce");
  expectInvalid([&] { ok.update(1.0, 0.0); }, "dt");

  ConstantVelocity<3> cv;
  cv.velocity[1] = nan;
  expectInvalid([&] { validate(Motion<3>(cv)); }, "velocity");

  // Defaults are valid.
  EXPECT_NO_THROW(validate(Motion<2>(JawCrusher<2>{})));
  EXPECT_NO_THROW(validate(Motion<3>(Platen<3>{})));
  EXPECT_NO_THROW(validate(Motion<3>(Swing<3>{})));
}
