#include "lsdem/dynamics/Motion.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace lsdem::dynamics {
namespace {

constexpr double kPi = std::numbers::pi;

double radians(double degrees) { return degrees * kPi / 180.0; }

// ---- one-line messages for bad input ----

std::string str(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

template <class Derived>
std::string str(const Eigen::MatrixBase<Derived>& v) {
  std::ostringstream os;
  os << '(';
  for (Eigen::Index i = 0; i < v.size(); ++i) os << (i ? ", " : "") << v[i];
  os << ')';
  return os.str();
}

[[noreturn]] void fail(const std::string& message) { throw std::invalid_argument(message); }

void requireFinite(const std::string& name, double v) {
  if (!std::isfinite(v)) fail(name + " = " + str(v) + " must be finite");
}

template <class Derived>
void requireFinite(const std::string& name, const Eigen::MatrixBase<Derived>& v) {
  if (!v.allFinite()) fail(name + " = " + str(v) + " must be finite");
}

void requireFinite(const std::string& name, const Eigen::Quaterniond& q) {
  if (!q.coeffs().allFinite()) fail(name + " = " + str(q.coeffs()) + " must be finite");
  if (!(q.norm() > 0.0)) fail(name + " must be a nonzero quaternion");
}

void requirePositive(const std::string& name, double v) {
  if (!(v > 0.0) || !std::isfinite(v)) fail(name + " = " + str(v) + " must be > 0 and finite");
}

void requireNonNegative(const std::string& name, double v) {
  if (!(v >= 0.0) || !std::isfinite(v)) fail(name + " = " + str(v) + " must be >= 0 and finite");
}

template <class Derived>
void requireDirection(const std::string& name, const Eigen::MatrixBase<Derived>& v) {
  requireFinite(name, v);
  if (!(v.norm() > 0.0)) fail(name + " = " + str(v) + " must be a nonzero vector");
}

// ---- 2D/3D helpers ----

// Orientation as given by a user, made usable: quaternions normalised.
template <int D>
Orientation<D> unit(const Orientation<D>& o) {
  if constexpr (D == 2) {
    return o;
  } else {
    return o.normalized();
  }
}

// A rotation by `angle` (rad) about z (2D) or about the unit `axis` (3D), as an orientation.
template <int D>
Orientation<D> turn(double angle, const Vec<3>& axis) {
  if constexpr (D == 2) {
    return angle;
  } else {
    return Eigen::Quaterniond(Eigen::AngleAxisd(angle, axis));
  }
}

// Composition: first `o`, then the turn `r` (both body to world): r o.
template <int D>
Orientation<D> compose(const Orientation<D>& r, const Orientation<D>& o) {
  if constexpr (D == 2) {
    return r + o;
  } else {
    return r * o;
  }
}

// Spin of the rotation rate `rate` (rad/s) about z (2D) or the unit `axis` (3D).
template <int D>
Spin<D> spin(double rate, const Vec<3>& axis) {
  if constexpr (D == 2) {
    return rate;
  } else {
    return rate * axis;
  }
}

// Rotation vector (axis times angle, rad) of the unit quaternion q, shortest arc.
Vec<3> rotationVector(Eigen::Quaterniond q) {
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  const double s = q.vec().norm();
  if (s == 0.0) return Vec<3>::Zero();
  return (2.0 * std::atan2(s, q.w()) / s) * q.vec();
}

// ---- jaw crusher kinematics in the crusher frame (x' across, y' up the stationary face) ----

struct JawPlane {
  Vec<2> shaft;       // S
  Vec<2> top;         // T (eccentric pin), and its velocity
  Vec<2> topVelocity;
  Vec<2> bottom;      // B
  Vec<2> centre;      // plate centre C, and its velocity
  Vec<2> centreVelocity;
  double beta = 0.0;      // nip angle, rad
  double betaRate = 0.0;  // d beta / dt, rad/s
  double radius = 0.0;    // eccentric radius r
};

template <int D>
double jawRadius(const JawCrusher<D>& j) {
  const double b = radians(j.nipAngleDegrees), db = radians(j.nipAngleVariationDegrees);
  return 0.5 * j.eccentricThrow + 0.5 * j.jawLength * (std::sin(b + db) - std::sin(b - db));
}

template <int D>
JawPlane jawPlane(const JawCrusher<D>& j, double t) {
  JawPlane k;
  const double b = radians(j.nipAngleDegrees), db = radians(j.nipAngleVariationDegrees);
  const double L = j.jawLength, w = j.jawThickness;
  const double rate = 2.0 * kPi * j.rpm / 60.0;
  const double psi = rate * t + j.phase;
  const double c = std::cos(psi), s = std::sin(psi);

  // Shaft and eccentric pin: T = S + r (cos psi, sin psi).
  k.radius = jawRadius(j);
  k.shaft = Vec<2>(j.closedSideSetting + k.radius + L * std::sin(b - db), L * std::cos(b));
  k.top = k.shaft + k.radius * Vec<2>(c, s);
  k.topVelocity = k.radius * rate * Vec<2>(-s, c);

  // Nip angle and the face: d up the face, m its normal into the chamber.
  k.beta = b + db * c;
  k.betaRate = -db * rate * s;
  const Vec<2> d(std::sin(k.beta), std::cos(k.beta));
  const Vec<2> m(-std::cos(k.beta), std::sin(k.beta));
  k.bottom = k.top - L * d;

  // Plate centre behind the face; rigid-body velocity about T with spin -beta'.
  k.centre = k.top - 0.5 * L * d - 0.5 * w * m;
  k.centreVelocity = k.topVelocity + Rotation<2>::velocityAt(-k.betaRate, k.centre - k.top);
  return k;
}

// Unit vectors of the crusher frame in the world plane: x' (across) and y' (up the face).
template <int D>
void jawAxes(const JawCrusher<D>& j, Vec<2>& across, Vec<2>& up) {
  const double a = radians(j.stationaryAngleDegrees);
  up = Vec<2>(std::cos(a), std::sin(a));
  across = Vec<2>(up[1], -up[0]);
}

// A crusher-frame vector in the world (3D: in the xy plane).
template <int D>
Vec<D> jawVector(const JawCrusher<D>& j, const Vec<2>& v) {
  Vec<2> across, up;
  jawAxes(j, across, up);
  const Vec<2> w = v[0] * across + v[1] * up;
  Vec<D> out = Vec<D>::Zero();
  out.template head<2>() = w;
  return out;
}

// A crusher-frame point in the world.
template <int D>
Vec<D> jawPoint(const JawCrusher<D>& j, const Vec<2>& p) {
  return j.stationaryBottom + jawVector(j, p);
}

// ---- key frames ----

// Tangent dp/dt at frame k: zero at the ends, else the slope of the parabola
// through frames k-1, k, k+1.
template <int D>
Vec<D> keyTangent(const std::vector<KeyFrame<D>>& f, std::size_t k) {
  if (k == 0 || k + 1 >= f.size()) return Vec<D>::Zero();
  const double h0 = f[k].time - f[k - 1].time, h1 = f[k + 1].time - f[k].time;
  const Vec<D> s0 = (f[k].position - f[k - 1].position) / h0;
  const Vec<D> s1 = (f[k + 1].position - f[k].position) / h1;
  return (h1 * s0 + h0 * s1) / (h0 + h1);
}

template <int D>
KinematicState<D> holdFrame(const KeyFrame<D>& f) {
  KinematicState<D> s;
  s.position = f.position;
  s.orientation = unit<D>(f.orientation);
  return s;
}

}  // namespace

// ---------------------------------------------------------------------------
// evaluate
// ---------------------------------------------------------------------------

template <int D>
KinematicState<D> evaluate(const ConstantVelocity<D>& m, double t) {
  KinematicState<D> s;
  s.position = m.position + t * m.velocity;
  s.velocity = m.velocity;
  s.angularVelocity = m.angularVelocity;
  // Orientation: exp(w t) applied to the initial orientation.
  if constexpr (D == 2) {
    s.orientation = m.orientation + m.angularVelocity * t;
  } else {
    const double rate = m.angularVelocity.norm();
    const Eigen::Quaterniond q0 = m.orientation.normalized();
    s.orientation = rate > 0.0 ? turn<3>(rate * t, m.angularVelocity / rate) * q0 : q0;
  }
  return s;
}

template <int D>
KinematicState<D> evaluate(const Swing<D>& m, double t) {
  // Swing angle and its rate.
  const double omega = 2.0 * kPi * m.frequency;
  const double angle = m.meanAngle + m.amplitude * std::sin(omega * t + m.phase);
  const double rate = m.amplitude * omega * std::cos(omega * t + m.phase);
  const Vec<3> axis = D == 3 ? Vec<3>(m.axis.normalized()) : Vec<3>(Vec<3>::UnitZ());

  // Rotate the pose at angle 0 about the pivot.
  const Orientation<D> r = turn<D>(angle, axis);
  KinematicState<D> s;
  s.position = m.pivot + Rotation<D>::matrix(r) * (m.position - m.pivot);
  s.orientation = compose<D>(r, unit<D>(m.orientation));
  s.angularVelocity = spin<D>(rate, axis);
  s.velocity = Rotation<D>::velocityAt(s.angularVelocity, s.position - m.pivot);
  return s;
}

template <int D>
KinematicState<D> evaluate(const JawCrusher<D>& j, double t) {
  const JawPlane k = jawPlane(j, t);
  // Body x along the face (world angle stationary - beta); spin -beta' about z.
  KinematicState<D> s;
  s.position = jawPoint(j, k.centre);
  s.velocity = jawVector(j, k.centreVelocity);
  s.orientation = compose<D>(turn<D>(radians(j.stationaryAngleDegrees) - k.beta, Vec<3>::UnitZ()), j.plateFrame);
  s.angularVelocity = spin<D>(-k.betaRate, Vec<3>::UnitZ());
  return s;
}

template <int D>
KinematicState<D> evaluate(const KeyFramed<D>& m, double t) {
  const auto& f = m.frames;
  if (f.empty()) fail("KeyFramed needs at least one key frame");
  // Hold the first frame before it and the last one after it.
  if (t < f.front().time) return holdFrame(f.front());
  if (t >= f.back().time) return holdFrame(f.back());

  // The interval [t_k, t_k+1) holding t.
  const auto next = std::upper_bound(f.begin(), f.end(), t,
                                     [](double time, const KeyFrame<D>& frame) { return time < frame.time; });
  const std::size_t k = std::size_t(next - f.begin()) - 1;
  const KeyFrame<D>& a = f[k];
  const KeyFrame<D>& b = f[k + 1];
  const double h = b.time - a.time;
  const double u = (t - a.time) / h;

  // Position: cubic Hermite basis on [0, 1] and its derivative.
  const Vec<D> ma = h * keyTangent(f, k), mb = h * keyTangent(f, k + 1);
  const double u2 = u * u, u3 = u2 * u;
  KinematicState<D> s;
  s.position = (2 * u3 - 3 * u2 + 1) * a.position + (u3 - 2 * u2 + u) * ma + (-2 * u3 + 3 * u2) * b.position +
               (u3 - u2) * mb;
  s.velocity = ((6 * u2 - 6 * u) * a.position + (3 * u2 - 4 * u + 1) * ma + (-6 * u2 + 6 * u) * b.position +
                (3 * u2 - 2 * u) * mb) /
               h;

  // Orientation: linear angle (2D) or slerp along the shortest arc (3D), constant spin.
  if constexpr (D == 2) {
    s.orientation = a.orientation + u * (b.orientation - a.orientation);
    s.angularVelocity = (b.orientation - a.orientation) / h;
  } else {
    const Eigen::Quaterniond qa = a.orientation.normalized();
    const Vec<3> arc = rotationVector(b.orientation.normalized() * qa.conjugate());
    const double angle = arc.norm();
    s.orientation = angle > 0.0 ? turn<3>(u * angle, arc / angle) * qa : qa;
    s.angularVelocity = arc / h;
  }
  return s;
}

template <int D>
KinematicState<D> evaluate(const Platen<D>& m, double t) {
  KinematicState<D> s;
  s.position = m.position;
  s.orientation = unit<D>(m.orientation);
  const double elapsed = t - m.startTime;
  if (elapsed < 0.0) return s;
  // Moving until the travel is reached, then at rest exactly there.
  const Vec<D> dir = m.direction.normalized();
  const double moved = m.speed * elapsed;
  if (moved >= m.travel) {
    s.position += m.travel * dir;
  } else {
    s.position += moved * dir;
    s.velocity = m.speed * dir;
  }
  return s;
}

template <int D>
KinematicState<D> evaluate(const Motion<D>& motion, double t) {
  return std::visit(
      [t](const auto& m) -> KinematicState<D> {
        if constexpr (std::is_same_v<std::decay_t<decltype(m)>, ServoPlaten<D>>) {
          return m.state();
        } else {
          return evaluate(m, t);
        }
      },
      motion);
}

// ---------------------------------------------------------------------------
// validate
// ---------------------------------------------------------------------------

template <int D>
void validate(const ConstantVelocity<D>& m) {
  requireFinite("ConstantVelocity position", m.position);
  requireFinite("ConstantVelocity orientation", m.orientation);
  requireFinite("ConstantVelocity velocity", m.velocity);
  requireFinite("ConstantVelocity angularVelocity", m.angularVelocity);
}

template <int D>
void validate(const Swing<D>& m) {
  requireFinite("Swing pivot", m.pivot);
  if constexpr (D == 3) requireDirection("Swing axis", m.axis);
  requireFinite("Swing position", m.position);
  requireFinite("Swing orientation", m.orientation);
  requireFinite("Swing meanAngle", m.meanAngle);
  requireFinite("Swing amplitude", m.amplitude);
  requirePositive("Swing frequency", m.frequency);
  requireFinite("Swing phase", m.phase);
}

template <int D>
void validate(const JawCrusher<D>& j) {
  requirePositive("JawCrusher rpm", j.rpm);
  requirePositive("JawCrusher eccentricThrow", j.eccentricThrow);
  requirePositive("JawCrusher closedSideSetting", j.closedSideSetting);
  requirePositive("JawCrusher jawLength", j.jawLength);
  requirePositive("JawCrusher jawThickness", j.jawThickness);
  requireNonNegative("JawCrusher nipAngleVariationDegrees", j.nipAngleVariationDegrees);
  requireFinite("JawCrusher nipAngleDegrees", j.nipAngleDegrees);
  requireFinite("JawCrusher stationaryBottom", j.stationaryBottom);
  requireFinite("JawCrusher stationaryAngleDegrees", j.stationaryAngleDegrees);
  requireFinite("JawCrusher phase", j.phase);
  // The nip angle must stay strictly between 0 and 90 degrees.
  const double lo = j.nipAngleDegrees - j.nipAngleVariationDegrees;
  const double hi = j.nipAngleDegrees + j.nipAngleVariationDegrees;
  if (!(lo > 0.0) || !(hi < 90.0)) {
    fail("JawCrusher nipAngleDegrees = " + str(j.nipAngleDegrees) + " +/- nipAngleVariationDegrees = " +
         str(j.nipAngleVariationDegrees) + " must stay within (0, 90) degrees");
  }
  // The gap must grow monotonically with cos(psi) so that its extremes are CSS and OSS:
  // r > L dbeta cos(beta - dbeta).
  const double db = radians(j.nipAngleVariationDegrees);
  if (!(jawRadius(j) > j.jawLength * db * std::cos(radians(lo)))) {
    fail("JawCrusher jawLength = " + str(j.jawLength) + " m is too long for eccentricThrow = " +
         str(j.eccentricThrow) + " m with nipAngleVariationDegrees = " + str(j.nipAngleVariationDegrees) +
         " (the discharge gap would not stay between CSS and OSS)");
  }
}

template <int D>
void validate(const KeyFramed<D>& m) {
  if (m.frames.empty()) fail("KeyFramed needs at least one key frame");
  for (std::size_t k = 0; k < m.frames.size(); ++k) {
    const std::string name = "KeyFramed frame " + std::to_string(k);
    requireFinite(name + " time", m.frames[k].time);
    requireFinite(name + " position", m.frames[k].position);
    requireFinite(name + " orientation", m.frames[k].orientation);
    if (k > 0 && !(m.frames[k].time > m.frames[k - 1].time)) {
      fail("KeyFramed frame times must increase strictly: frame " + std::to_string(k) + " time = " +
           str(m.frames[k].time) + " after " + str(m.frames[k - 1].time));
    }
  }
}

template <int D>
void validate(const Platen<D>& m) {
  requireFinite("Platen position", m.position);
  requireFinite("Platen orientation", m.orientation);
  requireDirection("Platen direction", m.direction);
  requireNonNegative("Platen speed", m.speed);
  if (!(m.travel >= 0.0)) fail("Platen travel = " + str(m.travel) + " must be >= 0");
  requireFinite("Platen startTime", m.startTime);
}

template <int D>
void validate(const Motion<D>& motion) {
  std::visit(
      [](const auto& m) {
        // A ServoPlaten checked its definition when it was made.
        if constexpr (!std::is_same_v<std::decay_t<decltype(m)>, ServoPlaten<D>>) validate(m);
      },
      motion);
}

// ---------------------------------------------------------------------------
// ServoPlaten
// ---------------------------------------------------------------------------

template <int D>
ServoPlaten<D>::ServoPlaten(const ServoPlatenDef<D>& def) : def_(def) {
  requireFinite("ServoPlaten position", def.position);
  requireFinite("ServoPlaten orientation", def.orientation);
  requireDirection("ServoPlaten direction", def.direction);
  requireNonNegative("ServoPlaten targetForce", def.targetForce);
  requirePositive("ServoPlaten gain", def.gain);
  requirePositive("ServoPlaten maxSpeed", def.maxSpeed);
  def_.direction = def.direction.normalized();
  def_.orientation = unit<D>(def.orientation);
}

template <int D>
void ServoPlaten<D>::update(double measuredForce, double dt) {
  requireFinite("ServoPlaten measuredForce", measuredForce);
  requirePositive("ServoPlaten dt", dt);
  // Speed proportional to the force error, clamped; then an explicit move.
  speed_ = std::clamp(def_.gain * (def_.targetForce - measuredForce), -def_.maxSpeed, def_.maxSpeed);
  displacement_ += speed_ * dt;
}

template <int D>
void ServoPlaten<D>::setTargetForce(double force) {
  requireNonNegative("ServoPlaten targetForce", force);
  def_.targetForce = force;
}

template <int D>
void ServoPlaten<D>::restore(double displacement, double speed) {
  requireFinite("ServoPlaten displacement", displacement);
  requireFinite("ServoPlaten speed", speed);
  displacement_ = displacement;
  speed_ = speed;
}

template <int D>
KinematicState<D> ServoPlaten<D>::state() const {
  KinematicState<D> s;
  s.position = def_.position + displacement_ * def_.direction;
  s.orientation = def_.orientation;
  s.velocity = speed_ * def_.direction;
  return s;
}

// ---------------------------------------------------------------------------
// jaw crusher geometry
// ---------------------------------------------------------------------------

template <int D>
double crusherPeriod(const JawCrusher<D>& j) {
  return 60.0 / j.rpm;
}

template <int D>
double eccentricAngle(const JawCrusher<D>& j, double t) {
  return 2.0 * kPi * j.rpm / 60.0 * t + j.phase;
}

template <int D>
double eccentricRadius(const JawCrusher<D>& j) {
  return jawRadius(j);
}

template <int D>
double nipAngle(const JawCrusher<D>& j, double t) {
  return radians(j.nipAngleDegrees) + radians(j.nipAngleVariationDegrees) * std::cos(eccentricAngle(j, t));
}

template <int D>
double dischargeGap(const JawCrusher<D>& j, double t) {
  return jawPlane(j, t).bottom[0];
}

template <int D>
Vec<D> shaftCentre(const JawCrusher<D>& j) {
  return jawPoint(j, jawPlane(j, 0.0).shaft);
}

template <int D>
Vec<D> swingJawTop(const JawCrusher<D>& j, double t) {
  return jawPoint(j, jawPlane(j, t).top);
}

template <int D>
Vec<D> swingJawBottom(const JawCrusher<D>& j, double t) {
  return jawPoint(j, jawPlane(j, t).bottom);
}

template <int D>
KinematicState<D> stationaryJawState(const JawCrusher<D>& j) {
  // Centre behind the face at mid-length; body x points down the face.
  KinematicState<D> s;
  s.position = jawPoint(j, Vec<2>(-0.5 * j.jawThickness, 0.5 * j.jawLength));
  s.orientation = compose<D>(turn<D>(radians(j.stationaryAngleDegrees) + kPi, Vec<3>::UnitZ()), j.plateFrame);
  return s;
}

// ---------------------------------------------------------------------------
// explicit instantiations
// ---------------------------------------------------------------------------

template class ServoPlaten<2>;
template class ServoPlaten<3>;
template KinematicState<2> evaluate<2>(const Motion<2>&, double);
template KinematicState<3> evaluate<3>(const Motion<3>&, double);
template KinematicState<2> evaluate<2>(const ConstantVelocity<2>&, double);
template KinematicState<3> evaluate<3>(const ConstantVelocity<3>&, double);
template KinematicState<2> evaluate<2>(const Swing<2>&, double);
template KinematicState<3> evaluate<3>(const Swing<3>&, double);
template KinematicState<2> evaluate<2>(const JawCrusher<2>&, double);
template KinematicState<3> evaluate<3>(const JawCrusher<3>&, double);
template KinematicState<2> evaluate<2>(const KeyFramed<2>&, double);
template KinematicState<3> evaluate<3>(const KeyFramed<3>&, double);
template KinematicState<2> evaluate<2>(const Platen<2>&, double);
template KinematicState<3> evaluate<3>(const Platen<3>&, double);
template void validate<2>(const Motion<2>&);
template void validate<3>(const Motion<3>&);
template void validate<2>(const ConstantVelocity<2>&);
template void validate<3>(const ConstantVelocity<3>&);
template void validate<2>(const Swing<2>&);
template void validate<3>(const Swing<3>&);
template void validate<2>(const JawCrusher<2>&);
template void validate<3>(const JawCrusher<3>&);
template void validate<2>(const KeyFramed<2>&);
template void validate<3>(const KeyFramed<3>&);
template void validate<2>(const Platen<2>&);
template void validate<3>(const Platen<3>&);
template double crusherPeriod<2>(const JawCrusher<2>&);
template double crusherPeriod<3>(const JawCrusher<3>&);
template double eccentricAngle<2>(const JawCrusher<2>&, double);
template double eccentricAngle<3>(const JawCrusher<3>&, double);
template double eccentricRadius<2>(const JawCrusher<2>&);
template double eccentricRadius<3>(const JawCrusher<3>&);
template double nipAngle<2>(const JawCrusher<2>&, double);
template double nipAngle<3>(const JawCrusher<3>&, double);
template double dischargeGap<2>(const JawCrusher<2>&, double);
template double dischargeGap<3>(const JawCrusher<3>&, double);
template Vec<2> shaftCentre<2>(const JawCrusher<2>&);
template Vec<3> shaftCentre<3>(const JawCrusher<3>&);
template Vec<2> swingJawTop<2>(const JawCrusher<2>&, double);
template Vec<3> swingJawTop<3>(const JawCrusher<3>&, double);
template Vec<2> swingJawBottom<2>(const JawCrusher<2>&, double);
template Vec<3> swingJawBottom<3>(const JawCrusher<3>&, double);
template KinematicState<2> stationaryJawState<2>(const JawCrusher<2>&);
template KinematicState<3> stationaryJawState<3>(const JawCrusher<3>&);

}  // namespace lsdem::dynamics
