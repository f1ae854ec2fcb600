#include "lsdem/dynamics/Effect.h"

#include "lsdem/dynamics/World.h"

#include <algorithm>
#include <cmath>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace lsdem::dynamics {

template <int D>
void Gravity<D>::applyForces(World<D>& world, double dt) {
  const Particles<D>& p = world.particles();
  const std::span<Vec<D>> force = world.forces();
  double power = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (world.isGhost(i)) continue;  // (a mirror's force and work are its owner's)
    const Vec<D> f = p.mass[i] * g_;
    force[i] += f;
    power += f.dot(p.velocity[i]);
  }
  // Exact work over the closing step: x(n+1) - x(n) = dt v(n+1/2).
  world.addGravityWork(power * dt);
}

template <int D>
GlobalDamping<D>::GlobalDamping(double coefficient) : c_(coefficient) {
  if (!(coefficient >= 0.0) || !std::isfinite(coefficient)) {
    throw std::invalid_argument("global damping C_g must be >= 0 (1/s), got " + std::to_string(coefficient));
  }
}

template <int D>
void GlobalDamping<D>::applyForces(World<D>& world, double /*dt*/) {
  const Particles<D>& p = world.particles();
  const std::span<Vec<D>> force = world.forces();
  const std::span<Spin<D>> torque = world.torques();
  double power = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (world.isGhost(i)) continue;
    const Vec<D> f = -c_ * p.mass[i] * p.velocity[i];
    force[i] += f;
    power -= f.dot(p.velocity[i]);
    if constexpr (D == 2) {
      const double t = -c_ * p.inertia[i] * p.angularVelocity[i];
      torque[i] += t;
      power -= t * p.angularVelocity[i];
    } else {
      // I w in the world frame: rotate to the principal frame and back.
      const Vec<3> wb = p.orientation[i].conjugate() * p.angularVelocity[i];
      const Vec<3> t = -c_ * (p.orientation[i] * Vec<3>(p.inertia[i].cwiseProduct(wb)));
      torque[i] += t;
      power -= t.dot(p.angularVelocity[i]);
    }
  }
  power_ = power;
}

template <int D>
LocalDamping<D>::LocalDamping(double alpha) : alpha_(alpha) {
  if (!(alpha >= 0.0 && alpha < 1.0)) {
    throw std::invalid_argument("local damping alpha must be in [0, 1), got " + std::to_string(alpha));
  }
}

template <int D>
void LocalDamping<D>::applyForces(World<D>& world, double /*dt*/) {
  const Particles<D>& p = world.particles();
  const std::span<Vec<D>> force = world.forces();
  const std::span<Spin<D>> torque = world.torques();
  double power = 0.0;
  auto damp = [&](double& f, double v) {
    const double df = -alpha_ * std::abs(f) * (v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0));
    f += df;
    power -= df * v;
  };
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (world.isGhost(i)) continue;
    for (int a = 0; a < D; ++a) damp(force[i][a], p.velocity[i][a]);
    if constexpr (D == 2) {
      damp(torque[i], p.angularVelocity[i]);
    } else {
      for (int a = 0; a < 3; ++a) damp(torque[i][a], p.angularVelocity[i][a]);
    }
  }
  power_ = power;
}

template <int D>
void Outflow<D>::afterStep(World<D>& world) {
  // In ascending id order, so the records do not depend on where the
  // particles sit (a distributed run records each on its owner and orders
  // them by id); a step without removals allocates nothing.
  const Particles<D>& p = world.particles();
  std::size_t leaving = 0;
  for (std::size_t i = 0; i < p.size(); ++i) leaving += !keep_.contains(p.position[i]);
  if (leaving == 0) return;
  std::vector<ParticleId> ids;
  ids.reserve(leaving);
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (!keep_.contains(p.position[i])) ids.push_back(p.id[i]);
  }
  std::sort(ids.begin(), ids.end());
  for (const ParticleId id : ids) {
    // (Swap-removal moves the last particle: look each one up.)
    const std::size_t i = std::size_t(std::find(p.id.begin(), p.id.end(), id) - p.id.begin());
    const Vec<D> x = p.position[i];
    world.removeParticle(i, discharge_ && discharge_->contains(x) ? "discharge" : "outflow");
  }
}

