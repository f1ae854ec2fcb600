#pragma once
/// @file Integrator.h
/// @brief Explicit rigid-body integration, velocity Verlet in two halves.
///
/// Scheme (second order, symplectic and time-reversible for conservative forces):
///
///     kick-drift  (before forces):  v += dt/2 F/m;  x += dt v;
///                                   L += dt/2 T;   free rotation over dt
///     forces at the new positions (with the half-step velocities)
///     kick        (after forces):   v += dt/2 F/m;  L += dt/2 T
///
/// Positions and velocities are synchronous between steps, so energies and
/// outputs need no correction. Velocity-dependent forces (damping) see the
/// half-step velocity, as in common DEM codes.
///
/// Rotation in 3D is advanced through the angular momentum, in the body frame
/// where the inertia is diagonal: the torque kicks L_b = I w_b, and the free
/// rotation over dt is split into exact rotations about the body's principal
/// axes in the symmetric sequence x(dt/2), y(dt/2), z(dt), y(dt/2), x(dt/2)
/// (the free-rigid-body splitting of Dullweber, Leimkuhler & McLachlan 1997),
/// each turning the orientation one way and L_b the other. Each sub-step is
/// an exact rotation, so |L| is kept to round-off and the energy error stays
/// bounded: a free asymmetric top conserves both. The stored angular velocity
/// is w = R I^-1 L_b. A sub-step's sine and cosine come from short Taylor
/// series at the small angles of a step (exact to round-off there) and from
/// the library beyond 1/16 rad. In 2D the angle and spin follow the same
/// kick-drift-kick.

#include "lsdem/dynamics/Particles.h"

namespace lsdem::dynamics {

/// @brief First half of the step: half kick of velocities and spins by the
/// stored forces/torques, then drift of positions and orientations over dt.
template <int D>
void kickDrift(Particles<D>& particles, double dt);

/// @brief Second half of the step: half kick by the forces/torques just computed.
template <int D>
void kick(Particles<D>& particles, double dt);

/// @brief Free rotation of one body over dt in 3D (torque-free), in place:
/// orientation q (body to world) and world angular momentum L (unchanged in the
/// world frame; exposed for tests). `invInertia` are the inverses of the
/// principal moments.
void freeRotation(Eigen::Quaterniond& q, const Vec<3>& angularMomentum, const Vec<3>& invInertia, double dt);

}  // namespace lsdem::dynamics
