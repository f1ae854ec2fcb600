#pragma once
/// @file Motion.h
/// @brief Prescribed rigid motions of kinematic bodies: walls, jaws, buckets,
/// platens (DESIGN "Walls and tools", "One step": moveKinematicBodies()).
///
/// A kinematic body has infinite mass: the particles push on it but do not move
/// it. Its motion is a pure function of time, `evaluate(motion, t)`, giving the
/// pose and the velocity of the body's reference point; the velocities are the
/// exact time derivatives of the pose, so a contact sees the relative velocity
/// the surfaces really have. The one stateful motion is the stress-controlled
/// platen (`ServoPlaten`), which integrates its own velocity from the force the
/// particles exert on it (`update(measuredForce, dt)`) and whose `evaluate`
/// returns the state of its last update.
///
/// The motions are small definition structs with defaults (STYLE 7) held in one
/// `std::variant`, `Motion<D>`; `evaluate` dispatches with `std::visit`, no
/// virtual calls. A world evaluates each kinematic body once per step.
/// `validate(motion)` checks a definition once, when the scene is built;
/// `evaluate` assumes a valid motion.
///
/// Frames and units: positions in the world frame (m); orientation body to
/// world (an angle about z in 2D, a unit quaternion in 3D); velocity of the
/// reference point (m/s); angular velocity in the world frame (rad/s). Angles
/// are in radians unless a name ends in `Degrees`.

#include "lsdem/dynamics/Rotation.h"

#include <cstddef>
#include <limits>
#include <numbers>
#include <variant>
#include <vector>

namespace lsdem::dynamics {

/// Pose and velocity of a kinematic body at one time.
template <int D>
struct KinematicState {
  Vec<D> position = Vec<D>::Zero();                       ///< reference point, world frame, m
  Orientation<D> orientation = Rotation<D>::identity();   ///< body to world
  Vec<D> velocity = Vec<D>::Zero();                       ///< of the reference point, world frame, m/s
  Spin<D> angularVelocity = Rotation<D>::zeroSpin();      ///< world frame, rad/s

