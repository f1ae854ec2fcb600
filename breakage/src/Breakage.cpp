#include "lsdem/breakage/Breakage.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

namespace lsdem::breakage {

using dynamics::Orientation;
using dynamics::ParticleDef;
using dynamics::Particles;
using dynamics::Rotation;
using dynamics::Spin;
using dynamics::World;
using geometry::HalfSpace;
using geometry::Mat;
using geometry::Shape;

namespace {

// Orientation of a body -> world rotation matrix.
template <int D>
Orientation<D> orientationOf(const Mat<D>& r) {
  if constexpr (D == 2) {
    return std::atan2(r(1, 0), r(0, 0));
  } else {
    Eigen::Quaterniond q(r);
    q.normalize();
    return q;
  }
}

// Kinetic energy of a particle about to be added from `def`, J (as Particles::kineticEnergy).
template <int D>
double kineticEnergyOf(const ParticleDef<D>& def) {
  const double rho = def.density * def.massScale;
  const auto& mp = def.shape->mass();
  const double translational = 0.5 * rho * mp.volume * def.velocity.squaredNorm();
  if constexpr (D == 2) {
    return translational + 0.5 * rho * mp.polarMoment() * def.angularVelocity * def.angularVelocity;
  } else {
    const Vec<3> wBody = def.orientation.conjugate() * def.angularVelocity;
    return translational + 0.5 * rho * (mp.principalInertia().array() * wBody.array().square()).sum();
  }
}

}  // namespace

const char* breakageModeName(BreakageMode mode) {
  switch (mode) {
    case BreakageMode::Split: return "split";
    case BreakageMode::Buckling: return "buckling";
    case BreakageMode::Manual: return "manual";
    case BreakageMode::Chip: return "chip";
  }
  return "split";
}

template <int D>
Breakage<D>::Breakage(const BreakageDef<D>& def) : def_(def), criterion_(makeCriterion(def.criterion)) {
  validateWeibull(def.weibull);
  if (!(def.minVolume >= 0.0) || !std::isfinite(def.minVolume)) {
    throw std::invalid_argument("breakage minVolume must be finite and >= 0, got " + std::to_string(def.minVolume));
  }
  if (!(def.minBreakableVolume >= 0.0) || !std::isfinite(def.minBreakableVolume)) {
    throw std::invalid_argument("breakage minBreakableVolume must be finite and >= 0, got " +
                                std::to_string(def.minBreakableVolume));
  }
  validateSplitOptions(def.split);
  // Fragments that leave as fines at once need no finer grid.
  if (!def.haltBelowMinimum) def_.split.regridMinVolume = std::max(def_.split.regridMinVolume, def.minVolume);
  if (def.minNodes < 0) {
    throw std::invalid_argument("breakage minNodes must be >= 0, got " + std::to_string(def.minNodes));
  }
  if (!(def.bucklingRatio > 1.0) || !std::isfinite(def.bucklingRatio)) {
    throw std::invalid_argument("breakage bucklingRatio must be finite and > 1, got " +
                                std::to_string(def.bucklingRatio));
  }
  for (const ManualBreak<D>& m : def.manual) {
    if (m.surface) continue;
    if (!(m.plane.normal.norm() > 0.0) || !m.plane.normal.allFinite() || !std::isfinite(m.plane.offset)) {
      throw std::invalid_argument("manual break of particle " + std::to_string(m.particle) +
                                  " needs a finite plane with a nonzero normal");
    }
  }
  if (def.chipping) validateChipping(*def.chipping);
  manualDone_.assign(def.manual.size(), false);
}

template <int D>
bool Breakage<D>::isBelowMinimum(const Shape<D>& shape) const {
  return shape.volume() < def_.minVolume || shape.nodes().size() < std::size_t(def_.minNodes);
}

template <int D>
void Breakage<D>::afterStep(World<D>& world) {
  const Particles<D>& p = world.particles();

  // (i) Weibull strengths (eq. 12) for particles that have none, keyed by
  // global id. In a distributed run each rank breaks its own particles only
  // (a mirror is its owner's: World::isGhost).
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p.strength[i] <= 0.0 && !world.isGhost(i)) {
      world.setStrength(i, sampleStrength(def_.weibull, def_.seed, p.id[i], p.shape[i]->descriptors().equivalentDiameter));
    }
  }

  // (ii) Failures of this step and manual breaks that are due.
  queue_.clear();
  queueFailures(world);
  if (def_.chipping) queueChips(world);

  // (iii)-(iv) Splits between steps, then one re-check of the time step.
  if (!queue_.empty()) applyQueue(world);
}

