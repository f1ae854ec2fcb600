#pragma once
/// @file Wall.h
/// @brief The two kinds of boundary a particle can touch besides another
/// particle: infinite planes and kinematic level-set bodies ("tools": jaws,
/// platens, buckets made from primitives or CAD meshes). Both have prescribed
/// motion (infinite mass): the contact solver reads their pose and velocity and
/// reports the load on them; it never moves them.

#include "lsdem/dynamics/Rotation.h"
#include "lsdem/geometry/Shape.h"

namespace lsdem::dynamics {

/// An infinite plane wall {x : normal . (x - point) = 0}; particles live on the
/// side the normal points into. A particle node x overlaps it by
/// -(normal . (x - point)) when that is positive.
template <int D>
struct Plane {
  Vec<D> point = Vec<D>::Zero();                    ///< a point of the plane, world frame, m
  Vec<D> normal = Vec<D>::UnitY();                  ///< unit normal, world frame, pointing into the particles' side
  Vec<D> velocity = Vec<D>::Zero();                 ///< velocity of the plane (translation only), m/s

  /// @brief Signed distance of world point x from the plane, m (> 0 on the particles' side).
  double signedDistance(const Vec<D>& x) const { return normal.dot(x - point); }
};

/// The pose and motion of a kinematic level-set body this step. Its body frame
/// is that of its shape (origin at the shape's centroid, principal axes), placed
/// in the world like a particle's: a body point xb is at position + R xb.
/// The contact solver tests the particles' nodes against its level set.
template <int D>
struct ToolPose {
  const geometry::Shape<D>* shape = nullptr;          ///< the tool's shape (not owned), required
  Vec<D> position = Vec<D>::Zero();                   ///< body-frame origin in the world, m
  Orientation<D> orientation = Rotation<D>::identity(); ///< body to world
  Vec<D> velocity = Vec<D>::Zero();                   ///< velocity of the body-frame origin, m/s
  Spin<D> angularVelocity = Rotation<D>::zeroSpin();  ///< rad/s, world frame

  /// @brief Velocity of the tool's material point at world position x, m/s.
  Vec<D> velocityAt(const Vec<D>& x) const { return velocity + Rotation<D>::velocityAt(angularVelocity, x - position); }
};

}  // namespace lsdem::dynamics