  /// @brief World position of a body-frame point xBody (m).
  Vec<D> toWorld(const Vec<D>& xBody) const { return position + Rotation<D>::matrix(orientation) * xBody; }
  /// @brief Velocity (m/s) of the body's material point at world position x (m).
  Vec<D> velocityAt(const Vec<D>& x) const { return velocity + Rotation<D>::velocityAt(angularVelocity, x - position); }
};

/// Constant translational and angular velocity: x(t) = x0 + v t, and the body
/// turns about its reference point at the constant world angular velocity w
/// (orientation(t) = exp(w t) orientation0).
template <int D>
struct ConstantVelocity {
  Vec<D> position = Vec<D>::Zero();                       ///< reference point at t = 0, world, m
  Orientation<D> orientation = Rotation<D>::identity();   ///< at t = 0, body to world
  Vec<D> velocity = Vec<D>::Zero();                       ///< m/s, world frame
  Spin<D> angularVelocity = Rotation<D>::zeroSpin();      ///< rad/s, world frame, about the reference point
};

/// A sinusoidal rotation about a fixed pivot:
///     angle(t) = meanAngle + amplitude sin(2 pi frequency t + phase),
/// the body rotated by angle(t) about the pivot from its pose at angle 0, so its
/// reference point moves on an arc about the pivot. In 2D the rotation is about
/// z (counter-clockwise positive); in 3D about `axis` through the pivot.
template <int D>
struct Swing {
  Vec<D> pivot = Vec<D>::Zero();                          ///< world, m
  Vec<3> axis = Vec<3>::UnitZ();                          ///< 3D only: rotation axis (world, normalised on use); 2D turns about z
  Vec<D> position = Vec<D>::Zero();                       ///< reference point at angle 0, world, m
  Orientation<D> orientation = Rotation<D>::identity();   ///< at angle 0, body to world
  double meanAngle = 0.0;                                 ///< rad
  double amplitude = 0.0;                                 ///< rad
  double frequency = 1.0;                                 ///< Hz, > 0
  double phase = 0.0;                                     ///< rad
};

/// The swing jaw of a single-toggle jaw crusher (paper section 4, Table 1).
///
/// Geometry, in the crusher plane (the xy plane; in 3D the jaws are extruded
/// along z and the shaft is parallel to z). Crusher frame: origin at the
/// discharge end of the stationary jaw's face, y' up that face (the direction
/// `stationaryAngleDegrees`), x' across the chamber towards the swing jaw
/// (y' turned 90 degrees clockwise):
///
///                 S = shaft centre; the eccentric pin T turns on a circle
///          S o    of radius r about S at `rpm`: T = S + r (cos psi, sin psi)
///      |   T*     psi = 2 pi rpm/60 t + phase
///      |   /
///      |  / L     swing jaw face, length L, from its discharge end B up to T,
///      | /beta    at the nip angle beta from the stationary face:
///      |/         beta = beta_mean + dbeta cos psi,  B = T - L (sin beta, cos beta)
///      |  B
///      |<>|       discharge gap = x'(B) (distance from B to the stationary face's line)
///     O  gap
///   stationary face (x' = 0)
///
/// With c = cos psi the gap is x'(S) + r c - L sin(beta_mean + dbeta c), which
/// increases monotonically with c (validated), so it is largest at psi = 0
/// (open side setting, OSS) and smallest at psi = pi (closed side setting, CSS).
/// Requiring OSS - CSS = eccentricThrow fixes the eccentric radius
///     r = throw / 2 + (L / 2) (sin(beta_mean + dbeta) - sin(beta_mean - dbeta)),
/// which is throw / 2 without nip-angle variation; with variation the jaw rocks
/// as well as translates (the pin's stroke 2r exceeds the stroke at the
/// discharge, as in a single-toggle crusher). The shaft sits at
/// x'(S) = CSS + r + L sin(beta_mean - dbeta) and y'(S) = L cos(beta_mean), so B
/// stays level with O on average. The eccentric turns so that the jaw moves
/// down as it closes onto the CSS: on the closing stroke (psi from 0 to pi) the
/// pin passes over the shaft and at the CSS it moves straight down, the usual
/// sense, which pushes the crushed rock towards the discharge.
///
/// The body. The swing jaw is a plate of thickness `jawThickness` behind its
/// face (on the side away from the chamber). Its body frame: origin at the
/// plate's centre C = (B + T) / 2 - (thickness / 2) m; body y = m, the face's
/// unit normal pointing into the chamber; body x = y turned 90 degrees
/// clockwise, i.e. along the face from B up to T. The face is the body's
/// y = +thickness/2 side, and the reference point of the KinematicState is C.
/// In 2D a Box shape with half extents (L/2, thickness/2), L > thickness, has
/// exactly this body frame (its principal frame; the box's symmetry makes the
/// axes' signs irrelevant). In 3D a shape's principal frame orders its axes by
/// extent, so a plate's shape frame (length, width, thickness) is a fixed
/// rotation of this one (length, face normal, width): `plateFrame`, which the
/// pose composes (a scene sets it for 3D plates; without it the plate's width
/// stood where its thickness belongs and the plate reached into the chamber).
/// The plateFrame of a 3D plate whose principal frame is (length, width,
/// thickness): its thickness axis (z) becomes the jaw's face normal (y), its
/// width (y) the jaw's out-of-plane axis (-z).
inline Orientation<3> plateFrame3D() { return Orientation<3>(Eigen::AngleAxisd(-0.5 * std::numbers::pi, Vec<3>::UnitX())); }
/// The plateFrame of a plate shape posed in its principal frame: identity in
/// 2D (length, thickness: the jaw's own), plateFrame3D in 3D.
template <int D>
Orientation<D> plateFrameOfPrincipal() {
  if constexpr (D == 2) {
    return Rotation<2>::identity();
  } else {
    return plateFrame3D();
  }
}

template <int D>
struct JawCrusher {
  double rpm = 300.0;                       ///< eccentric shaft speed, revolutions per minute (> 0)
  double eccentricThrow = 0.05;             ///< stroke at the discharge, OSS - CSS, m (> 0)
  double nipAngleDegrees = 22.0;            ///< mean angle between the jaw faces, degrees
  double nipAngleVariationDegrees = 1.7;    ///< the nip angle swings by +/- this, degrees (>= 0)
  double closedSideSetting = 0.05;          ///< CSS: smallest discharge gap, m (> 0)
  double jawLength = 1.0;                   ///< length of the swing jaw's face, m
  double jawThickness = 0.1;                ///< thickness of the jaw plates, m
  Vec<D> stationaryBottom = Vec<D>::Zero(); ///< world position of the discharge end of the stationary face, m
  double stationaryAngleDegrees = 90.0;     ///< direction of the stationary face from its discharge end upwards, counter-clockwise from +x, degrees
  double phase = 0.0;                       ///< eccentric angle psi at t = 0, rad (0: gap = OSS)
  /// The plate shape's body frame in the jaw's (above): a shape's principal
  /// frame, (length, thickness) in 2D, the jaw's own; (length, width,
  /// thickness) in 3D, turned -90 degrees about x (plateFrame3D). Identity
  /// poses a body whose frame is the jaw's.
  Orientation<D> plateFrame = plateFrameOfPrincipal<D>();
};

/// One key frame of a KeyFramed path.
template <int D>
struct KeyFrame {
  double time = 0.0;                                      ///< s
  Vec<D> position = Vec<D>::Zero();                       ///< reference point, world, m
  Orientation<D> orientation = Rotation<D>::identity();   ///< body to world (3D: normalised on use)
};

/// A path through key frames. Position: a C1 piecewise-cubic Hermite spline
/// through the frames with Catmull-Rom-type tangents for uneven spacing (at an
/// inner frame k the slope of the parabola through frames k-1, k, k+1:
/// m_k = (h_k s_{k-1} + h_{k-1} s_k) / (h_{k-1} + h_k), with h the interval
/// lengths and s the chord slopes), and zero tangent at the first and last
/// frames, so the body starts from rest, comes to rest at the last frame and the
/// path is C1 for all t. Orientation: slerp along the shortest arc in 3D, the
/// angle linearly in 2D (any number of turns), per interval; the angular
/// velocity is constant on each interval (it jumps at the frames). Before the
/// first frame the body holds the first frame; after the last, the last.
/// @note Frame times must increase strictly (validated).
template <int D>
struct KeyFramed {
  std::vector<KeyFrame<D>> frames;  ///< at least one, times strictly increasing
};

/// A displacement-controlled platen: at rest until `startTime`, then moving at
/// `speed` along `direction` until it has travelled `travel`, then at rest (the
/// oedometer's top platen; Table 2: wall rate 0.08 mm/s). It stops exactly at
/// the target: a step that crosses it ends there.
template <int D>
struct Platen {
  Vec<D> position = Vec<D>::Zero();                       ///< reference point before it moves, world, m
  Orientation<D> orientation = Rotation<D>::identity();   ///< body to world (constant)
  Vec<D> direction = -Vec<D>::UnitY();                    ///< direction of travel, world (normalised on use)
  double speed = 8e-5;                                    ///< m/s (>= 0)
  double travel = std::numeric_limits<double>::infinity();///< target displacement, m (>= 0; infinity: never stops)
  double startTime = 0.0;                                 ///< s
};

/// Definition of a stress-controlled platen (a servo).
template <int D>
struct ServoPlatenDef {
  Vec<D> position = Vec<D>::Zero();                       ///< reference point at the start, world, m
  Orientation<D> orientation = Rotation<D>::identity();   ///< body to world (constant)
  Vec<D> direction = -Vec<D>::UnitY();                    ///< direction in which the platen advances into the specimen, world (normalised)
  double targetForce = 0.0;                               ///< compressive force wanted on the platen, N (>= 0)
  double gain = 1e-6;                                     ///< speed per force error, m/(s N) (> 0)
  double maxSpeed = 1e-3;                                 ///< speed limit, m/s (> 0)
};

/// A stress-controlled platen: a servo that moves the platen to reach a target
/// force. Each step, `update(measuredForce, dt)` sets the speed along
/// `direction` to gain (target - measured), clamped to +/- maxSpeed, and
/// advances the platen by speed dt (explicit). The platen advances while the
/// specimen pushes back less than the target and retreats when it pushes more.
///
/// Stability: against a specimen of stiffness k (N/m) the force error shrinks
/// by the factor (1 - gain k dt) per step, so the servo converges without
/// overshoot for gain < 1 / (k dt), oscillates but converges for
/// gain < 2 / (k dt), and is unstable above (a bang-bang oscillation at
/// maxSpeed).
template <int D>
class ServoPlaten {
 public:
  /// @note Throws std::invalid_argument for a zero or NaN direction, a negative
  /// or NaN target, gain <= 0 or maxSpeed <= 0.
  explicit ServoPlaten(const ServoPlatenDef<D>& def = {});