template <int D>
void Breakage<D>::queueFailures(World<D>& world) {
  const Particles<D>& p = world.particles();
  const double now = world.time();

  // eq. 5-6 per grain and the criterion (eq. 7-10) at its own strength, on
  // contact records of the particles as they are (readsContacts).
  bool havePoints = false;
  grainStresses(p, world.contacts(), stress_);
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (stress_[i].isZero(0.0) || !std::isfinite(p.strength[i])) continue;  // infinite: unsplittable
    if (world.isGhost(i)) continue;  // its owner's
    const Vec<3> principal = principalStressTriple<D>(stress_[i]);
    if (!criterion_->fails(principal, p.strength[i])) continue;
    const Shape<D>& shape = *p.shape[i];
    if (def_.haltBelowMinimum && isBelowMinimum(shape)) continue;
    if (shape.volume() < def_.minBreakableVolume) continue;
    // Fracture plane: buckling (eq. 21) for slender grains, else the strongest contacts (eq. 18-20).
    const bool buckling = def_.buckling && circumscribedVolumeRatio(shape) > def_.bucklingRatio;
    std::optional<HalfSpace<D>> plane;
    if (buckling) {
      plane = bucklingPlane(shape, p.position[i], p.rotation(i), def_.seed, p.id[i]);
    } else {
      if (!havePoints) {
        strongestContacts(p, world.contacts(), points_);
        havePoints = true;
      }
      plane = fracturePlane<D>(p.position[i], points_.of(i), shape.descriptors().equivalentDiameter);
    }
    if (!plane) continue;
    queue_.push_back({p.id[i], i, criterion_->characteristicStress(principal), *plane, false, buckling, nullptr, false, 0.0, 0.0});
  }

  // Manual breaks that are due (they replace a natural failure of the same particle).
  for (std::size_t m = 0; m < def_.manual.size(); ++m) {
    const ManualBreak<D>& mb = def_.manual[m];
    if (manualDone_[m] || now < mb.time) continue;
    manualDone_[m] = true;
    const auto it = std::find(p.id.begin(), p.id.end(), mb.particle);
    if (it == p.id.end()) {
      // In a distributed run it may be another rank's.
      if (!world.isDistributed()) {
        manualNotApplied_.push_back({now, mb.particle, "no particle with this id (broken or removed earlier)"});
      }
      continue;
    }
    const std::size_t i = std::size_t(it - p.id.begin());
    if (world.isGhost(i)) continue;  // its owner breaks it
    double value = 0.0;
    if (i < stress_.size() && !stress_[i].isZero(0.0)) {
      value = criterion_->characteristicStress(principalStressTriple<D>(stress_[i]));
    }
    HalfSpace<D> plane = mb.plane;
    if (mb.surface) {
      plane = HalfSpace<D>{Vec<D>::Zero(), 0.0};
    } else {
      const double n = plane.normal.norm();
      plane.normal /= n;
      plane.offset /= n;
    }
    std::erase_if(queue_, [&](const Pending& q) { return q.id == mb.particle; });
    queue_.push_back({mb.particle, i, value, plane, true, false, mb.surface ? &mb : nullptr, false, 0.0, 0.0});
  }
}

