#include "lsdem/dynamics/Effect.h"

#include "lsdem/dynamics/World.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace lsdem::dynamics {

template <int D>
void Gravity<D>::applyForces(World<D>& world, double dt) {
  Particles<D>& p = world.particles();
  double power = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Vec<D> f = p.mass[i] * g_;
    p.force[i] += f;
    power += f.dot(p.velocity[i]);
  }
  // Exact work over the closing step: x(n+1) - x(n) = dt v(n+1/2).
  world.energyLedger().gravityWork += power * dt;
}

template <int D>
GlobalDamping<D>::GlobalDamping(double coefficient) : c_(coefficient) {
  if (!(coefficient >= 0.0) || !std::isfinite(coefficient)) {
    throw std::invalid_argument("global damping C_g must be >= 0 (1/s), got " + std::to_string(coefficient));
  }
}

template <int D>
void GlobalDamping<D>::applyForces(World<D>& world, double dt) {
  Particles<D>& p = world.particles();
  double power = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Vec<D> f = -c_ * p.mass[i] * p.velocity[i];
    p.force[i] += f;
    power -= f.dot(p.velocity[i]);
    if constexpr (D == 2) {
      const double t = -c_ * p.inertia[i] * p.angularVelocity[i];
      p.torque[i] += t;
      power -= t * p.angularVelocity[i];
    } else {
      // I w in the world frame: rotate to the principal frame and back.
      const Vec<3> wb = p.orientation[i].conjugate() * p.angularVelocity[i];
      const Vec<3> t = -c_ * (p.orientation[i] * Vec<3>(p.inertia[i].cwiseProduct(wb)));
      p.torque[i] += t;
      power -= t.dot(p.angularVelocity[i]);
    }
  }
  world.energyLedger().dampingLoss += power * dt;
}

template <int D>
LocalDamping<D>::LocalDamping(double alpha) : alpha_(alpha) {
  if (!(alpha >= 0.0 && alpha < 1.0)) {
    throw std::invalid_argument("local damping alpha must be in [0, 1), got " + std::to_string(alpha));
  }
}

template <int D>
void LocalDamping<D>::applyForces(World<D>& world, double dt) {
  Particles<D>& p = world.particles();
  double power = 0.0;
  auto damp = [&](double& f, double v) {
    const double df = -alpha_ * std::abs(f) * (v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0));
    f += df;
    power -= df * v;
  };
  for (std::size_t i = 0; i < p.size(); ++i) {
    for (int a = 0; a < D; ++a) damp(p.force[i][a], p.velocity[i][a]);
    if constexpr (D == 2) {
      damp(p.torque[i], p.angularVelocity[i]);
    } else {
      for (int a = 0; a < 3; ++a) damp(p.torque[i][a], p.angularVelocity[i][a]);
    }
  }
  world.energyLedger().dampingLoss += power * dt;
}

template <int D>
void Outflow<D>::afterStep(World<D>& world) {
  // Walk backwards so swap-removal does not skip a particle.
  for (std::size_t i = world.particles().size(); i-- > 0;) {
    if (!keep_.contains(world.particles().position[i])) world.removeParticle(i, "outflow");
  }
}

template class Gravity<2>;
template class Gravity<3>;
template class GlobalDamping<2>;
template class GlobalDamping<3>;
template class LocalDamping<2>;
template class LocalDamping<3>;
template class Outflow<2>;
template class Outflow<3>;

}  // namespace lsdem::dynamics
