#pragma once
/// @file Breakage.h
/// @brief Brittle breakage as one effect a scene declares (paper section 3):
/// Weibull strengths (eq. 11-13), grain stresses (eq. 5-6) against a criterion
/// (eq. 7-10), fracture planes through the strongest contacts (eq. 18-21),
/// level-set splitting (eq. 14-16) and fines removal.
///
/// The effect runs in World::afterStep, between steps, and reads the contacts
/// the step closed with (DESIGN "One step"):
///   1. every particle without a strength (strength <= 0) gets its Weibull
///      strength, sampleStrength(weibull, seed, global id, equivalent diameter);
///   2. grain stresses and principal stresses from this step's contacts; each
///      particle whose criterion fails at its strength is queued with its
///      fracture plane (fracturePlane, or bucklingPlane for slender grains when
///      the buckling mode is on; held, not queued, when no plane is defined),
///      unless it is smaller than minBreakableVolume; each manual break that
///      is due is queued too;
///   2b. with chipping declared (BreakageDef::chipping, Chipping.h), each
///      particle not already queued whose contact pressure exceeds its
///      chipping strength at one of its contacts is queued with the chip
///      plane of the contact that exceeds it most (one chip per particle and
///      step; the same size limits as splits);
///   3. the queue is applied in ascending global id: the parent is split by
///      its plane (mapped to the parent's body frame); a contact plane that
///      only grazes the grain is moved, parallel, to the centroid; if that
///      does not split it either, the grain cannot be cut at its grid
///      resolution and is made unbreakable (strength set to infinity, counted
///      in unsplittable()); else the parent leaves the store (not as a removal: its
///      matter lives on) and each fragment is added with the parent's density
///      (parent mass / parent shape volume), the split's exact-mass factor,
///      the rigid-body pose and velocity of fragmentState(), generation + 1,
///      birth time now and strength childStrength() (eq. 13; a parent made
///      unbreakable, strength infinite, gives its fragments none, so step 1
///      samples theirs); a chip plane that does not cut the grain at its
///      grid resolution leaves it whole (counted in unresolvedChips(); no
///      fall-back plane); a fragment below
///      minVolume or minNodes is recorded as removed ("fines") with its
///      kinetic energy instead;
///   4. the batch goes to the world in one World::replace (parents out,
///      fines recorded, fragments in, the ledger booked, the time step
///      re-checked once).
///
/// Manual breaks never stop a run: one that is due for a particle that is no
/// longer there, whose surface does not cut the particle (a plane or surface
/// outside it, or a cut the grid cannot resolve), or whose split throws is
/// recorded in manualNotApplied() and skipped.
///
/// Mass: fragments + fines carry the parent's mass exactly (to round-off;
/// Split.h). Energy: the kinetic energy of a broken parent leaves the ledger's
/// addedEnergy and that of all its fragments enters it, so addedEnergy
/// accumulates the net change of kinetic energy by splitting; fines then carry
/// theirs to removedEnergy. The contact springs' energy a split changes is
/// booked by the World as splitRelease.
///
/// Energy check, independent of that booking: after each batch the contacts
/// are evaluated at once on the new set (World::refreshContacts, which the
/// next step would do anyway), and each event records the mechanical energy
/// before and after: the parent's kinetic energy plus the springs of every
/// contact it was part of, against the fragments' kinetic energy (fines
/// included) plus the springs of every contact the kept fragments are part
/// of (BreakageEvent::energyGain). A split that cuts through a contact patch
/// may raise the springs' energy: its new surface nodes are new points of
/// contact, and with the per-node law a neighbour or wall can already overlap
/// the parent's surface between its nodes (node-to-surface contact), so a node
/// born there starts compressed. Such gains are measured against the run's
/// energy scale (EnergyLedger::scale, the largest term of the budget):
/// splitEnergyLimit() sets a bound on that fraction, and a split that exceeds
/// it stops the run (`lsdem run --check`); largestEnergyGain() reports the
/// worst split either way (docs/breakage.md "Energy check").
///
/// Contacts and indices. The stresses need the contact records to describe
/// the particles as they are: breakage reads contacts (readsContacts()), so
/// when an effect that ran before it in the same afterStep added or removed
/// particles, the world evaluates the contacts again before it runs
/// (World::step). Effects may be declared in any order.
///
/// Distributed runs (parallel/DistributedWorld.h): a world's ghosts (World::
/// isGhost) are never given a strength, queued or split here: their owner
/// does it. World::replace then agrees the ids, the time step and the other
/// ranks' mirrors with the other ranks before it returns.
///
/// Cost: an absent effect costs nothing (the scene adds it). A present one
/// walks the particles and the contact records once per step into buffers it
/// reuses; it allocates only when it breaks something.