template <int D>
void Breakage<D>::queueChips(const World<D>& world) {
  const ChippingDef& chip = *def_.chipping;
  const Particles<D>& p = world.particles();
  contactLoads(p, world.contacts(), loads_);
  const std::size_t queued = queue_.size();  // splits and manual breaks of this step come first
  for (std::size_t i = 0; i < p.size(); ++i) {
    const std::span<const ContactLoad<D>> loads = loads_.of(i);
    if (loads.empty() || !std::isfinite(p.strength[i])) continue;  // no contact; unsplittable
    if (world.isGhost(i)) continue;  // its owner's
    const Shape<D>& shape = *p.shape[i];
    const double shallowest = chip.minDepthCells * shape.grid().spacing();
    // The contact whose pressure exceeds its chipping strength the most,
    // among those whose cap is a chip (Chipping.h: not a face's slab).
    double worst = 1.0;
    const ContactLoad<D>* at = nullptr;
    double depth = 0.0, strength = 0.0;
    HalfSpace<D> plane;
    for (const ContactLoad<D>& load : loads) {
      if (!(load.force > 0.0)) continue;
      const double d = chipDepth<D>(chip, load.force, load.localRadius);
      if (d < shallowest) continue;  // not resolved by the grain's grid
      const double s = chipStrength(chip, d, chipUniform(def_.seed, p.id[i], load.partner));
      const double ratio = load.pressure() / s;
      if (ratio < worst) continue;
      // The chip plane: normal to the contact, depth d below its tip.
      const HalfSpace<D> cut{load.normal, load.normal.dot(p.position[i]) + load.localRadius - d};
      if (capWidth<D>(shape, p.rotation(i), p.position[i], cut.normal, cut.offset) > chip.maxWidthToDepth * d) continue;
      worst = ratio;
      at = &load;
      depth = d;
      strength = s;
      plane = cut;
    }
    if (!at) continue;
    if (def_.haltBelowMinimum && isBelowMinimum(shape)) continue;
    if (shape.volume() < def_.minBreakableVolume) continue;
    // A particle that splits (or is broken by hand) this step does not chip.
    const auto split = std::find_if(queue_.begin(), queue_.begin() + std::ptrdiff_t(queued),
                                    [&](const Pending& q) { return q.index == i; });
    if (split != queue_.begin() + std::ptrdiff_t(queued)) continue;
    queue_.push_back({p.id[i], i, at->pressure(), plane, false, false, nullptr, true, depth, strength});
  }
}

template <int D>
geometry::SignedDistance<D> Breakage<D>::clearanceAround(const World<D>& world, std::size_t i) {
  const Particles<D>& p = world.particles();
  const Shape<D>& shape = *p.shape[i];
  const Vec<D> centre = p.position[i];
  const double reach = shape.boundingRadius() + 4.0 * shape.grid().spacing();
  // The particles in reach in global id order: the look-up below skips a
  // body by its bounding sphere, and a grid's level set can fall a little
  // below that bound, so the order must not depend on the store's (a
  // distributed run holds the same particles in another order).
  near_.clear();
  for (std::size_t j = 0; j < p.size(); ++j) {
    if (j == i) continue;
    if ((p.position[j] - centre).norm() > reach + p.shape[j]->boundingRadius()) continue;
    near_.push_back(j);
  }
  std::sort(near_.begin(), near_.end(), [&](std::size_t a, std::size_t b) { return p.id[a] < p.id[b]; });
  around_.clear();
  for (std::size_t j : near_) {
    around_.push_back({p.shape[j].get(), p.rotation(j), p.position[j], Vec<D>::Zero(), p.shape[j]->boundingRadius()});
  }
  for (const dynamics::Plane<D>& plane : world.planes()) {
    around_.push_back({nullptr, Mat<D>::Identity(), plane.point, plane.normal, 0.0});
  }
  for (const dynamics::ToolPose<D>& tool : world.toolPoses()) {
    const double radius = tool.shape->boundingRadius();
    if ((tool.position - centre).norm() > reach + radius) continue;
    around_.push_back({tool.shape, dynamics::Rotation<D>::matrix(tool.orientation), tool.position, Vec<D>::Zero(), radius});
  }
  // The nearest body's level set at the point; a body whose bounding sphere
  // is farther than the nearest value so far is not looked up.
  return [this, rotation = p.rotation(i), centre](const Vec<D>& xBody) {
    const Vec<D> x = centre + rotation * xBody;
    double nearest = std::numeric_limits<double>::infinity();
    for (const Neighbour& n : around_) {
      if (!n.shape) {
        nearest = std::min(nearest, n.normal.dot(x - n.position));
        continue;
      }
      const Vec<D> r = x - n.position;
      if (r.norm() - n.radius >= nearest) continue;
      nearest = std::min(nearest, n.shape->value(n.rotation.transpose() * r));
    }
    return nearest;
  };
}

