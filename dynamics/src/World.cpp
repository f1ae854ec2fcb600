#include "lsdem/dynamics/World.h"

#include "lsdem/dynamics/Integrator.h"
#include "lsdem/dynamics/TimeStep.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>

namespace lsdem::dynamics {
namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Hertz contacts are pair-level: their stiffness does not grow with the node
// count. The time step uses the tangent stiffness at an overlap of this
// fraction of the combined radius, a deep overlap for a Hertz contact.
constexpr double kHertzOverlapFraction = 0.05;

template <class T>
bool finite(const T& v) {
  if constexpr (std::is_arithmetic_v<T>) {
    return std::isfinite(v);
  } else if constexpr (std::is_same_v<T, Eigen::Quaterniond>) {
    return v.coeffs().allFinite();
  } else {
    return v.allFinite();
  }
}

// Velocity and spin of particle i after `lead` seconds of its current force
// and torque (the 3D spin through the inverse inertia at the current
// orientation).
template <int D>
std::pair<Vec<D>, Spin<D>> advanced(const Particles<D>& p, std::size_t i, double lead) {
  const Vec<D> v = p.velocity[i] + lead * p.invMass[i] * p.force[i];
  if constexpr (D == 2) {
    return {v, p.angularVelocity[i] + lead * p.invInertia[i] * p.torque[i]};
  } else {
    const Mat<3> R = p.rotation(i);
    return {v, p.angularVelocity[i] + lead * (R * p.invInertia[i].cwiseProduct(R.transpose() * p.torque[i]))};
  }
}

// Power the contact dashpots take out of the particles at the velocities the
// particles reach after `lead` seconds of their current forces: minus the
// dashpots' work rate on the particles, plus their work rate on moving
// boundaries (which the boundary work already counts). With ghosts (flags
// not empty), each pair's work on a particle counts where that particle is
// not a ghost (its owner, whose force on it is whole), a boundary's with
// its particle.
template <int D>
double dashpotLoss(const Particles<D>& p, const ContactSolver<D>& contacts, double lead,
                   const std::vector<std::uint8_t>& ghost) {
  const std::span<const PairContact<D>> pairs = contacts.pairContacts();
  const std::span<const PairDashpot<D>> dash = contacts.pairDashpots();
  const std::size_t particlePairs = contacts.particleContacts().size();
  const auto own = [&](std::size_t i) { return ghost.empty() || ghost[i] == 0; };
  double loss = 0.0;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const PairDashpot<D>& d = dash[k];
    if (d.power == 0.0) continue;
    if (own(pairs[k].a)) {
      const auto [va, wa] = advanced(p, pairs[k].a, lead);
      loss -= d.force.dot(va) + Rotation<D>::dot(d.torqueA, wa);
      if (k >= particlePairs) loss += d.boundaryPower;
    }
    if (k < particlePairs && own(pairs[k].b)) {
      const auto [vb, wb] = advanced(p, pairs[k].b, lead);
      loss -= -d.force.dot(vb) + Rotation<D>::dot(d.torqueB, wb);
    }
  }
  return loss;
}

}  // namespace

const char* stageName(Stage s) {
  switch (s) {
    case Stage::Integrate: return "integrate";
    case Stage::Kinematics: return "kinematics";
    case Stage::BroadPhase: return "broad_phase";
    case Stage::NarrowPhase: return "narrow_phase";
    case Stage::Accumulate: return "accumulate";
    case Stage::Effects: return "effects";
    case Stage::AfterStep: return "after_step";
    case Stage::Energy: return "energy";
    case Stage::Count: break;
  }
  return "unknown";
}

double EnergyLedger::scale() const {
  return std::max({std::abs(initial), std::abs(total()), std::abs(gravityWork), std::abs(boundaryWork), dampingLoss,
                   contactLoss, removedEnergy, addedEnergy, std::abs(splitRelease), std::numeric_limits<double>::min()});
}

double EnergyLedger::relativeBalanceError() const { return balanceError() / scale(); }

void EnergyLedger::add(const EnergyLedger& o) {
  kineticTranslational += o.kineticTranslational;
  kineticRotational += o.kineticRotational;
  elastic += o.elastic;
  gravityWork += o.gravityWork;
  boundaryWork += o.boundaryWork;
  dampingLoss += o.dampingLoss;
  contactLoss += o.contactLoss;
  removedEnergy += o.removedEnergy;
  addedEnergy += o.addedEnergy;
  splitRelease += o.splitRelease;
  initial += o.initial;
}

template <int D>
World<D>::World(const WorldDef<D>& def) : def_(def), broad_(def.broadPhase), contacts_(def.contact) {
  if (!(def.dt >= 0.0) || !std::isfinite(def.dt)) {
    throw std::invalid_argument("dt must be >= 0 (0: automatic), got " + std::to_string(def.dt));
  }
  if (def.densityScaling) {
    const DensityScalingDef& ds = *def.densityScaling;
    if (!(ds.belowDiameter > 0.0) || !std::isfinite(ds.belowDiameter)) {
      throw std::invalid_argument("density scaling: the size below which fragments are scaled must be > 0 m, got " +
                                  std::to_string(ds.belowDiameter));
    }
    if (!(ds.maxFactor >= 1.0) || !std::isfinite(ds.maxFactor)) {
      throw std::invalid_argument("density scaling: the largest factor must be >= 1, got " +
                                  std::to_string(ds.maxFactor));
    }
  }
  if (!(def.dtSafety > 0.0 && def.dtSafety <= 1.0)) {
    throw std::invalid_argument("dt safety factor must be in (0, 1], got " + std::to_string(def.dtSafety));
  }
  // Effects the scene declared, and only those.
  if (def.gravity) addEffect(std::make_unique<Gravity<D>>(*def.gravity));
  if (def.globalDamping) addEffect(std::make_unique<GlobalDamping<D>>(*def.globalDamping));
  if (def.localDamping) addEffect(std::make_unique<LocalDamping<D>>(*def.localDamping));
  if (def.outflow) addEffect(std::make_unique<Outflow<D>>(*def.outflow, def.discharge));
  dt_ = def.dt;
}

// ---------------------------------------------------------------- building --

namespace {

// How much more a tangential spring at the surface shakes a body than a
// normal one through its centre: 1 + m r^2 / I_min per unit density (r the
// bounding radius; 3.5 for a sphere), the rotation the spring drives.
template <int D>
double tangentialLeverage(const geometry::Shape<D>& shape) {
  const auto& mp = shape.mass();
  const double r = shape.boundingRadius();
  if constexpr (D == 2) {
    return 1.0 + mp.volume * r * r / mp.polarMoment();
  } else {
    return 1.0 + mp.volume * r * r / mp.principalInertia().minCoeff();
  }
}

}  // namespace

