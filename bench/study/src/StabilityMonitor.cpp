#include "lsdem/study/Stability.h"

#include "lsdem/breakage/Breakage.h"
#include "lsdem/dynamics/TimeStep.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ostream>
#include <sstream>

namespace lsdem::study {

using dynamics::World;
using geometry::Vec;

namespace {

// Sum of every hot state value of the particles: a NaN or an Inf anywhere
// makes the sum non-finite (Inf - Inf is NaN), so one test covers them all.
template <int D>
double stateSum(const dynamics::Particles<D>& p) {
  double s = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    s += p.position[i].sum() + p.velocity[i].sum() + p.force[i].sum();
    if constexpr (D == 2) {
      s += p.orientation[i] + p.angularVelocity[i] + p.torque[i];
    } else {
      s += p.orientation[i].coeffs().sum() + p.angularVelocity[i].sum() + p.torque[i].sum();
    }
  }
  return s;
}

std::string format(const char* fmt, double a, double b) {
  char buffer[200];
  std::snprintf(buffer, sizeof buffer, fmt, a, b);
  return buffer;
}

}  // namespace

// ------------------------------------------------------------------ monitor --

template <int D>
StabilityMonitor<D>::StabilityMonitor(const World<D>& world, const breakage::Breakage<D>* breakage,
                                      std::optional<geometry::Box<D>> container)
    : world_(world), breakage_(breakage), container_(std::move(container)) {
  initialMass_ = world.particleMass() + world.removedMass();
  out_.dimension = D;
  checkTimeStep();
}

template <int D>
bool StabilityMonitor<D>::checkTimeStep() {
  // Re-estimate the critical step only when the particles changed: a new
  // fragment (ids handed out), a removal or an addition.
  const dynamics::Particles<D>& p = world_.particles();
  const std::uint64_t firstId = p.empty() ? 0 : p.id.front();
  if (p.size() != particleCount_ || p.nextId() != lastNextId_ || firstId != lastFirstId_) {
    particleCount_ = p.size();
    lastNextId_ = p.nextId();
    lastFirstId_ = firstId;
    const dynamics::ContactLawDef& law = world_.def().contact;
    if (p.empty() || law.normal != dynamics::NormalModel::Linear ||
        law.formulation != dynamics::ForceFormulation::PerNode) {
      criticalDt_ = std::numeric_limits<double>::infinity();
    } else {
      // The per-node law: the same estimate the world makes, computed here
      // afresh from the particles present (stiffest patch of every shape,
      // cached per live shape).
      dynamics::NodeStiffness ns;
      ns.perNode = law.kn;
      ns.perWeight = 0.0;
      ns.tangentialRatio = law.hasFriction ? law.ks / law.kn : 0.0;
      std::erase_if(stiffness_, [](const CachedStiffness& c) { return c.alive.expired(); });
      masses_.assign(p.mass.begin(), p.mass.end());
      stiffnesses_.resize(p.size());
      for (std::size_t i = 0; i < p.size(); ++i) {
        const auto it = std::find_if(stiffness_.begin(), stiffness_.end(), [&](const CachedStiffness& c) {
          return c.shape == p.shape[i].get() && !c.alive.expired();
        });
        if (it != stiffness_.end()) {
          stiffnesses_[i] = it->stiffness;
        } else {
          stiffnesses_[i] = dynamics::stiffestContact(*p.shape[i], ns).stiffness;
          stiffness_.push_back({p.shape[i].get(), p.shape[i], stiffnesses_[i]});
        }
      }
      criticalDt_ = dynamics::criticalTimeStep(masses_, stiffnesses_, law.hasDamping ? law.dampingRatio : 0.0);
    }
    return true;
  }
  return false;
}