template <int D>
std::vector<dynamics::ChildBirth::Rest> Breakage<D>::inheritedRestOverlaps(
    const std::vector<typename dynamics::ContactSolver<D>::RestOverlap>& rest, std::uint64_t parentId,
    const Shape<D>& parent, const Fragment<D>& f) {
  std::vector<dynamics::ChildBirth::Rest> out;
  // A parent node's rest overlaps go to the fragment's nodes within half a
  // parent cell of it (the node itself, where the fragment kept it; the nodes
  // made afresh around it, where it was re-gridded).
  const double reach2 = 0.25 * parent.grid().spacing() * parent.grid().spacing();
  for (const auto& r : rest) {
    if (r.owner != parentId) {
      // Another body's node inside the parent: inside one of the fragments now.
      out.push_back({r.owner, r.node, r.restOverlap, false});
      continue;
    }
    const Vec<D>& x = parent.nodes().positions[r.node];
    const auto& nodes = f.shape->nodes().positions;
    for (std::size_t n = 0; n < nodes.size(); ++n) {
      if ((f.childToParent.apply(nodes[n]) - x).squaredNorm() <= reach2) {
        out.push_back({r.partner, std::uint32_t(n), r.restOverlap, true});
      }
    }
  }
  return out;
}

template <int D>
void Breakage<D>::applyQueue(World<D>& world) {
  const Particles<D>& p = world.particles();
  const double now = world.time();
  const double m = def_.weibull.modulus;
  std::sort(queue_.begin(), queue_.end(), [](const Pending& a, const Pending& b) { return a.id < b.id; });
  splits_.clear();
  std::vector<std::size_t> addEvent;
  const std::size_t firstEvent = events_.size();
  // The springs each particle holds, for the energy check (stale records: unknown).
  springs_.clear();
  if (world.contactsCurrent()) springsPerParticle(world);

  // Fragments' nodes go on their surfaces as the scene's contact reads them.
  SplitOptions splitOptions = def_.split;
  splitOptions.nodeInterpolant = world.def().contact.interpolation == dynamics::LevelSetInterpolation::Tricubic
                                     ? geometry::GridInterpolant::CatmullRom
                                     : geometry::GridInterpolant::Multilinear;

  // Split every queued parent while the store's indices are unchanged.
  for (const Pending& q : queue_) {
    const std::size_t i = q.index;
    const Shape<D>& shape = *p.shape[i];
    const Mat<D> rotation = p.rotation(i);
    // World plane n.x = o to the parent's body frame: (R^T n).x_b = o - n.X.
    FractureSurface<D> surface;
    if (q.curved) {
      // phi_f(x_body) = phi_surface(surfaceToWorld^-1 (R x_body + X)): the grid lookup is pure.
      const geometry::Grid<D>* grid = &q.curved->surface->grid();
      const geometry::Rigid<D> bodyToSurface = q.curved->surfaceToWorld.inverse() * geometry::Rigid<D>{rotation, p.position[i]};
      surface.field = [grid, bodyToSurface](const Vec<D>& x) { return grid->value(bodyToSurface.apply(x)); };
    } else {
      surface.plane = HalfSpace<D>{rotation.transpose() * q.plane.normal, q.plane.offset - q.plane.normal.dot(p.position[i])};
    }
    // The split moves no surface near another body.
    const geometry::SignedDistance<D> clearance =
        def_.split.matchEnclosedVolume ? clearanceAround(world, i) : geometry::SignedDistance<D>{};
    SplitResult<D> split;
    try {
      split = splitShape(shape, surface, splitOptions, clearance);
    } catch (const std::exception& e) {
      // A manual break is logged and skipped; a failure the criterion found is a bug worth stopping for.
      if (!q.manual) throw;
      manualNotApplied_.push_back({now, q.id, std::string("the split failed: ") + e.what()});
      continue;
    }
    if (!split.isSplit && q.manual) {
      // (Not a failure of the criterion: not counted in unsplitFailures.)
      std::string reason = "the surface does not cut the particle at its grid resolution";
      if (!q.curved) {
        // A plane wholly beside the grain, or one cutting it within a cell of its surface.
        double lo = std::numeric_limits<double>::infinity(), hi = -lo;
        for (const Vec<D>& x : shape.nodes().positions) {
          const double d = surface.plane->distance(x);
          lo = std::min(lo, d);
          hi = std::max(hi, d);
        }
        char text[96];
        std::snprintf(text, sizeof(text), "%.3g m", lo >= 0.0 ? lo : -hi);
        reason = lo >= 0.0 || hi <= 0.0
                     ? std::string("the plane misses the particle (its nearest surface node is ") + text + " from it)"
                     : "the plane cuts the particle too close to its surface to split it at its grid resolution";
      }
      manualNotApplied_.push_back({now, q.id, reason});
      continue;
    }
    if (!split.isSplit && q.chip) {
      // Too shallow or grazing at this grid: the grain stays whole this step.
      ++unresolvedChips_;
      continue;
    }
    if (!split.isSplit && !q.curved && !q.manual) {
      // The plane through the contacts grazes the grain (one side holds no
      // interior grid node): the same orientation through the centroid.
      surface.plane->offset = 0.0;
      split = splitShape(shape, surface, splitOptions, clearance);
      if (!split.isSplit) {
        // No cut resolves at this grid: the grain stays whole from now on
        // rather than being retried every step.
        world.setStrength(i, std::numeric_limits<double>::infinity());
        ++unsplittable_;
      }
    }
    if (!split.isSplit) {
      ++unsplit_;
      continue;
    }

    // The event: parent state before the split.
    BreakageEvent<D> ev;
    ev.time = now;
    ev.parent = q.id;
    ev.criterionValue = q.criterionValue;
    ev.strength = q.chip ? q.chipStrength : p.strength[i];
    ev.manual = q.manual;
    ev.buckling = q.buckling;
    ev.chip = q.chip;
    ev.chipDepth = q.chipDepth;
    if (q.chip) ++chips_;
    ev.planeNormal = q.plane.normal;
    ev.planeOffset = q.plane.offset;
    ev.rawVolumeError = split.rawRelativeError;
    ev.inertiaRelativeError = split.inertiaRelativeError;
    ev.parentMass = world.unscaledMass(i);  // the true mass (World::densityScale)
    ev.parentMomentum = ev.parentMass * p.velocity[i];
    const double parentKinetic = p.kineticEnergy(i);           // as the dynamics has it
    ev.parentKineticEnergy = parentKinetic / world.densityScale(i);  // at the true mass
    if (!springs_.empty()) ev.parentSpringEnergy = springs_[i];
    // At the true mass, as the kinetic energies of the event (the store's
    // inertia is density-scaled for a scaled parent).
    if constexpr (D == 2) {
      ev.inertiaEnergyBound = 0.5 * split.inertiaRelativeError * p.inertia[i] * p.angularVelocity[i] *
                              p.angularVelocity[i] / world.densityScale(i);
    } else {
      ev.inertiaEnergyBound = 0.5 * split.inertiaRelativeError * p.inertia[i].norm() *
                              p.angularVelocity[i].squaredNorm() / world.densityScale(i);
    }
    rawVolumeError_ += std::abs(split.rawRelativeError) * split.parentVolume;

    // Fragments: the parent's density and motion, eq. 13 strengths; small ones leave as fines.
    const double density = ev.parentMass / shape.volume();
    const double parentDiameter = shape.descriptors().equivalentDiameter;
    // The parent's springs that started relaxed (ContactSolver, rest
    // overlaps) pass to its fragments, so breaking does not load them again.
    const auto rest = world.contacts().restOverlaps(p, i);
    dynamics::Replacement<D> product;
    for (const Fragment<D>& f : split.fragments) {
      const FragmentState<D> st = fragmentState(f, p.position[i], rotation, p.velocity[i], p.angularVelocity[i]);
      ParticleDef<D> def;
      def.shape = f.shape;
      def.density = density;
      def.massScale = f.massScale();
      def.position = st.position;
      def.orientation = orientationOf<D>(st.rotation);
      def.velocity = st.velocity;
      def.angularVelocity = st.angularVelocity;
      def.material = p.material[i];
      def.parent = q.id;
      def.generation = p.generation[i] + 1;
      def.birthTime = now;
      // eq. 13; a parent made unbreakable (infinite strength) passes none on:
      // step (i) samples the fragment's own.
      def.strength = std::isfinite(p.strength[i])
                         ? childStrength(p.strength[i], f.shape->descriptors().equivalentDiameter, parentDiameter, m)
                         : 0.0;
      const bool small = !def_.haltBelowMinimum &&
                         (f.volume < def_.minVolume || f.shape->nodes().size() < std::size_t(def_.minNodes));
      const double mass = density * def.massScale * f.shape->volume();
      const double kinetic = kineticEnergyOf(def);
      ev.fragmentMass += mass;
      ev.fragmentMomentum += mass * def.velocity;
      ev.fragmentKineticEnergy += kinetic;
      const bool fines = small;
      if (fines) {
        // Removed at once (World::replace gives it its id and books its energy).
        dynamics::RemovedParticle r;
        r.mass = mass;
        r.volume = f.volume;
        r.sieveSize = f.shape->descriptors().sieveSize;
        r.reason = "fines";
        product.fines.emplace_back(std::move(r), kinetic);
        finesMass_ += mass;
        ev.finesVolumes.push_back(f.volume);
      } else {
        product.children.push_back(std::move(def));
        // Its contacts start relaxed: new-face nodes, and the parent's rest overlaps.
        if (def_.relaxNewContacts) product.births.push_back({f.cutFaceNodes, inheritedRestOverlaps(rest, q.id, shape, f)});
        addEvent.push_back(events_.size());
        ev.childVolumes.push_back(f.volume);
      }
    }
    product.parent = i;
    splits_.push_back(std::move(product));
    events_.push_back(std::move(ev));
  }
  if (splits_.empty()) return;

  // Parents leave, their fines are recorded, fragments enter in the order of
  // their parents' ids with their births (World::replace keeps the ledger and
  // the time step, and gives the ids: it writes them into the defs).
  const std::vector<std::size_t> added = world.replace(splits_);
  eventOf_.assign(p.size(), -1);
  std::size_t k = 0;
  for (const dynamics::Replacement<D>& s : splits_) {
    for (const ParticleDef<D>& child : s.children) {
      events_[addEvent[k]].children.push_back(child.id);
      eventOf_[added[k]] = std::int64_t(addEvent[k]);
      ++k;
    }
  }
  checkEnergy(world, firstEvent);
}