template <int D>
typename World<D>::ShapeStiffness World<D>::shapeStiffness(const std::shared_ptr<const geometry::Shape<D>>& shapePtr) {
  // A hit needs the cached shape alive: an expired entry's address may now
  // hold another shape (it is then recomputed in place). Expired entries are
  // dropped whenever the cache has doubled since the last sweep, so a lookup
  // and the sweeps cost O(1) amortised per shape.
  const auto hit = shapeStiffness_.find(shapePtr.get());
  if (hit != shapeStiffness_.end() && !hit->second.alive.expired()) return hit->second.stiffness;
  if (shapeStiffness_.size() >= 2 * stiffnessSweepSize_ + 64) {
    std::erase_if(shapeStiffness_, [](const auto& entry) { return entry.second.alive.expired(); });
    stiffnessSweepSize_ = shapeStiffness_.size();
  }
  const geometry::Shape<D>& shape = *shapePtr;
  const ContactLawDef& law = def_.contact;

  // The stiffest contact of one kind: its constants, and whether the partner is a particle.
  const auto stiffnessOf = [&](const ContactConstants& c, bool particlePairs) -> ShapeStiffness {
    if (law.normal == NormalModel::Hertz) {
      // Pair-level: the tangent stiffness at a deep overlap (and the Mindlin
      // spring's, through the rotation it drives), doubled for two particles.
      const double own = equivalentRadius<D>(shape.volume());
      const double R = particlePairs ? combinedRadius(own, own) : own;
      double k = hertzStiffness(c.eStar, R, kHertzOverlapFraction * R);
      if (law.hasFriction && c.gStar > 0.0) {
        k = std::max(k, tangentialLeverage(shape) * mindlinStiffness(c.gStar, R, kHertzOverlapFraction * R));
      }
      return {(particlePairs ? 2.0 : 1.0) * k, -1, 0};
    }
    NodeStiffness ns;
    const double w = referenceNodeWeight<D>(shape.contactSpacing());
    ns.perNode = law.formulation == ForceFormulation::PerNode ? c.kn : 0.0;
    ns.perWeight = law.formulation == ForceFormulation::AreaWeighted ? c.kn / w : 0.0;
    ns.tangentialRatio = law.hasFriction ? c.ks / c.kn : 0.0;
    ContactStiffnessOptions options;
    options.particlePairs = particlePairs;
    const StiffestContact<D> patch = stiffestContact(shape, ns, options);
    return {patch.stiffness, -1, patch.nodeCount};
  };

  // Particle on particle, then every boundary with its own material (a
  // boundary of the grains' material is never stiffer than a particle pair).
  ShapeStiffness k = stiffnessOf(lawConstants(law), true);
  const auto consider = [&](const ContactConstants* c, std::size_t boundary) {
    if (c == nullptr) return;
    ShapeStiffness kb = stiffnessOf(*c, false);
    kb.boundary = std::int32_t(boundary);
    if (kb.stiffness > k.stiffness) k = kb;
  };
  for (std::size_t j = 0; j < planes_.size(); ++j) consider(contacts_.planeConstants(j), j);
  for (std::size_t j = 0; j < tools_.size(); ++j) consider(contacts_.toolConstants(j), planes_.size() + j);
  // (kn near the largest double overflows the stiffness of a node patch,
  // which then comes out 0 or not finite: the time step would be 0.)
  if (!std::isfinite(k.stiffness) || !(k.stiffness > 0.0)) {
    std::ostringstream what;
    what << "contact stiffness of a grain = " << k.stiffness << " N/m is not a finite positive number (";
    if (k.boundary >= 0) what << "against boundary " << k.boundary << " with its own material; ";
    if (law.normal == NormalModel::Hertz) {
      what << "youngs_modulus = " << law.youngsModulus << " Pa";
    } else {
      what << "kn = " << law.kn << " N/m, ks = " << law.ks << " N/m";
    }
    what << "): the time step would be 0 s";
    throw std::invalid_argument(what.str());
  }
  shapeStiffness_[shapePtr.get()] = CachedStiffness{shapePtr, k};
  return k;
}

template <int D>
TimeStepLimit World<D>::limitOf(std::size_t i) const {
  const geometry::Shape<D>& shape = *particles_.shape[i];
  TimeStepLimit l;
  l.id = particles_.id[i];
  l.mass = particles_.mass[i];
  l.stiffness = stiffness_[i].stiffness;
  l.patchNodes = stiffness_[i].patchNodes;
  l.diameter = shape.descriptors().equivalentDiameter;
  l.spacing = shape.grid().spacing();
  l.nodes = shape.nodes().size();
  l.generation = particles_.generation[i];
  l.boundary = stiffness_[i].boundary;
  l.densityScale = densityScale(i);
  return l;
}

template <int D>
void World<D>::updateTimeStep(bool lastAddedOnly) {
  const double zeta = def_.contact.hasDamping ? def_.contact.dampingRatio : 0.0;
  // The particle with the largest omega^2 = k / m (of equals, the lowest id:
  // setsStepBefore) sets the step; the minimum over particles of
  // criticalTimeStep is that particle's.
  const auto omega2Of = [&](std::size_t i) { return stiffness_[i].stiffness / particles_.mass[i]; };
  const auto setLimit = [&](std::size_t i) {
    dtCritical_ = criticalTimeStep({particles_.mass[i]}, {stiffness_[i].stiffness}, zeta);
    limit_ = limitOf(i);
    limit_.criticalDt = dtCritical_;
  };
  if (lastAddedOnly) {
    // One particle more: the minimum over particles takes one more term (O(1)
    // per add, so building a world of N particles stays O(N)).
    const std::size_t i = particles_.size() - 1;
    const double w2 = std::isfinite(dtCritical_) ? limit_.omega2() : 0.0;
    if (setsStepBefore(omega2Of(i), particles_.id[i], w2, limit_.id)) setLimit(i);
  } else {
    // A distributed part counts its own particles only: a mirror's owner
    // counts it (finishCoordination takes the run's minimum), and a mirror
    // may be of a parent that has split on its owner and not left here yet.
    std::size_t stiffest = particles_.size();
    double omega2 = 0.0;
    std::uint64_t stiffestId = kNoParent;
    for (std::size_t i = 0; i < particles_.size(); ++i) {
      if (!ghost_.empty() && ghost_[i]) continue;
      const double w2 = omega2Of(i);
      if (setsStepBefore(w2, particles_.id[i], omega2, stiffestId)) {
        omega2 = w2;
        stiffest = i;
        stiffestId = particles_.id[i];
      }
    }
    if (stiffest < particles_.size()) {
      setLimit(stiffest);
    } else {
      dtCritical_ = std::numeric_limits<double>::infinity();
    }
  }
  stepFromCritical();
}

template <int D>
void World<D>::boundaryMaterialsChanged() {
  shapeStiffness_.clear();
  if (particles_.empty()) return;
  for (std::size_t i = 0; i < particles_.size(); ++i) stiffness_[i] = shapeStiffness(particles_.shape[i]);
  updateTimeStep(false);
}

template <int D>
double World<D>::densityScale(std::size_t i) const {
  const double decided = decidedDensityScale(i);  // (a factor is >= 1; 0: none decided)
  return decided > 0.0 ? decided : 1.0;
}

template <int D>
double World<D>::unscaledMass(std::size_t i) const {
  return particles_.mass[i] / densityScale(i);
}

template <int D>
double World<D>::decidedDensityScale(std::size_t i) const {
  if (densityScales_.empty()) return 0.0;
  const auto it = densityScales_.find(particles_.id[i]);
  return it == densityScales_.end() ? 0.0 : it->second;
}

template <int D>
void World<D>::setDecidedDensityScale(std::size_t i, double factor) {
  if (factor > 0.0) {
    densityScales_[particles_.id[i]] = factor;
  } else {
    densityScales_.erase(particles_.id[i]);
  }
}