#include "lsdem/breakage/Chipping.h"
#include "lsdem/breakage/Criteria.h"
#include "lsdem/breakage/FracturePlane.h"
#include "lsdem/breakage/GrainStress.h"
#include "lsdem/breakage/Split.h"
#include "lsdem/breakage/Weibull.h"
#include "lsdem/dynamics/Effect.h"
#include "lsdem/dynamics/World.h"
#include "lsdem/geometry/Primitives.h"
#include "lsdem/geometry/Types.h"

#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace lsdem::breakage {

/// A prescribed first break (demolition): particle `particle` is split by
/// `plane` at the first step ending at or after `time`, whatever its stress.
/// An arbitrary fracture surface replaces the plane when `surface` is set:
/// the zero level set of that shape's grid (a grain file's level set, a CAD
/// mesh's, a primitive's), placed in the world by `surfaceToWorld`; the
/// fragments are the parent's parts inside and outside it, and their new
/// surface nodes are regenerated from their own level sets (curved cuts).
template <int D>
struct ManualBreak {
  std::uint64_t particle = 0;                 ///< global id of the particle
  double time = 0.0;                          ///< s
  geometry::HalfSpace<D> plane;               ///< fracture plane, WORLD frame (normal need not be unit)
  std::shared_ptr<const geometry::Shape<D>> surface;  ///< optional curved fracture surface (its grid's phi = 0)
  geometry::Rigid<D> surfaceToWorld;          ///< the surface shape's GRID frame -> world
};

/// Everything that configures the breakage effect (STYLE 7).
template <int D>
struct BreakageDef {
  CriterionDef criterion;        ///< which criterion (eq. 7-10) and its reference limits
  WeibullDef weibull;            ///< strength distribution (eq. 11-13)
  std::uint64_t seed = 1;        ///< seed of the keyed strengths and buckling directions
  double minVolume = 0.0;        ///< fragments with a smaller volume (area in 2D) are removed as fines, m^D (>= 0)
  int minNodes = 0;              ///< fragments with fewer surface nodes are removed as fines (>= 0)
  /// Instead of removing small fragments: particles below minVolume or
  /// minNodes do not break (and fragments below them are kept).
  bool haltBelowMinimum = false;
  /// Particles with a smaller volume (area in 2D) do not break, m^D (>= 0;
  /// 0: every size breaks). The paper's first remedy for unstable small
  /// fragments (section 4), independent of the fines size minVolume: with
  /// minVolume well below it, pieces between the two are kept whole and only
  /// chips below minVolume leave as fines.
  double minBreakableVolume = 0.0;
  /// Contacts a split creates start relaxed (dynamics::ContactSolver::
  /// markNewborn): a fragment's new-face nodes born inside another body carry
  /// no force at the overlap they are born with, and the rest overlaps of the
  /// parent's contacts pass to its fragments. false: they push at once (a
  /// split then adds their spring energy; docs/breakage.md, "Energy check").
  bool relaxNewContacts = true;
  bool buckling = false;         ///< eq. 21 buckling mode (off by default)
  /// Buckling trigger: circumscribed sphere (circle) volume / grain volume > this (> 1).
  double bucklingRatio = 10.0;
  std::vector<ManualBreak<D>> manual;  ///< prescribed first breaks
  /// How grains are split: fragment node density, re-gridding of small
  /// fragments (SplitOptions::regridCells, on by default) and its bounds.
  SplitOptions split;
  /// Chipping at single contacts (Chipping.h); empty: no chipping, and the
  /// effect does not look at it (a run is bitwise the one without the key).
  std::optional<ChippingDef> chipping;
};