// A particle pair's spring counts for both particles (once when both are one
// event's fragments); a plane's or tool's for its particle.
template <int D>
void Breakage<D>::springsPerParticle(const World<D>& world) {
  const auto& pairs = world.contacts().pairContacts();
  const std::size_t particlePairs = world.contacts().particleContacts().size();
  springs_.assign(world.particles().size(), 0.0);
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    springs_[pairs[k].a] += pairs[k].elasticEnergy;
    if (k < particlePairs) springs_[pairs[k].b] += pairs[k].elasticEnergy;
  }
}

template <int D>
void Breakage<D>::fragmentSprings(const World<D>& world, std::size_t firstEvent) {
  // A part of a distributed run: the run's, summed over its parts (a
  // fragment on another part holds springs this one does not compute).
  if (world.isDistributed()) {
    for (std::size_t e = firstEvent; e < events_.size(); ++e) {
      events_[e].fragmentSpringEnergy = world.runFragmentSprings(events_[e].parent);
    }
    return;
  }
  std::vector<double> springs(events_.size(), 0.0);
  world.contacts().addSpringsByGroup(eventOf_, {}, springs);
  for (std::size_t e = firstEvent; e < events_.size(); ++e) events_[e].fragmentSpringEnergy = springs[e];
}

template <int D>
void Breakage<D>::checkEnergy(World<D>& world, std::size_t firstEvent) {
  // The fragments' springs on the new set, evaluated now (the next step would).
  world.refreshContacts();
  fragmentSprings(world, firstEvent);
  for (std::size_t e = firstEvent; e < events_.size(); ++e) {
    const BreakageEvent<D>& ev = events_[e];
    if (std::isnan(ev.parentSpringEnergy)) {
      ++unchecked_;
      continue;
    }
    const double gain = ev.energyGain();
    const double scale = world.energyScale();
    if (!std::isfinite(gain) || !std::isfinite(scale)) {
      if (!std::isfinite(energyLimit_)) continue;  // reported by the ledger and the state checks
      std::ostringstream os;
      os << "breakage energy check: the split of particle " << ev.parent << " at t = " << ev.time
         << " s has a non-finite energy (gain " << gain << " J, energy scale " << scale << " J)";
      throw std::runtime_error(os.str());
    }
    if (!(gain > 0.0)) continue;
    const double relative = gain / scale;
    if (relative > largestGain_) {
      largestGain_ = relative;
      largestGainJoules_ = gain;
    }
    if (relative > energyLimit_) {
      std::ostringstream os;
      os << "breakage energy check: the split of particle " << ev.parent << " at t = " << ev.time
         << " s gave its fragments " << gain << " J more kinetic + spring energy than the parent had ("
         << ev.parentKineticEnergy + ev.parentSpringEnergy << " J): " << relative
         << " of the run's energy scale " << scale << " J, over the limit " << energyLimit_;
      throw std::runtime_error(os.str());
    }
  }
}