template <int D>
void World<D>::scaleDensity(std::size_t i) {
  // Only small fragments, each decided once.
  const DensityScalingDef& ds = *def_.densityScaling;
  Particles<D>& p = particles_;
  if (p.parentId[i] == kNoParent || !(p.shape[i]->descriptors().equivalentDiameter < ds.belowDiameter)) return;
  if (!densityScales_.emplace(p.id[i], 1.0).second) return;
  // The factor that brings its omega^2 down to the reference, within [1, maxFactor].
  const double omega2 = stiffness_[i].stiffness / p.mass[i];
  const double ref = scalingStats_.referenceOmega2;
  const double factor = ref > 0.0 ? std::clamp(omega2 / ref, 1.0, ds.maxFactor) : 1.0;
  if (!(factor > 1.0)) return;
  densityScales_[p.id[i]] = factor;
  const double before = p.kineticEnergy(i);
  p.mass[i] *= factor;
  p.invMass[i] = 1.0 / p.mass[i];
  p.inertia[i] *= factor;
  if constexpr (D == 2) {
    p.invInertia[i] = 1.0 / p.inertia[i];
  } else {
    p.invInertia[i] = p.inertia[i].cwiseInverse();
  }
  if (steps_ > 0) energy_.addedEnergy += p.kineticEnergy(i) - before;
  ++scalingStats_.scaled;
  scalingStats_.largestFactor = std::max(scalingStats_.largestFactor, factor);
  if (factor == ds.maxFactor) ++scalingStats_.capped;
}

template <int D>
void World<D>::anticipateParticle(const ParticleDef<D>& def) {
  if (!def.shape) throw std::invalid_argument("anticipateParticle: the particle has no shape");
  const double mass = def.density * def.massScale * def.shape->volume();
  if (!(mass > 0.0) || !std::isfinite(mass)) {
    throw std::invalid_argument("anticipateParticle: mass must be positive, got " + std::to_string(mass));
  }
  const double zeta = def_.contact.hasDamping ? def_.contact.dampingRatio : 0.0;
  const ShapeStiffness k = shapeStiffness(def.shape);
  const double critical = criticalTimeStep({mass}, {k.stiffness}, zeta);
  if (critical < dtCritical_) {
    // A grain still to come: no id yet.
    dtCritical_ = critical;
    limit_ = TimeStepLimit{};
    limit_.id = kNoParent;
    limit_.mass = mass;
    limit_.stiffness = k.stiffness;
    limit_.patchNodes = k.patchNodes;
    limit_.diameter = def.shape->descriptors().equivalentDiameter;
    limit_.spacing = def.shape->grid().spacing();
    limit_.nodes = def.shape->nodes().size();
    limit_.boundary = k.boundary;
    limit_.criticalDt = critical;
  }
  stepFromCritical();
}

template <int D>
void World<D>::stepFromCritical() {
  if (!std::isfinite(dtCritical_)) return;  // no contacts possible yet
  const double before = dt_;
  if (def_.dt > 0.0) {
    checkUserTimeStep(def_.dt, dtCritical_, def_.forceDt, def_.dtSafety);
    dt_ = def_.dt;
  } else {
    // Automatic: never grow during a run (adding particles only lowers it).
    const double stable = stableTimeStep(dtCritical_, def_.dtSafety);
    dt_ = dt_ > 0.0 ? std::min(dt_, stable) : stable;
  }
  if (dt_ != before || dtChanges_.empty()) dtChanges_.push_back({time_, dt_, limit_});
}

template <int D>
std::size_t World<D>::addParticle(const ParticleDef<D>& def) {
  if (coordinator_ && def.id == kNoParent) {
    // The run's next id, the same in every world (a feed adds alike
    // everywhere); the world that keeps it as its own books the energy it
    // brings (afterStepCoordinated).
    ParticleDef<D> withId = def;
    withId.id = coordinator_->takeId();
    effectAdded_.push_back(withId.id);
    return insertParticle(withId, false);
  }
  return insertParticle(def, true);
}

template <int D>
std::size_t World<D>::addCopy(const ParticleDef<D>& def, double densityScale) {
  if (!(def.mass > 0.0)) throw std::invalid_argument("World::addCopy: a copy needs its owner's mass");
  const std::size_t i = insertParticle(def, false);
  setDecidedDensityScale(i, densityScale);
  return i;
}

template <int D>
std::size_t World<D>::insertParticle(const ParticleDef<D>& def, bool books) {
  const std::size_t i = particles_.add(def);
  effectChanged_ = true;
  if (!ghost_.empty()) ghost_.push_back(0);
  stiffness_.push_back(shapeStiffness(def.shape));
  // A mass given is a copy's (a distributed run's mirror or view), as its
  // owner scaled it; the owner's decision comes with it (setDecidedDensityScale).
  if (def_.densityScaling && !(def.mass > 0.0)) scaleDensity(i);
  updateTimeStep(true);
  broad_.invalidate();
  forcesValid_ = false;
  energyCurrent_ = false;
  if (books && steps_ > 0) energy_.addedEnergy += particles_.kineticEnergy(i);
  return i;
}

template <int D>
void World<D>::removeParticle(std::size_t index, const std::string& reason) {
  if (isGhost(index)) {
    // A mirror leaves with its particle, which its owner records.
    detachParticle(index);
    return;
  }
  RemovedParticle r;
  r.id = particles_.id[index];
  r.time = time_;
  r.mass = unscaledMass(index);
  if (!densityScales_.empty()) densityScales_.erase(r.id);
  r.volume = particles_.shape[index]->volume();
  r.sieveSize = particles_.shape[index]->descriptors().sieveSize;
  r.reason = reason;
  removed_.push_back(r);
  energy_.removedEnergy += particles_.kineticEnergy(index);
  dropParticle(index);
}

template <int D>
void World<D>::detachParticle(std::size_t index) {
  if (index >= particles_.size()) {
    throw std::out_of_range("World::detachParticle: index " + std::to_string(index) + " of " +
                            std::to_string(particles_.size()) + " particles");
  }
  if (!densityScales_.empty()) densityScales_.erase(particles_.id[index]);
  dropParticle(index);
}

template <int D>
void World<D>::dropParticle(std::size_t index) {
  particles_.remove(index);
  effectChanged_ = true;
  if (!ghost_.empty()) {
    ghost_[index] = ghost_.back();
    ghost_.pop_back();
  }
  if (index < stiffness_.size()) {
    stiffness_[index] = stiffness_.back();
    stiffness_.pop_back();
  }
  // The contact records index the particles as they were (the last one took
  // the removed one's place): the next step re-evaluates them, and the
  // springs the particle held leave the ledger as splitRelease.
  broad_.invalidate();
  forcesValid_ = false;
  energyCurrent_ = false;
}

template <int D>
void World<D>::setGhost(std::size_t index, bool ghost) {
  if (index >= particles_.size()) {
    throw std::out_of_range("World::setGhost: index " + std::to_string(index) + " of " +
                            std::to_string(particles_.size()) + " particles");
  }
  if (ghost_.empty()) {
    if (!ghost) return;
    ghost_.assign(particles_.size(), 0);
  }
  if (ghost_[index] != std::uint8_t(ghost)) forcesValid_ = false;
  ghost_[index] = std::uint8_t(ghost);
  energyCurrent_ = false;  // (this world's share of the kinetic energy)
}