/// How a particle broke (BreakageEvent::mode).
enum class BreakageMode {
  Split,     ///< the criterion failed: a cut through the strongest contacts (eq. 18-20)
  Buckling,  ///< the criterion failed, cut by the buckling plane (eq. 21)
  Manual,    ///< a prescribed break (ManualBreak)
  Chip,      ///< chipping at one contact (Chipping.h)
};

/// @brief The mode's name in the breakage log: "split", "buckling", "manual", "chip".
const char* breakageModeName(BreakageMode mode);

/// One breakage, as kept in the effect's log.
template <int D>
struct BreakageEvent {
  double time = 0.0;                           ///< s
  std::uint64_t parent = 0;                    ///< global id of the broken particle
  std::vector<std::uint64_t> children;         ///< global ids of the kept fragments
  double criterionValue = 0.0;                 ///< characteristic stress sigma^c at failure, Pa (manual: this step's, 0 without contacts)
  double strength = 0.0;                       ///< the parent's critical stress, Pa
  bool manual = false;                         ///< a prescribed break (ManualBreak)
  bool buckling = false;                       ///< cut by the buckling plane (eq. 21)
  /// A chip (Chipping.h): criterionValue is then the contact pressure over
  /// its node patch and strength the chipping strength of a chip of depth chipDepth.
  bool chip = false;
  double chipDepth = 0.0;                      ///< chips: the chip's depth below the contact's tip, m (0 otherwise)
  geometry::Vec<D> planeNormal = geometry::Vec<D>::Zero();  ///< unit normal of the fracture plane, world frame (zero for a curved manual surface)
  double planeOffset = 0.0;                    ///< normal . x on the plane, world frame, m
  std::vector<double> childVolumes;            ///< corrected volumes of the kept fragments, m^D
  std::vector<double> finesVolumes;            ///< corrected volumes of the fragments removed as fines, m^D
  double rawVolumeError = 0.0;                 ///< the split's relative raw volume error (SplitResult::rawRelativeError)
  double inertiaRelativeError = 0.0;           ///< SplitResult::inertiaRelativeError
  double parentMass = 0.0;                     ///< kg
  geometry::Vec<D> parentMomentum = geometry::Vec<D>::Zero();    ///< kg m/s, world frame
  geometry::Vec<D> fragmentMomentum = geometry::Vec<D>::Zero();  ///< of all fragments incl. fines, kg m/s
  double fragmentMass = 0.0;                   ///< of all fragments incl. fines, kg
  double parentKineticEnergy = 0.0;            ///< J
  /// J: the largest change of kinetic energy the split's inertia mismatch can
  /// make, (1/2) inertiaRelativeError |I_parent| |w|^2 (Split.h: the change is
  /// (1/2) w.(I_comb - I_parent) w; 3D: |I| the Frobenius norm of the principal
  /// moments, which bounds the quadratic form).
  double inertiaEnergyBound = 0.0;
  double fragmentKineticEnergy = 0.0;          ///< of all fragments incl. fines, J
  /// The split's energy check (file comment), J; NaN when the parent's
  /// springs were not known (contacts stale at the split).
  /// Elastic energy of every contact the parent was part of, just before the split.
  double parentSpringEnergy = std::numeric_limits<double>::quiet_NaN();
  /// Elastic energy of every contact the kept fragments are part of, evaluated
  /// on the new particle set right after the batch of splits.
  double fragmentSpringEnergy = std::numeric_limits<double>::quiet_NaN();
  /// @brief (fragments' kinetic + spring energy) - (parent's kinetic + spring
  /// energy) - inertiaEnergyBound, J: what the split added beyond what its
  /// inertia error explains (NaN when not measured). Kinetic energies at true
  /// masses (World::unscaledMass).
  double energyGain() const {
    return fragmentKineticEnergy + fragmentSpringEnergy - parentKineticEnergy - parentSpringEnergy -
           inertiaEnergyBound;
  }
  /// @brief How the particle broke.
  BreakageMode mode() const {
    return chip ? BreakageMode::Chip
                : manual ? BreakageMode::Manual : buckling ? BreakageMode::Buckling : BreakageMode::Split;
  }
};