template <int D>
void Breakage<D>::saveState(dynamics::StateWriter& out) const {
  // 2: with the manual breaks not applied; 3: the energy check; 4: chips
  // (written only when chipping is declared: without it the bytes are those
  // of the release before chips).
  const bool withChips = def_.chipping.has_value();
  out.putTag(withChips ? "breakage 4" : "breakage 3");
  std::vector<std::uint8_t> done(manualDone_.begin(), manualDone_.end());
  out.putVector(done);
  out.put(std::uint64_t(manualNotApplied_.size()));
  for (const ManualBreakNotApplied& n : manualNotApplied_) {
    out.put(n.time);
    out.put(n.particle);
    out.putString(n.reason);
  }
  out.put(rawVolumeError_);
  out.put(finesMass_);
  out.put(std::uint64_t(unsplit_));
  out.put(std::uint64_t(unsplittable_));
  out.put(std::uint64_t(0));  // reserved (steps whose stresses were skipped, before contacts were kept current)
  out.put(std::uint64_t(0));  // reserved (removals seen, before contacts were kept current)
  out.put(std::uint64_t(events_.size()));
  for (const BreakageEvent<D>& e : events_) {
    out.put(e.time);
    out.put(e.parent);
    out.putVector(e.children);
    out.put(e.criterionValue);
    out.put(e.strength);
    out.put(e.manual);
    out.put(e.buckling);
    out.put(e.planeNormal);
    out.put(e.planeOffset);
    out.putVector(e.childVolumes);
    out.putVector(e.finesVolumes);
    out.put(e.rawVolumeError);
    out.put(e.inertiaRelativeError);
    out.put(e.parentMass);
    out.put(e.parentMomentum);
    out.put(e.fragmentMomentum);
    out.put(e.fragmentMass);
    out.put(e.parentKineticEnergy);
    out.put(e.inertiaEnergyBound);
    out.put(e.fragmentKineticEnergy);
    out.put(e.parentSpringEnergy);
    out.put(e.fragmentSpringEnergy);
    if (!withChips) continue;
    out.put(e.chip);
    out.put(e.chipDepth);
  }
  out.put(largestGain_);
  out.put(largestGainJoules_);
  out.put(std::uint64_t(unchecked_));
  if (!withChips) return;
  out.put(std::uint64_t(chips_));
  out.put(std::uint64_t(unresolvedChips_));
}