template <int D>
void World<D>::setMotion(std::size_t index, const Vec<D>& position, const Orientation<D>& orientation,
                         const Vec<D>& velocity, const Spin<D>& angularVelocity) {
  particles_.position.at(index) = position;
  particles_.orientation[index] = orientation;
  particles_.velocity[index] = velocity;
  particles_.angularVelocity[index] = angularVelocity;
  forcesValid_ = false;
  energyCurrent_ = false;
}

template <int D>
void World<D>::setBoundaryLoads(const BoundaryLoads<D>& loads) {
  if (loads.planeForce.size() != planes_.size() || loads.planeTorque.size() != planes_.size() ||
      loads.toolForce.size() != tools_.size() || loads.toolTorque.size() != tools_.size()) {
    throw std::invalid_argument("World::setBoundaryLoads: loads for " + std::to_string(loads.planeForce.size()) +
                                " planes and " + std::to_string(loads.toolForce.size()) + " tools, the world has " +
                                std::to_string(planes_.size()) + " and " + std::to_string(tools_.size()));
  }
  loads_ = loads;
}

template <int D>
void World<D>::recordRemoval(const RemovedParticle& r, double kineticEnergy) {
  removed_.push_back(r);
  energy_.removedEnergy += kineticEnergy;
}

template <int D>
std::size_t World<D>::addTool(const ToolDef<D>& def) {
  if (!def.shape) throw std::invalid_argument("tool '" + def.name + "' needs a shape");
  if (def.material) contacts_.setToolMaterial(tools_.size(), *def.material);
  tools_.push_back(def);
  toolPoses_.emplace_back();
  toolPoses_.back().shape = def.shape.get();
  moveKinematicBodies(time_);
  forcesValid_ = false;
  if (def.material) boundaryMaterialsChanged();
  return tools_.size() - 1;
}

template <int D>
std::size_t World<D>::addPlane(const PlaneDef<D>& def) {
  const double n = def.plane.normal.norm();
  if (!(std::abs(n - 1.0) < 1e-6)) {
    throw std::invalid_argument("plane '" + def.name + "' needs a unit normal, |n| = " + std::to_string(n));
  }
  if (def.material) contacts_.setPlaneMaterial(planes_.size(), *def.material);
  Plane<D> atStart = def.plane;
  planesAtStart_.push_back(atStart);
  atStart.point += time_ * atStart.velocity;
  planes_.push_back(atStart);
  planeNames_.push_back(def.name);
  forcesValid_ = false;
  if (def.material) boundaryMaterialsChanged();
  return planes_.size() - 1;
}

template <int D>
void World<D>::addEffect(std::unique_ptr<Effect<D>> effect) {
  effects_.push_back(std::move(effect));
  effectSeconds_.push_back(0.0);
}

template <int D>
std::vector<std::size_t> World<D>::replace(std::vector<Replacement<D>>& splits) {
  std::vector<std::size_t> parents;
  parents.reserve(splits.size());
  for (const Replacement<D>& s : splits) {
    if (s.parent >= particles_.size()) {
      throw std::out_of_range("World::replace: parent index " + std::to_string(s.parent) + " of " +
                              std::to_string(particles_.size()) + " particles");
    }
    if (!s.births.empty() && s.births.size() != s.children.size()) {
      throw std::invalid_argument("World::replace: " + std::to_string(s.births.size()) + " births for " +
                                  std::to_string(s.children.size()) + " children");
    }
    parents.push_back(s.parent);
  }
  std::sort(parents.begin(), parents.end(), std::greater<>());
  if (std::adjacent_find(parents.begin(), parents.end()) != parents.end()) {
    throw std::out_of_range("World::replace: a parent given twice");
  }
  // A distributed run: the run's ids for this batch (collective).
  if (coordinator_) {
    if (!replaceAllowed_ || coordinatedThisStep_) {
      throw std::logic_error(
          "World::replace: in a distributed run only an effect that declares replacesParticles() replaces particles, "
          "at most once per step");
    }
    splitRequests_.clear();
    for (const Replacement<D>& s : splits) {
      const ParticleId parent = particles_.id[s.parent];
      if (!splitRequests_.empty() && !(splitRequests_.back().parent < parent)) {
        throw std::invalid_argument("World::replace: a distributed run needs the splits in ascending parent id");
      }
      splitRequests_.push_back({parent, s.fines.size(), s.children.size()});
    }
    coordinatedThisStep_ = true;
    coordinator_->allocateIds(splitRequests_, splitIds_);
  }
  // The ledger, split by split: the fines' kinetic energy is brought (by a
  // fragment) and carried away at once; the parent's leaves with it.
  for (std::size_t k = 0; k < splits.size(); ++k) {
    Replacement<D>& s = splits[k];
    for (std::size_t f = 0; f < s.fines.size(); ++f) {
      auto& [r, kinetic] = s.fines[f];
      r.id = coordinator_ ? splitIds_[k].firstFine + f : particles_.nextId();
      particles_.reserveIdsBelow(r.id + 1);
      r.time = time_;
      energy_.addedEnergy += kinetic;
      recordRemoval(r, kinetic);
    }
    energy_.addedEnergy -= particles_.kineticEnergy(s.parent);
  }
  // Parents leave, highest index first (swap-removal keeps the others valid);
  // the children enter in order with their births and bring their kinetic energy.
  for (std::size_t i : parents) dropParticle(i);
  std::vector<std::size_t> added;
  born_.clear();
  for (std::size_t k = 0; k < splits.size(); ++k) {
    Replacement<D>& s = splits[k];
    for (std::size_t c = 0; c < s.children.size(); ++c) {
      ParticleDef<D>& def = s.children[c];
      if (coordinator_) def.id = splitIds_[k].firstChild + c;
      const std::size_t i = particles_.add(def);
      def.id = particles_.id[i];
      if (!ghost_.empty()) ghost_.push_back(0);
      energy_.addedEnergy += particles_.kineticEnergy(i);
      added.push_back(i);
      const ChildBirth* birth = s.births.empty() ? nullptr : &s.births[c];
      if (birth) markBirth(def.id, *birth);
      if (coordinator_) born_.push_back({def.id, birth});
    }
  }
  const std::size_t dtChangesBefore = dtChanges_.size();
  const double dtBefore = dt_;
  particlesChanged();
  if (!coordinator_) return added;

  // A distributed run: the run's time step and the mirrors (collective),
  // which may reorder the particles; each child stays here (its own, or a
  // mirror when its centroid lies in another part: it is within reach).
  finishCoordination(dtChangesBefore, dtBefore);
  std::vector<std::pair<ParticleId, std::size_t>> byId;
  byId.reserve(added.size());
  for (std::size_t k = 0; k < born_.size(); ++k) byId.emplace_back(born_[k].id, k);
  std::sort(byId.begin(), byId.end());
  std::size_t found = 0;
  for (std::size_t i = 0; i < particles_.size(); ++i) {
    const auto it = std::lower_bound(byId.begin(), byId.end(), std::pair<ParticleId, std::size_t>{particles_.id[i], 0});
    if (it == byId.end() || it->first != particles_.id[i]) continue;
    added[it->second] = i;
    ++found;
  }
  if (found != added.size()) {
    throw std::logic_error("World::replace: a child left this part of the distributed run at its birth");
  }
  return added;
}