/// A manual break that was due but could not be applied: it is logged here
/// (and in the run summary), never thrown out of World::step.
struct ManualBreakNotApplied {
  double time = 0.0;          ///< s, when it was due
  std::uint64_t particle = 0; ///< global id it named
  std::string reason;         ///< one line: why it was not applied
};

/// @brief The breakage effect (see the file comment).
template <int D>
class Breakage final : public dynamics::Effect<D> {
 public:
  /// @note Throws std::invalid_argument for a bad criterion or Weibull
  /// parameter, minVolume < 0, minNodes < 0, bucklingRatio not > 1, or
  /// split options out of range (validateSplitOptions).
  explicit Breakage(const BreakageDef<D>& def);

  std::string name() const override { return "breakage"; }
  /// @brief Strengths, stresses, failures and splits of this step (file comment).
  void afterStep(dynamics::World<D>& world) override;
  /// @brief The stresses and fracture planes come from the contact records.
  bool readsContacts() const override { return true; }
  bool replacesParticles() const override { return true; }
  bool distributable() const override { return true; }
  /// @brief Writes the log, totals and which manual breaks are done (checkpoints).
  void saveState(dynamics::StateWriter& out) const override;
  void loadState(dynamics::StateReader& in) override;

  const BreakageDef<D>& def() const { return def_; }
  const Criterion& criterion() const { return *criterion_; }
  /// @brief Every breakage so far, in the order applied.
  const std::vector<BreakageEvent<D>>& events() const { return events_; }
  /// @brief Number of breakages so far (chips included).
  std::size_t breakages() const { return events_.size(); }
  /// @brief Number of chips so far (events whose mode() is Chip).
  std::size_t chips() const { return chips_; }
  /// @brief Chips whose plane did not cut the grain at its grid resolution
  /// (the grain was left whole).
  std::size_t unresolvedChips() const { return unresolvedChips_; }
  /// @brief Sum over breakages of |rawVolumeError| x parent volume: the volume
  /// the exact-mass correction redistributed, m^D.
  double rawVolumeError() const { return rawVolumeError_; }
  /// @brief Mass removed as fines so far, kg.
  double finesMass() const { return finesMass_; }
  /// @brief Failures of the criterion whose surface did not split the grain
  /// (it missed or grazed it, and for a contact plane so did the parallel
  /// plane through the centroid). Manual breaks that were not applied are
  /// in manualNotApplied(), not here.
  std::size_t unsplitFailures() const { return unsplit_; }
  /// @brief Grains that failed but could not be split at their grid
  /// resolution through their centroid either; they were made unbreakable
  /// (strength set to infinity).
  std::size_t unsplittable() const { return unsplittable_; }
  /// @brief Stops the run (std::runtime_error out of afterStep, naming the
  /// split) when a split's energyGain() exceeds `fraction` of the run's energy
  /// scale (EnergyLedger::scale at the split); +infinity (the default): report only.
  void setSplitEnergyLimit(double fraction) { energyLimit_ = fraction; }
  double splitEnergyLimit() const { return energyLimit_; }
  /// @brief The largest energyGain() of any split so far as a fraction of the
  /// run's energy scale at that split (0 when none gained), and that gain in J.
  double largestEnergyGain() const { return largestGain_; }
  double largestEnergyGainJoules() const { return largestGainJoules_; }
  /// @brief Splits whose energy was not checked (contacts stale at the split).
  std::size_t uncheckedSplits() const { return unchecked_; }
  /// @brief Manual breaks that were due but not applied, in order: the
  /// particle was no longer there (broken or removed earlier), the surface
  /// does not cut it at its grid resolution, or the split failed (the
  /// reason names the error). The run goes on without them.
  const std::vector<ManualBreakNotApplied>& manualNotApplied() const { return manualNotApplied_; }
  /// @brief Makes this effect's log and totals those of a distributed run
  /// (docs/parallel.md): `parts` are the ranks' effects, each of which
  /// started from `base` (the log at the start, or at the checkpoint the run
  /// resumed from) and logged its own particles' breakages since. The log is
  /// base's events, then every part's new ones, in the order one world
  /// applies them (time, then parent id); counts and volumes are base's plus
  /// every part's increase, the largest energy gain the largest, and a manual
  /// break is done when one part did it.
  /// @note Throws std::invalid_argument when a part holds fewer events than
  /// `base` or other manual breaks.
  void mergeLogs(const Breakage& base, std::span<const Breakage* const> parts);

