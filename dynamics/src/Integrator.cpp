#include "lsdem/dynamics/Integrator.h"

namespace lsdem::dynamics {
namespace {

// Angular momentum (world) of a 3D body from its world angular velocity.
Vec<3> angularMomentum(const Eigen::Quaterniond& q, const Vec<3>& inertia, const Vec<3>& w) {
  return q * Vec<3>(inertia.cwiseProduct(q.conjugate() * w));
}

// World angular velocity of a 3D body from its world angular momentum.
Vec<3> angularVelocity(const Eigen::Quaterniond& q, const Vec<3>& invInertia, const Vec<3>& L) {
  return q * Vec<3>(invInertia.cwiseProduct(q.conjugate() * L));
}

// Exact free rotation about body axis k for a time s: the body turns by
// s L_k / I_k about its own axis k; the body-frame momentum turns the other way.
void rotateAboutBodyAxis(Eigen::Quaterniond& q, Vec<3>& Lbody, const Vec<3>& inertia, int k, double s) {
  const double angle = s * Lbody[k] / inertia[k];
  const Eigen::AngleAxisd turn(angle, Vec<3>::Unit(k));
  q = q * Eigen::Quaterniond(turn);
  Lbody = turn.inverse() * Lbody;
}

}  // namespace

void freeRotation(Eigen::Quaterniond& q, const Vec<3>& L, const Vec<3>& inertia, double dt) {
  Vec<3> Lbody = q.conjugate() * L;
  rotateAboutBodyAxis(q, Lbody, inertia, 0, 0.5 * dt);
  rotateAboutBodyAxis(q, Lbody, inertia, 1, 0.5 * dt);
  rotateAboutBodyAxis(q, Lbody, inertia, 2, dt);
  rotateAboutBodyAxis(q, Lbody, inertia, 1, 0.5 * dt);
  rotateAboutBodyAxis(q, Lbody, inertia, 0, 0.5 * dt);
  q.normalize();
}

// Half kick of particle i by its force and torque. In 3D the torque kicks the
// world angular momentum, which is returned for the caller to turn into the
// angular velocity (after the free rotation, when drifting); in 2D the spin is
// kicked directly.
template <int D>
auto halfKick(Particles<D>& p, std::ptrdiff_t i, double half) {
  p.velocity[i] += half * p.invMass[i] * p.force[i];
  if constexpr (D == 2) {
    p.angularVelocity[i] += half * p.invInertia[i] * p.torque[i];
    return 0;
  } else {
    return Vec<3>(angularMomentum(p.orientation[i], p.inertia[i], p.angularVelocity[i]) + half * p.torque[i]);
  }
}

template <int D>
void kickDrift(Particles<D>& p, double dt) {
  const double half = 0.5 * dt;
  const std::ptrdiff_t n = std::ptrdiff_t(p.size());
#pragma omp parallel for schedule(static) if (n > 512)
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    const auto L = halfKick(p, i, half);
    p.position[i] += dt * p.velocity[i];
    if constexpr (D == 2) {
      p.orientation[i] += dt * p.angularVelocity[i];
    } else {
      freeRotation(p.orientation[i], L, p.inertia[i], dt);
      p.angularVelocity[i] = angularVelocity(p.orientation[i], p.invInertia[i], L);
    }
  }
}

template <int D>
void kick(Particles<D>& p, double dt) {
  const double half = 0.5 * dt;
  const std::ptrdiff_t n = std::ptrdiff_t(p.size());
#pragma omp parallel for schedule(static) if (n > 512)
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    [[maybe_unused]] const auto L = halfKick(p, i, half);
    if constexpr (D == 3) p.angularVelocity[i] = angularVelocity(p.orientation[i], p.invInertia[i], L);
  }
}

template void kickDrift<2>(Particles<2>&, double);
template void kickDrift<3>(Particles<3>&, double);
template void kick<2>(Particles<2>&, double);
template void kick<3>(Particles<3>&, double);

}  // namespace lsdem::dynamics