template <int D>
void World<D>::finishCoordination(std::size_t dtChangesBefore, double dtBefore) {
  // The new small fragments' density scaling, from the run's reference; the
  // critical step of what this part holds (one world takes it over all its
  // particles after a replacement).
  if (def_.densityScaling) scaleNewFragments();
  updateTimeStep(false);
  // Each part saw its own particles; the run's step is the smallest, and
  // every part keeps the run's critical step and what sets it (a mirror that
  // arrives later cannot lower it: its owner counted it).
  // (A part that owns no particle offers none: its limit_ is an old one. A
  // run with no particle left keeps an infinite critical step and its last
  // limit, as one world does.)
  TimeStepLimit runLimit = std::isfinite(dtCritical_) ? limit_ : TimeStepLimit{};
  dt_ = coordinator_->agreeTimeStep(dt_, runLimit);
  if (runLimit.criticalDt > 0.0) {
    dtCritical_ = runLimit.criticalDt;
    limit_ = runLimit;
  }
  dtChanges_.resize(dtChangesBefore);
  if (dt_ != dtBefore) dtChanges_.push_back({time_, dt_, runLimit});
  // One world re-evaluates all its contacts after a replacement; so does
  // every part, whether or not its own set changed (the coordinator, once
  // the mirrors are up to date).
  broad_.invalidate();
  forcesValid_ = false;
  energyCurrent_ = false;
  coordinator_->particlesReplaced(born_);
}

template <int D>
void World<D>::markBirth(std::uint64_t id, const ChildBirth& birth) {
  contacts_.markNewborn(id, birth.newFaceNodes);
  for (const ChildBirth::Rest& r : birth.rests) {
    if (r.childOwns) {
      contacts_.inheritRestOverlap(id, r.key, r.node, r.restOverlap);
    } else {
      contacts_.inheritRestOverlap(r.key, id, r.node, r.restOverlap);
    }
  }
}

template <int D>
void World<D>::particlesChanged() {
  broad_.invalidate();
  forcesValid_ = false;
  energyCurrent_ = false;
  stiffness_.resize(particles_.size());
  for (std::size_t i = 0; i < particles_.size(); ++i) stiffness_[i] = shapeStiffness(particles_.shape[i]);
  // A distributed run scales, and then re-checks the step (which never
  // grows), once the run's reference is known: finishCoordination.
  if (coordinator_) return;
  if (def_.densityScaling) scaleNewFragments();
  updateTimeStep(false);
}

template <int D>
void World<D>::scaleNewFragments() {
  // The reference: the fastest particle the scaling leaves alone (so far),
  // of the whole run; then the new small fragments (a mirror's is its
  // owner's, decided already); then forget the particles that left.
  Particles<D>& p = particles_;
  const double below = def_.densityScaling->belowDiameter;
  double reference = scalingStats_.referenceOmega2;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p.parentId[i] != kNoParent && p.shape[i]->descriptors().equivalentDiameter < below) continue;
    reference = std::max(reference, stiffness_[i].stiffness / p.mass[i]);
  }
  scalingStats_.referenceOmega2 = coordinator_ ? coordinator_->largest(reference) : reference;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (!isGhost(i)) scaleDensity(i);
  }
  std::vector<std::uint64_t> present(p.id.begin(), p.id.end());
  std::sort(present.begin(), present.end());
  std::erase_if(densityScales_, [&](const auto& e) { return !std::binary_search(present.begin(), present.end(), e.first); });
}

template <int D>
std::vector<std::string> World<D>::effectNames() const {
  std::vector<std::string> names;
  for (const auto& e : effects_) names.push_back(e->name());
  return names;
}

// ----------------------------------------------------------------- running --

template <int D>
void World<D>::moveKinematicBodies(double t) {
  for (std::size_t k = 0; k < tools_.size(); ++k) {
    // A servo platen reacts to the force the particles exerted last step.
    if (auto* servo = std::get_if<ServoPlaten<D>>(&tools_[k].motion)) {
      if (k < loads_.toolForce.size() && t > time_) {
        servo->update(-loads_.toolForce[k].dot(servo->def().direction), t - time_);
      }
    }
    const KinematicState<D> s = evaluate(tools_[k].motion, t);
    ToolPose<D>& pose = toolPoses_[k];
    pose.position = s.position;
    pose.orientation = s.orientation;
    pose.velocity = s.velocity;
    pose.angularVelocity = s.angularVelocity;
  }
  for (std::size_t k = 0; k < planes_.size(); ++k) {
    planes_[k].point = planesAtStart_[k].point + t * planesAtStart_[k].velocity;
  }
}

template <int D>
void World<D>::computeForces(double dtClosing) {
  // Broad phase: bounding spheres with a Verlet skin.
  auto t0 = Clock::now();
  radii_.resize(particles_.size());
  // (The tricubic look-up's negative region reaches a little farther: lookupRadius.)
  for (std::size_t i = 0; i < particles_.size(); ++i) {
    radii_[i] = lookupRadius(*particles_.shape[i], def_.contact.interpolation);
  }
  broad_.update(particles_.position, radii_, particles_.id);
  stageSeconds_[std::size_t(Stage::BroadPhase)] += secondsSince(t0);

  // Narrow phase and contact law (eq. 3-4). The shear increment needs a step;
  // the initial evaluation uses the step to come. A re-evaluation between
  // steps (the particle set changed) sees the state the last evaluation saw,
  // so the shear springs of the pairs that remain keep their length.
  t0 = Clock::now();
  const double forceTime = dtClosing > 0.0 ? time_ + dtClosing : time_;
  contacts_.setFrictionActive(forceTime >= def_.contact.frictionFrom);
  // With ghosts (a distributed run), the pairs of two ghosts are left out;
  // a view (showRunOf) evaluates only the pairs its run found touching.
  const std::vector<std::array<std::uint32_t, 2>>* pairs = &broad_.pairs();
  if (!ghost_.empty() || onlyPairs_) {
    evaluatedPairs_.clear();
    for (const auto& pair : broad_.pairs()) {
      if (!ghost_.empty() && ghost_[pair[0]] && ghost_[pair[1]]) continue;
      if (onlyPairs_) {
        const ParticleId a = particles_.id[pair[0]], b = particles_.id[pair[1]];
        const std::array<ParticleId, 2> key{std::min(a, b), std::max(a, b)};
        if (!std::binary_search(onlyPairs_->begin(), onlyPairs_->end(), key)) continue;
      }
      evaluatedPairs_.push_back(pair);
    }
    pairs = &evaluatedPairs_;
  }
  contacts_.compute(particles_, *pairs, planes_, toolPoses_, dtClosing > 0.0 ? dtClosing : dt_,
                    dtClosing > 0.0 || steps_ == 0);
  evaluatedElastic_ = contacts_.elasticEnergy();
  if (!ghost_.empty()) {
    evaluatedElastic_ = 0.0;
    for (const PairContact<D>& rec : contacts_.pairContacts()) {
      if (!ghost_[rec.a]) evaluatedElastic_ += rec.elasticEnergy;
    }
  }
  stageSeconds_[std::size_t(Stage::NarrowPhase)] += secondsSince(t0);

  // Sum contact forces into the particles in a fixed order.
  t0 = Clock::now();
  for (std::size_t i = 0; i < particles_.size(); ++i) {
    particles_.force[i].setZero();
    particles_.torque[i] = Rotation<D>::zeroSpin();
  }
  loads_ = contacts_.accumulate(particles_);
  stageSeconds_[std::size_t(Stage::Accumulate)] += secondsSince(t0);

  // Declared effects (gravity books its exact work over the closing step).
  for (std::size_t e = 0; e < effects_.size(); ++e) {
    t0 = Clock::now();
    effects_[e]->applyForces(*this, dtClosing);
    const double s = secondsSince(t0);
    effectSeconds_[e] += s;
    stageSeconds_[std::size_t(Stage::Effects)] += s;
  }

  t0 = Clock::now();
  if (def_.energyLedger) bookClosing(dtClosing);
  stageSeconds_[std::size_t(Stage::Energy)] += secondsSince(t0);
  forcesValid_ = true;
}