  /// @brief Advances the servo by one step.
  /// @param measuredForce compressive force the particles exert on the platen,
  ///   i.e. minus the component of their total force on it along `direction`, N.
  /// @param dt time step, s (> 0).
  void update(double measuredForce, double dt);
  /// @brief Changes the target force (a stress path), N (>= 0).
  void setTargetForce(double force);
  /// @brief Restores the servo's state (a checkpoint): displacement along
  /// `direction` since the start (m) and current speed along it (m/s).
  void restore(double displacement, double speed);

  /// @brief Pose and velocity after the last update.
  KinematicState<D> state() const;
  /// @brief Displacement along `direction` since the start, m.
  double displacement() const { return displacement_; }
  /// @brief Current speed along `direction`, m/s (negative: retreating).
  double speed() const { return speed_; }
  /// @brief The definition, with the current target force and a unit direction.
  const ServoPlatenDef<D>& def() const { return def_; }

 private:
  ServoPlatenDef<D> def_;
  double displacement_ = 0.0;
  double speed_ = 0.0;
};

/// Any prescribed motion of a kinematic body.
template <int D>
using Motion = std::variant<ConstantVelocity<D>, Swing<D>, JawCrusher<D>, KeyFramed<D>, Platen<D>, ServoPlaten<D>>;

/// @brief Pose and velocity of a kinematic body at time t (s); the velocities
/// are the exact time derivatives of the pose. A ServoPlaten ignores t and
/// returns the state of its last update.
/// @note Assumes a valid motion (see validate); a KeyFramed path without frames throws.
template <int D>
KinematicState<D> evaluate(const Motion<D>& motion, double t);

/// @brief Pose and velocity of a constant-velocity motion at time t (s).
template <int D>
KinematicState<D> evaluate(const ConstantVelocity<D>& motion, double t);
/// @brief Pose and velocity of a swing at time t (s).
template <int D>
KinematicState<D> evaluate(const Swing<D>& motion, double t);
/// @brief Pose and velocity of the swing jaw's plate (body frame: see JawCrusher) at time t (s).
template <int D>
KinematicState<D> evaluate(const JawCrusher<D>& motion, double t);
/// @brief Pose and velocity on a key-framed path at time t (s).
/// @note Throws std::invalid_argument when the path has no frames.
template <int D>
KinematicState<D> evaluate(const KeyFramed<D>& motion, double t);
/// @brief Pose and velocity of a displacement-controlled platen at time t (s).
template <int D>
KinematicState<D> evaluate(const Platen<D>& motion, double t);

/// @brief Checks a motion's parameters once, when a scene is built.
/// @note Throws std::invalid_argument with a one-line message naming the
/// parameter and its value: NaN or infinite values (except Platen::travel =
/// +infinity), a zero direction or axis, Swing frequency <= 0, JawCrusher
/// rpm <= 0, throw <= 0, CSS <= 0, length or thickness <= 0, nip angle and its
/// variation outside 0 < nip - variation, nip + variation < 90 degrees, or a
/// jaw too long for the gap to be monotone in the eccentric angle; KeyFramed
/// without frames or with times not strictly increasing; Platen speed < 0 or
/// travel < 0.
template <int D>
void validate(const Motion<D>& motion);

/// @brief Checks a constant-velocity motion (finite values).
template <int D>
void validate(const ConstantVelocity<D>& motion);
/// @brief Checks a swing (finite values, nonzero axis, frequency > 0).
template <int D>
void validate(const Swing<D>& motion);
/// @brief Checks jaw-crusher settings (see validate(const Motion&)).
template <int D>
void validate(const JawCrusher<D>& motion);
/// @brief Checks a key-framed path (frames present, finite, times strictly increasing).
template <int D>
void validate(const KeyFramed<D>& motion);
/// @brief Checks a displacement-controlled platen (nonzero direction, speed and travel >= 0).
template <int D>
void validate(const Platen<D>& motion);

// ---- jaw crusher geometry (see JawCrusher) ----

/// @brief Period of one crusher cycle, 60 / rpm, s.
template <int D>
double crusherPeriod(const JawCrusher<D>& jaw);
/// @brief Eccentric angle psi(t) = 2 pi rpm/60 t + phase, rad.
template <int D>
double eccentricAngle(const JawCrusher<D>& jaw, double t);
/// @brief Radius r of the eccentric pin's circle about the shaft, m (see JawCrusher).
template <int D>
double eccentricRadius(const JawCrusher<D>& jaw);
/// @brief Nip angle beta(t) between the jaw faces, rad: mean +/- variation.
template <int D>
double nipAngle(const JawCrusher<D>& jaw, double t);
/// @brief Discharge gap at time t: distance from the swing jaw's discharge end
/// to the line of the stationary face, m; between CSS and CSS + throw.
template <int D>
double dischargeGap(const JawCrusher<D>& jaw, double t);
/// @brief World position of the eccentric shaft's centre S, m.
template <int D>
Vec<D> shaftCentre(const JawCrusher<D>& jaw);
/// @brief World position of the top end T of the swing jaw's face (the eccentric pin), m.
template <int D>
Vec<D> swingJawTop(const JawCrusher<D>& jaw, double t);
/// @brief World position of the discharge end B of the swing jaw's face, m.
template <int D>
Vec<D> swingJawBottom(const JawCrusher<D>& jaw, double t);
/// @brief Pose of the stationary jaw plate (at rest): a plate of the same
/// length and thickness as the swing jaw behind the stationary face, body
/// origin at its centre, body y = the face's normal into the chamber, body x = y
/// turned 90 degrees clockwise (down the face).
template <int D>
KinematicState<D> stationaryJawState(const JawCrusher<D>& jaw);

// ---- explicit instantiations (Motion.cpp) ----
extern template class ServoPlaten<2>;
extern template class ServoPlaten<3>;
extern template KinematicState<2> evaluate<2>(const Motion<2>&, double);
extern template KinematicState<3> evaluate<3>(const Motion<3>&, double);
extern template KinematicState<2> evaluate<2>(const ConstantVelocity<2>&, double);
extern template KinematicState<3> evaluate<3>(const ConstantVelocity<3>&, double);
extern template KinematicState<2> evaluate<2>(const Swing<2>&, double);
extern template KinematicState<3> evaluate<3>(const Swing<3>&, double);
extern template KinematicState<2> evaluate<2>(const JawCrusher<2>&, double);
extern template KinematicState<3> evaluate<3>(const JawCrusher<3>&, double);
extern template KinematicState<2> evaluate<2>(const KeyFramed<2>&, double);
extern template KinematicState<3> evaluate<3>(const KeyFramed<3>&, double);
extern template KinematicState<2> evaluate<2>(const Platen<2>&, double);
extern template KinematicState<3> evaluate<3>(const Platen<3>&, double);
extern template void validate<2>(const Motion<2>&);
extern template void validate<3>(const Motion<3>&);
extern template void validate<2>(const ConstantVelocity<2>&);
extern template void validate<3>(const ConstantVelocity<3>&);
extern template void validate<2>(const Swing<2>&);
extern template void validate<3>(const Swing<3>&);
extern template void validate<2>(const JawCrusher<2>&);
extern template void validate<3>(const JawCrusher<3>&);
extern template void validate<2>(const KeyFramed<2>&);
extern template void validate<3>(const KeyFramed<3>&);
extern template void validate<2>(const Platen<2>&);
extern template void validate<3>(const Platen<3>&);
extern template double crusherPeriod<2>(const JawCrusher<2>&);
extern template double crusherPeriod<3>(const JawCrusher<3>&);
extern template double eccentricAngle<2>(const JawCrusher<2>&, double);
extern template double eccentricAngle<3>(const JawCrusher<3>&, double);
extern template double eccentricRadius<2>(const JawCrusher<2>&);
extern template double eccentricRadius<3>(const JawCrusher<3>&);
extern template double nipAngle<2>(const JawCrusher<2>&, double);
extern template double nipAngle<3>(const JawCrusher<3>&, double);
extern template double dischargeGap<2>(const JawCrusher<2>&, double);
extern template double dischargeGap<3>(const JawCrusher<3>&, double);
extern template Vec<2> shaftCentre<2>(const JawCrusher<2>&);
extern template Vec<3> shaftCentre<3>(const JawCrusher<3>&);
extern template Vec<2> swingJawTop<2>(const JawCrusher<2>&, double);
extern template Vec<3> swingJawTop<3>(const JawCrusher<3>&, double);
extern template Vec<2> swingJawBottom<2>(const JawCrusher<2>&, double);
extern template Vec<3> swingJawBottom<3>(const JawCrusher<3>&, double);
extern template KinematicState<2> stationaryJawState<2>(const JawCrusher<2>&);
extern template KinematicState<3> stationaryJawState<3>(const JawCrusher<3>&);

}  // namespace lsdem::dynamics
