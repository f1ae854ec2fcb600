#pragma once
/// @file Rotation.h
/// @brief What differs between 2D and 3D rigid motion, behind one interface:
/// the orientation (an angle in 2D, a unit quaternion in 3D) and the spin
/// quantities (angular velocity, torque, inverse inertia: scalars about z in 2D,
/// 3-vectors in 3D).

#include "lsdem/geometry/Types.h"

#include <Eigen/Geometry>

namespace lsdem::dynamics {

using geometry::Mat;
using geometry::Vec;

template <int D>
struct Rotation;

template <>
struct Rotation<2> {
  using Orientation = double;  ///< angle about z, radians, counter-clockwise
  using Spin = double;         ///< angular velocity (rad/s), torque (N m), inertia about z

  static Orientation identity() { return 0.0; }
  static Spin zeroSpin() { return 0.0; }
  /// @brief Body-to-world rotation matrix.
  static Mat<2> matrix(Orientation a) {
    const double c = std::cos(a), s = std::sin(a);
    Mat<2> r;
    r << c, -s, s, c;
    return r;
  }
  /// @brief Torque of force f applied at lever arm r: r x f (z component).
  static Spin moment(const Vec<2>& r, const Vec<2>& f) { return r[0] * f[1] - r[1] * f[0]; }
  /// @brief Velocity of a point at lever arm r on a body spinning at w: w x r.
  static Vec<2> velocityAt(Spin w, const Vec<2>& r) { return Vec<2>(-w * r[1], w * r[0]); }
  static double dot(Spin a, Spin b) { return a * b; }
};

template <>
struct Rotation<3> {
  using Orientation = Eigen::Quaterniond;  ///< unit quaternion, body to world
  using Spin = Vec<3>;                     ///< angular velocity (rad/s), torque (N m), in the world frame

  static Orientation identity() { return Orientation::Identity(); }
  static Spin zeroSpin() { return Spin::Zero(); }
  static Mat<3> matrix(const Orientation& q) { return q.toRotationMatrix(); }
  static Spin moment(const Vec<3>& r, const Vec<3>& f) { return r.cross(f); }
  static Vec<3> velocityAt(const Spin& w, const Vec<3>& r) { return w.cross(r); }
  static double dot(const Spin& a, const Spin& b) { return a.dot(b); }
};

template <int D>
using Orientation = typename Rotation<D>::Orientation;
template <int D>
using Spin = typename Rotation<D>::Spin;

}  // namespace lsdem::dynamics