template <int D>
void World<D>::bookClosing(double dtClosing) {
  // Sliding friction: capping a shear spring at the Coulomb limit took
  // energy out of it at this evaluation, booked whole (power x the solver's
  // step). At a re-evaluation between steps that drop is part of splitRelease.
  // With ghosts, a pair's loss is booked where its lower-id particle (a) is
  // not a ghost.
  if (dtClosing > 0.0) {
    const std::span<const PairContact<D>> records = contacts_.pairContacts();
    const std::span<const PairDashpot<D>> dash = contacts_.pairDashpots();
    double dissipated = 0.0, dashpotPower = 0.0;
    for (std::size_t k = 0; k < records.size(); ++k) {
      if (isGhost(records[k].a)) continue;
      dissipated += records[k].dissipatedPower;
      dashpotPower += dash[k].power;
    }
    energy_.contactLoss += (dissipated - dashpotPower) * dtClosing;
  }

  // Powers of the damping effects and moving boundaries (see lastPower_),
  // with ghosts through this world's own particles only.
  double dampingPower = 0.0;
  for (const auto& e : effects_) dampingPower += e->dampingPower();
  const BoundaryLoads<D>& loads = ghost_.empty() ? loads_ : contacts_.boundaryLoadsOf(ghost_, ownLoads_);
  double boundaryPower = 0.0;
  for (std::size_t k = 0; k < planes_.size(); ++k) boundaryPower -= loads.planeForce[k].dot(planes_[k].velocity);
  for (std::size_t k = 0; k < toolPoses_.size(); ++k) {
    boundaryPower -= loads.toolForce[k].dot(toolPoses_[k].velocity);
    boundaryPower -= Rotation<D>::dot(loads.toolTorque[k], toolPoses_[k].angularVelocity);
  }
  lastPower_ = {dampingPower, boundaryPower};

  // The closing half kick: velocities go from v(n+1/2) on by dt/2 a.
  if (dtClosing > 0.0) bookHalfKick(0.5 * dtClosing, 0.25 * dtClosing, energy_);
}

template <int D>
void World<D>::bookHalfKick(double halfDt, double lead, EnergyLedger& into) const {
  into.dampingLoss += halfDt * lastPower_[0];
  into.boundaryWork += halfDt * lastPower_[1];
  // Contact dashpots, exactly: over a half kick a dashpot force does its
  // force times the mean velocity of that half kick, the velocity `lead`
  // seconds of the current forces ahead (a quarter step). Booking the sampled
  // c v^2 dt instead overstates the loss by about c dt / (2 m) of it, which for
  // small or slender bodies (whose effective mass at a contact is a fraction
  // of their mass) showed as energy from nothing.
  if (def_.contact.hasDamping) into.contactLoss += halfDt * dashpotLoss(particles_, contacts_, lead, ghost_);
}

template <int D>
void World<D>::refreshContacts() {
  if (forcesValid_) return;
  const double elasticBefore = evaluatedElastic_;
  computeForces(0.0);
  energyCurrent_ = false;
  if (steps_ == 0) {
    refreshEnergy();
    energy_.initial = energy_.total();
  } else {
    energy_.splitRelease += (elasticBefore - evaluatedElastic_);
  }
}

template <int D>
void World<D>::keepForces() {
  if (!forcesValid_) throw std::logic_error("World::keepForces: the forces are not those of the particles now");
  keepForces_ = true;
  keptOpening_ = EnergyLedger{};
  if (def_.energyLedger) bookHalfKick(0.5 * dt_, 0.25 * dt_, keptOpening_);
}

template <int D>
EnergyLedger World<D>::bookedEnergy() const {
  EnergyLedger e = energy_;
  e.kineticTranslational = 0.0;
  e.kineticRotational = 0.0;
  e.elastic = 0.0;
  return e;
}

template <int D>
void World<D>::setBookedEnergy(const EnergyLedger& booked) {
  energy_ = booked;
  energyCurrent_ = false;
}

template <int D>
double World<D>::runFragmentSprings(ParticleId parent) const {
  const auto it = std::lower_bound(runFragmentSprings_.begin(), runFragmentSprings_.end(),
                                   std::pair<ParticleId, double>{parent, -std::numeric_limits<double>::infinity()});
  return it != runFragmentSprings_.end() && it->first == parent ? it->second
                                                                 : std::numeric_limits<double>::quiet_NaN();
}

template <int D>
void World<D>::setRunFragmentSprings(std::vector<std::pair<ParticleId, double>> springs) {
  std::sort(springs.begin(), springs.end());
  runFragmentSprings_ = std::move(springs);
}

template <int D>
void World<D>::resetLedger() {
  setBookedEnergy({});
  evaluatedElastic_ = 0.0;
  keptOpening_ = EnergyLedger{};
}