template <int D>
void StabilityMonitor<D>::observe() {
  const dynamics::Particles<D>& p = world_.particles();
  ++out_.steps;

  // NaN / Inf anywhere in the state.
  if (!std::isfinite(stateSum(p))) ++out_.nonFinite;

  // Time step against the critical step of the particles present now.
  const bool changed = checkTimeStep();
  const double dt = world_.dt();
  out_.minDt = std::min(out_.minDt, dt);
  out_.maxDt = std::max(out_.maxDt, dt);
  if (dt > world_.def().dtSafety * criticalDt_ * (1.0 + 1e-9)) ++out_.unsafeDtSteps;

  // Energy: now + losses - sources, against the energy scale.
  const dynamics::EnergyLedger& e = world_.energy();
  const double scale = std::max({e.initial + std::max(0.0, e.gravityWork) + std::max(0.0, e.boundaryWork) +
                                     std::max(0.0, e.addedEnergy),
                                 e.total(), std::numeric_limits<double>::min()});
  const double excess = e.balanceError() / scale;
  if (std::isfinite(excess)) {
    out_.maxEnergyExcess = std::max(out_.maxEnergyExcess, excess);
  } else {
    ++out_.nonFinite;
  }

  // Mass over the whole run: particles + removed = initial.
  const double mass = world_.particleMass() + world_.removedMass();
  out_.maxMassError = std::max(out_.maxMassError, std::abs(mass - initialMass_) / initialMass_);

  // Deepest overlap against the smaller body's size. The contact records index
  // the particles as they were when the step computed them: after a split or
  // removal in afterStep they are stale, and the next step's are checked.
  const auto& pairs = world_.contacts().pairContacts();
  const auto& nodes = world_.contacts().nodeContacts();
  const std::size_t particlePairs = world_.contacts().particleContacts().size();
  for (std::size_t k = 0; k < (changed ? 0 : pairs.size()); ++k) {
    const auto& pc = pairs[k];
    if (pc.nodeCount == 0) continue;
    double size = p.shape[pc.a]->descriptors().equivalentDiameter;
    if (k < particlePairs) size = std::min(size, p.shape[pc.b]->descriptors().equivalentDiameter);
    double deepest = 0.0;
    for (std::uint32_t n = pc.firstNode; n < pc.firstNode + pc.nodeCount; ++n) {
      deepest = std::max(deepest, nodes[n].overlap);
    }
    out_.maxOverlapFraction = std::max(out_.maxOverlapFraction, deepest / size);
  }

  // Escapes from the closed container.
  if (container_) {
    std::size_t outside = 0;
    for (std::size_t i = 0; i < p.size(); ++i) outside += !container_->contains(p.position[i]);
    out_.escaped = std::max(out_.escaped, outside);
  }

  // Each new split: fragments + fines carry the parent's mass, and their
  // kinetic energy stays within the parent's plus the inertia error.
  if (breakage_ != nullptr) {
    const auto& events = breakage_->events();
    for (; eventsSeen_ < events.size(); ++eventsSeen_) {
      const breakage::BreakageEvent<D>& ev = events[eventsSeen_];
      out_.maxSplitMassError =
          std::max(out_.maxSplitMassError, std::abs(ev.fragmentMass - ev.parentMass) / ev.parentMass);
      const double allowed = ev.parentKineticEnergy + ev.inertiaEnergyBound;
      const double gain = (ev.fragmentKineticEnergy - allowed) / std::max(ev.parentKineticEnergy, 1e-300);
      if (ev.fragmentKineticEnergy > allowed) out_.maxSplitEnergyGain = std::max(out_.maxSplitEnergyGain, gain);
      if (!std::isfinite(ev.fragmentKineticEnergy) || !std::isfinite(ev.fragmentMass)) ++out_.nonFinite;
    }
    out_.breakages = events.size();
  }
  out_.particles = p.size();
}

template <int D>
void StabilityMonitor<D>::finish(StabilityResult& result) const {
  const std::string name = result.name;
  const std::string note = result.note;
  const std::size_t minBreakages = result.minBreakages;
  const double overlapLimit = result.overlapLimit;
  const double seconds = result.seconds;
  std::vector<std::string> violations = result.violations;
  result = out_;
  result.violations = std::move(violations);
  result.name = name;
  result.note = note;
  result.minBreakages = minBreakages;
  result.overlapLimit = overlapLimit;
  result.seconds = seconds;
}

// --------------------------------------------------------------- invariants --