template <int D>
void Breakage<D>::mergeLogs(const Breakage& base, std::span<const Breakage* const> parts) {
  events_ = base.events_;
  manualNotApplied_ = base.manualNotApplied_;
  manualDone_ = base.manualDone_;
  rawVolumeError_ = base.rawVolumeError_;
  finesMass_ = base.finesMass_;
  unsplit_ = base.unsplit_;
  unsplittable_ = base.unsplittable_;
  chips_ = base.chips_;
  unresolvedChips_ = base.unresolvedChips_;
  unchecked_ = base.unchecked_;
  largestGain_ = base.largestGain_;
  largestGainJoules_ = base.largestGainJoules_;
  for (const Breakage* part : parts) {
    if (part->events_.size() < base.events_.size() || part->manualDone_.size() != base.manualDone_.size() ||
        part->manualNotApplied_.size() < base.manualNotApplied_.size()) {
      throw std::invalid_argument("Breakage::mergeLogs: a part did not start from the base log");
    }
    events_.insert(events_.end(), part->events_.begin() + std::ptrdiff_t(base.events_.size()), part->events_.end());
    manualNotApplied_.insert(manualNotApplied_.end(),
                             part->manualNotApplied_.begin() + std::ptrdiff_t(base.manualNotApplied_.size()),
                             part->manualNotApplied_.end());
    for (std::size_t m = 0; m < manualDone_.size(); ++m) manualDone_[m] = manualDone_[m] || part->manualDone_[m];
    rawVolumeError_ += part->rawVolumeError_ - base.rawVolumeError_;
    finesMass_ += part->finesMass_ - base.finesMass_;
    unsplit_ += part->unsplit_ - base.unsplit_;
    unsplittable_ += part->unsplittable_ - base.unsplittable_;
    chips_ += part->chips_ - base.chips_;
    unresolvedChips_ += part->unresolvedChips_ - base.unresolvedChips_;
    unchecked_ += part->unchecked_ - base.unchecked_;
    if (part->largestGain_ > largestGain_) {
      largestGain_ = part->largestGain_;
      largestGainJoules_ = part->largestGainJoules_;
    }
  }
  // One world applies a step's splits in ascending parent id.
  const auto later = [](const auto& a, const auto& b) {
    return a.time < b.time || (a.time == b.time && a.parent < b.parent);
  };
  std::stable_sort(events_.begin() + std::ptrdiff_t(base.events_.size()), events_.end(), later);
  std::stable_sort(manualNotApplied_.begin() + std::ptrdiff_t(base.manualNotApplied_.size()), manualNotApplied_.end(),
                   [](const auto& a, const auto& b) { return a.time < b.time; });
}