template <int D>
void World<D>::showRunOf(const World& run, std::span<const ShownParticle> shown,
                         std::span<const std::array<ParticleId, 2>> touching,
                         std::span<const std::array<ParticleId, 2>> touchingTools) {
  if (run.tools_.size() != tools_.size() || run.planes_.size() != planes_.size() ||
      run.effects_.size() != effects_.size()) {
    throw std::invalid_argument("World::showRunOf: the run has other tools, planes or effects than this world");
  }
  if (shown.size() != particles_.size()) {
    throw std::invalid_argument("World::showRunOf: " + std::to_string(shown.size()) + " particles shown, " +
                                std::to_string(particles_.size()) + " held");
  }
  if (!std::is_sorted(touching.begin(), touching.end()) ||
      !std::is_sorted(touchingTools.begin(), touchingTools.end())) {
    throw std::invalid_argument("World::showRunOf: the touching pairs are not in ascending order");
  }
  // The run's critical step and what sets it (every part of a distributed
  // run keeps the run's: finishCoordination), and its step.
  dtCritical_ = run.dtCritical_;
  limit_ = run.limit_;
  time_ = run.time_;
  steps_ = run.steps_;
  dt_ = run.dt_;
  dtChanges_ = run.dtChanges_;
  toolPoses_ = run.toolPoses_;
  // A servo platen's state (its travel and speed) is the run's.
  for (std::size_t k = 0; k < tools_.size(); ++k) {
    if (std::holds_alternative<ServoPlaten<D>>(run.tools_[k].motion)) tools_[k].motion = run.tools_[k].motion;
  }
  planes_ = run.planes_;
  forcesValid_ = false;
  energyCurrent_ = false;
  std::vector<Vec<D>> velocity(shown.size());
  std::vector<Spin<D>> spin(shown.size());
  for (std::size_t i = 0; i < shown.size(); ++i) {
    velocity[i] = shown[i].forceVelocity;
    spin[i] = shown[i].forceSpin;
  }
  particles_.velocity.swap(velocity);
  particles_.angularVelocity.swap(spin);
  // Only the pairs the run found touching, for this evaluation.
  struct Limit {
    World& w;
    Limit(World& world, std::span<const std::array<ParticleId, 2>> pairs,
          std::span<const std::array<ParticleId, 2>> tools)
        : w(world) {
      w.onlyPairs_ = pairs;
      w.contacts_.limitToolPairs(tools);
    }
    ~Limit() {
      w.onlyPairs_.reset();
      w.contacts_.limitToolPairs(std::nullopt);
    }
  } limit(*this, touching, touchingTools);
  refreshContacts();
  particles_.velocity.swap(velocity);
  particles_.angularVelocity.swap(spin);
  std::vector<std::uint64_t> ids;
  std::vector<const typename ContactSolver<D>::ParticleHistory*> histories;
  for (std::size_t i = 0; i < shown.size(); ++i) {
    particles_.force[i] = shown[i].force;
    particles_.torque[i] = shown[i].torque;
    if (shown[i].history) {
      ids.push_back(particles_.id[i]);
      histories.push_back(shown[i].history);
    }
  }
  if (!contacts_.overwriteHistories(ids, histories)) {
    throw std::logic_error("World::showRunOf: the run's contact histories do not fit the contacts found here");
  }
  energyCurrent_ = false;
  stageSeconds_ = run.stageSeconds_;
  effectSeconds_ = run.effectSeconds_;
}

template <int D>
void World<D>::step() {
  beginStep();
  finishStep();
}

template <int D>
void World<D>::beginStep() {
  if (!(dt_ > 0.0)) {
    throw std::logic_error("no time step: give dt, or add particles so the automatic step can be estimated");
  }
  // Forces of the current state, once, before the first step or after changes.
  const bool keptForces = keepForces_;
  if (!keptForces) refreshContacts();
  keepForces_ = false;

  // The opening half kick books the work of the forces it applies (kept
  // forces: as keepForces worked it out).
  auto t0 = Clock::now();
  if (keptForces) {
    energy_.add(keptOpening_);
  } else if (def_.energyLedger) {
    bookHalfKick(0.5 * dt_, 0.25 * dt_, energy_);
  }
  stageSeconds_[std::size_t(Stage::Energy)] += secondsSince(t0);

  // Half kick and drift.
  t0 = Clock::now();
  kickDrift(particles_, dt_);
  stageSeconds_[std::size_t(Stage::Integrate)] += secondsSince(t0);

  // Tools and planes to the end of the step.
  t0 = Clock::now();
  moveKinematicBodies(time_ + dt_);
  stageSeconds_[std::size_t(Stage::Kinematics)] += secondsSince(t0);
}

template <int D>
void World<D>::finishStep() {
  // Forces at the new positions, then the closing half kick.
  computeForces(dt_);
  auto t0 = Clock::now();
  kick(particles_, dt_);
  time_ += dt_;
  ++steps_;
  stageSeconds_[std::size_t(Stage::Integrate)] += secondsSince(t0);

  // Between steps: removal, breakage, recorders. An effect that reads the
  // contacts gets them for the particles as they are (Effect::readsContacts).
  t0 = Clock::now();
  const std::size_t recordsBefore = removed_.size();
  for (std::size_t e = 0; e < effects_.size(); ++e) {
    const auto te = Clock::now();
    if (effects_[e]->readsContacts()) refreshContacts();
    if (coordinator_) {
      afterStepCoordinated(*effects_[e]);
    } else {
      effects_[e]->afterStep(*this);
    }
    effectSeconds_[e] += secondsSince(te);
  }
  // The step's removal records (every effect's) in ascending id: removed()
  // is in (time, id) order, whatever the effects' order, as a distributed
  // run gathers them.
  if (removed_.size() > recordsBefore + 1) {
    std::sort(removed_.begin() + std::ptrdiff_t(recordsBefore), removed_.end(),
              [](const RemovedParticle& a, const RemovedParticle& b) { return a.id < b.id; });
  }
  stageSeconds_[std::size_t(Stage::AfterStep)] += secondsSince(t0);

  // The kinetic and elastic energy of the new state are worked out when the
  // ledger is read (energy()), not every step.
  energyCurrent_ = false;
  if (def_.checkFinite) checkFinite();
}

template <int D>
void World<D>::afterStepCoordinated(Effect<D>& effect) {
  // Every world makes the same collective calls after the same effects, in
  // the scene's order (ParticleSetCoordinator.h).
  const bool replaces = effect.replacesParticles();
  const bool changes = effect.changesParticles();
  effectChanged_ = false;
  effectAdded_.clear();
  coordinatedThisStep_ = false;
  replaceAllowed_ = replaces;
  effect.afterStep(*this);
  replaceAllowed_ = false;
  // A world that replaced nothing takes part with an empty batch.
  if (replaces && !coordinatedThisStep_) {
    born_.clear();
    if (coordinator_->allocateIds({}, splitIds_) > 0) finishCoordination(dtChanges_.size(), dt_);
  }
  coordinatedThisStep_ = false;
  if (changes && coordinator_->effectChangedParticles(effectChanged_, effectAdded_)) {
    broad_.invalidate();
    forcesValid_ = false;
    energyCurrent_ = false;
  }
  // The energy a new particle brings, booked once: by the world that keeps
  // it as its own.
  if (!effectAdded_.empty() && steps_ > 0) {
    for (std::size_t i = 0; i < particles_.size(); ++i) {
      if (!isGhost(i) && std::find(effectAdded_.begin(), effectAdded_.end(), particles_.id[i]) != effectAdded_.end()) {
        energy_.addedEnergy += particles_.kineticEnergy(i);
      }
    }
  }
  effectAdded_.clear();
}

template <int D>
void World<D>::run(std::uint64_t n) {
  for (std::uint64_t s = 0; s < n; ++s) step();
}

// ------------------------------------------------------------- checkpoints --