 private:
  struct Pending {
    std::uint64_t id;
    std::size_t index;
    double criterionValue;
    geometry::HalfSpace<D> plane;  // world frame
    bool manual;
    bool buckling;
    const ManualBreak<D>* curved;  // a manual break with a curved surface, or null
    bool chip = false;
    double chipDepth = 0.0;        // m
    double chipStrength = 0.0;     // Pa
  };

  bool isBelowMinimum(const geometry::Shape<D>& shape) const;
  void queueFailures(dynamics::World<D>& world);
  /// Queues the chips of this step (file comment, 2b): particles not queued yet.
  void queueChips(const dynamics::World<D>& world);
  void applyQueue(dynamics::World<D>& world);
  /// The springs' energy of the current contacts per particle, into springs_.
  void springsPerParticle(const dynamics::World<D>& world);
  /// The springs' energy of the current contacts into the fragmentSpringEnergy
  /// of the events from `firstEvent` on that the particles were born in (eventOf_).
  void fragmentSprings(const dynamics::World<D>& world, std::size_t firstEvent);
  /// Evaluates the new set's contacts and checks the energy of events from `firstEvent` on.
  void checkEnergy(dynamics::World<D>& world, std::size_t firstEvent);
  /// The bodies within reach of particle i's surface (other particles whose
  /// bounding spheres come within a few of its cells, every plane, tools
  /// likewise) into around_, and splitShape's `clearance` over them.
  geometry::SignedDistance<D> clearanceAround(const dynamics::World<D>& world, std::size_t i);

  BreakageDef<D> def_;
  std::unique_ptr<Criterion> criterion_;
  std::vector<bool> manualDone_;
  // Reused buffers.
  std::vector<geometry::Mat<D>> stress_;
  GrainContactPoints<D> points_;
  GrainContactLoads<D> loads_;
  /// A body near a grain being split: its shape placed in the world (or a plane).
  struct Neighbour {
    const geometry::Shape<D>* shape = nullptr;  ///< nullptr: a plane
    geometry::Mat<D> rotation;                  ///< body -> world
    geometry::Vec<D> position;                  ///< body origin / a point of the plane, world frame
    geometry::Vec<D> normal;                    ///< a plane's normal
    double radius = 0.0;                        ///< bounding radius
  };
  std::vector<Neighbour> around_;
  std::vector<std::size_t> near_;  // clearanceAround's particles in reach, by global id
  std::vector<Pending> queue_;
  std::vector<dynamics::Replacement<D>> splits_;  // this batch's, in the order of the parents' ids
  // The rest overlaps fragment `f` of the parent takes over (ChildBirth::Rest).
  static std::vector<dynamics::ChildBirth::Rest> inheritedRestOverlaps(
      const std::vector<typename dynamics::ContactSolver<D>::RestOverlap>& rest, std::uint64_t parentId,
      const geometry::Shape<D>& parent, const Fragment<D>& f);
  // Log and totals.
  std::vector<BreakageEvent<D>> events_;
  double rawVolumeError_ = 0.0;
  double finesMass_ = 0.0;
  std::size_t unsplit_ = 0;
  std::size_t unsplittable_ = 0;
  std::size_t chips_ = 0;
  std::size_t unresolvedChips_ = 0;
  std::vector<ManualBreakNotApplied> manualNotApplied_;
  // Energy check.
  std::vector<double> springs_;    // per particle: elastic energy of its contacts
  std::vector<std::int64_t> eventOf_;  // per particle: the batch event it was born in, -1: none
  double energyLimit_ = std::numeric_limits<double>::infinity();
  double largestGain_ = 0.0;
  double largestGainJoules_ = 0.0;
  std::size_t unchecked_ = 0;
};

extern template class Breakage<2>;
extern template class Breakage<3>;

}  // namespace lsdem::breakage