template <int D>
void Breakage<D>::loadState(dynamics::StateReader& in) {
  // A checkpoint of the release before chips ("breakage 3") holds none.
  const std::string tag = in.getString();
  if (tag != "breakage 3" && tag != "breakage 4") {
    throw std::runtime_error("checkpoint state is truncated or corrupt: expected section 'breakage 4', found '" + tag +
                             "'");
  }
  const bool withChips = tag == "breakage 4";
  std::vector<std::uint8_t> done;
  in.getVector(done);
  manualNotApplied_.resize(std::size_t(in.get<std::uint64_t>()));
  for (ManualBreakNotApplied& n : manualNotApplied_) {
    n.time = in.get<double>();
    n.particle = in.get<std::uint64_t>();
    n.reason = in.getString();
  }
  if (done.size() != manualDone_.size()) {
    throw std::runtime_error("checkpoint does not fit this scene: " + std::to_string(done.size()) +
                             " manual breaks in the checkpoint, " + std::to_string(manualDone_.size()) + " in the scene");
  }
  for (std::size_t m = 0; m < done.size(); ++m) manualDone_[m] = done[m] != 0;
  rawVolumeError_ = in.get<double>();
  finesMass_ = in.get<double>();
  unsplit_ = std::size_t(in.get<std::uint64_t>());
  unsplittable_ = std::size_t(in.get<std::uint64_t>());
  (void)in.get<std::uint64_t>();  // reserved
  (void)in.get<std::uint64_t>();  // reserved
  events_.resize(std::size_t(in.get<std::uint64_t>()));
  for (BreakageEvent<D>& e : events_) {
    e.time = in.get<double>();
    e.parent = in.get<std::uint64_t>();
    in.getVector(e.children);
    e.criterionValue = in.get<double>();
    e.strength = in.get<double>();
    e.manual = in.get<bool>();
    e.buckling = in.get<bool>();
    e.planeNormal = in.get<geometry::Vec<D>>();
    e.planeOffset = in.get<double>();
    in.getVector(e.childVolumes);
    in.getVector(e.finesVolumes);
    e.rawVolumeError = in.get<double>();
    e.inertiaRelativeError = in.get<double>();
    e.parentMass = in.get<double>();
    e.parentMomentum = in.get<geometry::Vec<D>>();
    e.fragmentMomentum = in.get<geometry::Vec<D>>();
    e.fragmentMass = in.get<double>();
    e.parentKineticEnergy = in.get<double>();
    e.inertiaEnergyBound = in.get<double>();
    e.fragmentKineticEnergy = in.get<double>();
    e.parentSpringEnergy = in.get<double>();
    e.fragmentSpringEnergy = in.get<double>();
    e.chip = withChips ? in.get<bool>() : false;
    e.chipDepth = withChips ? in.get<double>() : 0.0;
  }
  largestGain_ = in.get<double>();
  largestGainJoules_ = in.get<double>();
  unchecked_ = std::size_t(in.get<std::uint64_t>());
  chips_ = withChips ? std::size_t(in.get<std::uint64_t>()) : 0;
  unresolvedChips_ = withChips ? std::size_t(in.get<std::uint64_t>()) : 0;
}

template class Breakage<2>;
template class Breakage<3>;

}  // namespace lsdem::breakage