template <int D>
void World<D>::saveState(
    StateWriter& out, const std::function<std::uint32_t(const std::shared_ptr<const geometry::Shape<D>>&)>& shapeIndex) const {
  // 3: with the time-step limits and density scaling; 4: whether the
  // contacts are current; 5: the tools' poses.
  out.putTag("world 5");
  out.put(std::int32_t(D));
  out.put(std::uint64_t(planes_.size()));
  out.put(std::uint64_t(tools_.size()));
  out.put(std::uint64_t(effects_.size()));
  out.put(time_);
  out.put(steps_);
  out.put(dt_);
  out.put(dtCritical_);
  out.put(limit_);
  out.putVector(dtChanges_);
  out.put(std::uint64_t(densityScales_.size()));
  for (const auto& [id, factor] : densityScales_) {
    out.put(id);
    out.put(factor);
  }
  out.put(scalingStats_);
  out.put(energy_);
  out.put(lastPower_);
  // A state saved after an effect changed the particles (outflow, a feed) has
  // stale contact records: the resumed run must re-evaluate them, as the
  // uninterrupted one does.
  out.put(std::uint8_t(forcesValid_ ? 1 : 0));
  out.putWallClock(stageSeconds_);
  out.putWallClockVector(effectSeconds_);
  out.put(std::uint64_t(removed_.size()));
  for (const RemovedParticle& r : removed_) {
    out.put(r.id);
    out.put(r.time);
    out.put(r.mass);
    out.put(r.volume);
    out.put(r.sieveSize);
    out.putString(r.reason);
  }
  particles_.saveState(out, shapeIndex);
  contacts_.saveState(out);
  out.putVector(loads_.planeForce);
  out.putVector(loads_.planeTorque);
  out.putVector(loads_.toolForce);
  out.putVector(loads_.toolTorque);
  // Servo platens carry state; every other motion is a function of time.
  for (const ToolDef<D>& tool : tools_) {
    if (const auto* servo = std::get_if<ServoPlaten<D>>(&tool.motion)) {
      out.put(servo->displacement());
      out.put(servo->speed());
      out.put(servo->def().targetForce);
    }
  }
  for (const ToolPose<D>& pose : toolPoses_) {
    out.put(pose.position);
    out.put(pose.orientation);
  }
  for (const auto& e : effects_) {
    out.putString(e->name());
    e->saveState(out);
  }
  out.putTag("end of world");
}

template <int D>
void World<D>::loadState(StateReader& in,
                         const std::function<std::shared_ptr<const geometry::Shape<D>>(std::uint32_t)>& shapeAt) {
  const bool withPoses = in.expectTag({"world 5", "world 4"}) == 0;
  const auto mismatch = [](const std::string& what, std::uint64_t saved, std::uint64_t here) {
    throw std::runtime_error("checkpoint does not fit this scene: " + what + " " + std::to_string(saved) +
                             " in the checkpoint, " + std::to_string(here) + " in the scene");
  };
  const std::int32_t dim = in.get<std::int32_t>();
  if (dim != D) mismatch("dimension", std::uint64_t(dim), D);
  const std::uint64_t planes = in.get<std::uint64_t>(), tools = in.get<std::uint64_t>(), effects = in.get<std::uint64_t>();
  if (planes != planes_.size()) mismatch("planes", planes, planes_.size());
  if (tools != tools_.size()) mismatch("tools", tools, tools_.size());
  if (effects != effects_.size()) mismatch("effects", effects, effects_.size());
  time_ = in.get<double>();
  steps_ = in.get<std::uint64_t>();
  dt_ = in.get<double>();
  dtCritical_ = in.get<double>();
  limit_ = in.get<TimeStepLimit>();
  in.getVector(dtChanges_);
  densityScales_.clear();
  for (std::uint64_t k = 0, n = in.get<std::uint64_t>(); k < n; ++k) {
    const std::uint64_t id = in.get<std::uint64_t>();
    densityScales_[id] = in.get<double>();
  }
  scalingStats_ = in.get<DensityScalingStats>();
  energy_ = in.get<EnergyLedger>();
  lastPower_ = in.get<std::array<double, 2>>();
  const bool contactsCurrent = in.get<std::uint8_t>() != 0;
  stageSeconds_ = in.get<std::array<double, std::size_t(Stage::Count)>>();
  in.getVector(effectSeconds_);
  effectSeconds_.resize(effects_.size(), 0.0);
  removed_.resize(std::size_t(in.get<std::uint64_t>()));
  for (RemovedParticle& r : removed_) {
    r.id = in.get<std::uint64_t>();
    r.time = in.get<double>();
    r.mass = in.get<double>();
    r.volume = in.get<double>();
    r.sieveSize = in.get<double>();
    r.reason = in.getString();
  }
  particles_.loadState(in, shapeAt);
  ghost_.clear();  // a checkpoint holds one world's own particles
  contacts_.loadState(in);
  evaluatedElastic_ = contacts_.elasticEnergy();
  in.getVector(loads_.planeForce);
  in.getVector(loads_.planeTorque);
  in.getVector(loads_.toolForce);
  in.getVector(loads_.toolTorque);
  for (ToolDef<D>& tool : tools_) {
    if (auto* servo = std::get_if<ServoPlaten<D>>(&tool.motion)) {
      const double displacement = in.get<double>(), speed = in.get<double>(), target = in.get<double>();
      servo->setTargetForce(target);
      servo->restore(displacement, speed);
    }
  }
  savedToolPoses_.clear();
  if (withPoses) {
    savedToolPoses_.resize(tools_.size());
    for (std::size_t k = 0; k < tools_.size(); ++k) {
      savedToolPoses_[k].shape = tools_[k].shape.get();
      savedToolPoses_[k].position = in.get<Vec<D>>();
      savedToolPoses_[k].orientation = in.get<Orientation<D>>();
    }
  }
  for (auto& e : effects_) {
    const std::string name = in.getString();
    if (name != e->name()) {
      throw std::runtime_error("checkpoint does not fit this scene: effect '" + name + "' in the checkpoint, '" +
                               e->name() + "' in the scene");
    }
    e->loadState(in);
  }
  in.expectTag("end of world");
  energyCurrent_ = false;

  // Derived state: per-particle stiffness, poses at the current time, a fresh
  // broad phase (its output is sorted by id, so a rebuild finds the same
  // contacts), and the forces of this state, which were saved (stale when
  // an effect had changed the particles after them: the next step
  // re-evaluates them, as the saved world's would have).
  stiffness_.resize(particles_.size());
  for (std::size_t i = 0; i < particles_.size(); ++i) stiffness_[i] = shapeStiffness(particles_.shape[i]);
  moveKinematicBodies(time_);
  broad_.invalidate();
  forcesValid_ = contactsCurrent;
}

template <int D>
void World<D>::refreshEnergy() const {
  double kt = 0.0, kr = 0.0;
  for (std::size_t i = 0; i < particles_.size(); ++i) {
    if (isGhost(i)) continue;
    kt += particles_.translationalEnergy(i);
    kr += particles_.rotationalEnergy(i);
  }
  energy_.kineticTranslational = kt;
  energy_.kineticRotational = kr;
  energy_.elastic = evaluatedElastic_;
  energyCurrent_ = true;
}

template <int D>
void World<D>::checkFinite() const {
  const Particles<D>& p = particles_;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (!finite(p.position[i]) || !finite(p.orientation[i]) || !finite(p.velocity[i]) ||
        !finite(p.angularVelocity[i]) || !finite(p.force[i]) || !finite(p.torque[i])) {
      throw std::runtime_error("non-finite state of particle id " + std::to_string(p.id[i]) + " at step " +
                               std::to_string(steps_) + " (t = " + std::to_string(time_) + " s)");
    }
  }
}

template <int D>
double World<D>::particleMass() const {
  double m = 0.0;
  for (std::size_t i = 0; i < particles_.size(); ++i) m += unscaledMass(i);
  return m;
}

template <int D>
double World<D>::removedMass() const {
  double m = 0.0;
  for (const RemovedParticle& r : removed_) m += r.mass;
  return m;
}

template class World<2>;
template class World<3>;

}  // namespace lsdem::dynamics