void checkInvariants(StabilityResult& r, const StabilityLimits& limits) {
  r.failures = r.violations;
  if (r.nonFinite > 0) r.failures.push_back("non-finite state in " + std::to_string(r.nonFinite) + " steps");
  if (!(r.maxEnergyExcess <= limits.energyExcess)) {
    r.failures.push_back(format("energy grew without a source by %.3g of its scale (limit %.3g)", r.maxEnergyExcess,
                                limits.energyExcess));
  }
  if (!(r.maxSplitEnergyGain <= limits.splitEnergyGain)) {
    r.failures.push_back(format("a split raised the kinetic energy by %.3g of the parent's (limit %.3g)",
                                r.maxSplitEnergyGain, limits.splitEnergyGain));
  }
  if (!(r.maxSplitMassError <= limits.splitMassError)) {
    r.failures.push_back(
        format("split mass error %.3g (limit %.3g)", r.maxSplitMassError, limits.splitMassError));
  }
  if (!(r.maxMassError <= limits.massError)) {
    r.failures.push_back(format("run mass balance error %.3g (limit %.3g)", r.maxMassError, limits.massError));
  }
  const double overlapLimit = r.overlapLimit > 0.0 ? r.overlapLimit : limits.overlapFraction;
  if (!(r.maxOverlapFraction <= overlapLimit)) {
    r.failures.push_back(format("overlap %.3g of the smaller body's diameter (limit %.3g)", r.maxOverlapFraction,
                                overlapLimit));
  }
  if (r.escaped > 0) r.failures.push_back(std::to_string(r.escaped) + " particles escaped the container");
  if (r.unsafeDtSteps > 0) {
    r.failures.push_back(std::to_string(r.unsafeDtSteps) + " steps with dt above the safe fraction of the critical step");
  }
  if (r.breakages < r.minBreakages) {
    r.failures.push_back(std::to_string(r.breakages) + " breakages, fewer than the " + std::to_string(r.minBreakages) +
                         " the case needs");
  }
}

// ---------------------------------------------------------------- reporting --

std::string stabilityTableHeader() {
  char buffer[256];
  std::snprintf(buffer, sizeof buffer, "%-16s %3s %9s %9s %10s %9s %9s %10s %9s  %s", "case", "dim", "steps",
                "breakages", "energy_%", "mass_err", "overlap", "min_dt", "wall_s", "result");
  return buffer;
}

std::string stabilityTableRow(const StabilityResult& r) {
  char buffer[256];
  std::snprintf(buffer, sizeof buffer, "%-16s %3d %9llu %9zu %10.4f %9.2e %9.2e %10.3e %9.2f  %s", r.name.c_str(),
                r.dimension, static_cast<unsigned long long>(r.steps), r.breakages, 100.0 * r.maxEnergyExcess,
                std::max(r.maxMassError, r.maxSplitMassError), r.maxOverlapFraction,
                std::isfinite(r.minDt) ? r.minDt : 0.0, r.seconds, r.passed() ? "PASS" : "FAIL");
  return buffer;
}

void writeStabilityCsv(const std::vector<StabilityResult>& results, std::ostream& out) {
  out << "case,dim,steps,breakages,particles,energy_excess,split_energy_gain,split_mass_error,mass_error,"
         "max_overlap,escaped,non_finite,unsafe_dt_steps,min_dt,max_dt,wall_seconds,passed,failures\n";
  std::ostringstream row;
  row.precision(9);
  for (const StabilityResult& r : results) {
    std::string failures;
    for (const std::string& f : r.failures) failures += (failures.empty() ? "" : "; ") + f;
    row.str("");
    row << r.name << ',' << r.dimension << ',' << r.steps << ',' << r.breakages << ',' << r.particles << ','
        << r.maxEnergyExcess << ',' << r.maxSplitEnergyGain << ',' << r.maxSplitMassError << ',' << r.maxMassError
        << ',' << r.maxOverlapFraction << ',' << r.escaped << ',' << r.nonFinite << ',' << r.unsafeDtSteps << ','
        << (std::isfinite(r.minDt) ? r.minDt : 0.0) << ',' << r.maxDt << ',' << r.seconds << ','
        << (r.passed() ? 1 : 0) << ",\"" << failures << "\"\n";
    out << row.str();
  }
}

template class StabilityMonitor<2>;
template class StabilityMonitor<3>;

}  // namespace lsdem::study