template <int D>
Feed<D>::Feed(FeedDef<D> def) : def_(std::move(def)) {
  if (def_.shapes.empty()) throw std::invalid_argument("feed: needs at least one shape");
  for (const auto& s : def_.shapes) {
    if (!s) throw std::invalid_argument("feed: a shape is missing");
  }
  if (!(def_.density > 0.0) || !std::isfinite(def_.density)) {
    throw std::invalid_argument("feed: density must be positive, got " + std::to_string(def_.density));
  }
  if (!(def_.interval >= 0.0) || !std::isfinite(def_.interval)) {
    throw std::invalid_argument("feed: interval must be >= 0 s, got " + std::to_string(def_.interval));
  }
  if (def_.interval == 0.0 && !(def_.clearance > 0.0 && std::isfinite(def_.clearance))) {
    throw std::invalid_argument("feed: give an interval > 0 or a clearance > 0, got clearance " +
                                std::to_string(def_.clearance));
  }
  if (!def_.point.allFinite() || !def_.velocity.allFinite()) throw std::invalid_argument("feed: point and velocity must be finite");
}

template <int D>
bool Feed<D>::due(World<D>& world) const {
  if (def_.count > 0 && dropped_ >= def_.count) return false;
  if (world.time() < def_.startTime) return false;
  if (dropped_ > 0 && def_.interval > 0.0 && world.time() < lastDropTime_ + def_.interval) return false;
  // The drop point must be free: no particle's bounding sphere may reach the
  // next grain's (a grain dropped onto fragments of the last one would start
  // deeply overlapping them). With a clearance, the last grain must also have
  // moved that far from the point (or be gone: broken or removed). In a
  // distributed run each world asks its own particles and the answer is the
  // whole run's (World::anyWorld); the tests above agree everywhere.
  const Particles<D>& p = world.particles();
  const double r = def_.shapes[std::size_t(dropped_ % def_.shapes.size())]->boundingRadius();
  bool blocked = false;
  for (std::size_t i = 0; i < p.size() && !blocked; ++i) {
    const double distance = (p.position[i] - def_.point).norm();
    blocked = distance < r + p.shape[i]->boundingRadius() ||
              (def_.interval == 0.0 && dropped_ > 0 && p.id[i] == lastId_ && distance <= def_.clearance);
  }
  return !world.anyWorld(blocked);
}

template <int D>
void Feed<D>::afterStep(World<D>& world) {
  if (!due(world)) return;
  ParticleDef<D> g;
  g.shape = def_.shapes[std::size_t(dropped_ % def_.shapes.size())];
  g.density = def_.density;
  g.material = def_.material;
  g.position = def_.point;
  g.velocity = def_.velocity;
  g.birthTime = world.time();
  const std::size_t i = world.addParticle(g);
  lastId_ = world.particles().id[i];
  droppedMass_ += world.particles().mass[i];
  lastDropTime_ = world.time();
  ++dropped_;
}

template <int D>
void Feed<D>::saveState(StateWriter& out) const {
  out.putTag("feed");
  out.put(dropped_);
  out.put(lastDropTime_);
  out.put(lastId_);
  out.put(droppedMass_);
}

template <int D>
void Feed<D>::loadState(StateReader& in) {
  in.expectTag("feed");
  dropped_ = in.get<std::uint64_t>();
  lastDropTime_ = in.get<double>();
  lastId_ = in.get<std::uint64_t>();
  droppedMass_ = in.get<double>();
}

template class Feed<2>;
template class Feed<3>;
template class Gravity<2>;
template class Gravity<3>;
template class GlobalDamping<2>;
template class GlobalDamping<3>;
template class LocalDamping<2>;
template class LocalDamping<3>;
template class Outflow<2>;
template class Outflow<3>;

}  // namespace lsdem::dynamics
