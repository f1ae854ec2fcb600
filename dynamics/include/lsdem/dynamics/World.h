#pragma once
/// @file World.h
/// @brief The LS-DEM world: particles, walls and tools, the contact law, the
/// declared effects, and the step that advances them.
///
/// One step (DESIGN "One step"), velocity Verlet in two halves (Integrator.h):
///
///     integrate: half kick + drift       x(n) -> x(n+1), v(n) -> v(n+1/2)
///     moveKinematicBodies()              tools and planes to t(n+1)
///     broadPhase()                       candidate pairs, Verlet skin
///     narrowPhase() + contactForces()    node contacts and forces (eq. 3-4)
///     applyEffects()                     gravity, damping, ... (declared only)
///     integrate: half kick               v(n+1/2) -> v(n+1)
///     afterStep()                        breakage, removal, recorders
///
/// The force stages of a step are the ones that close it, so the state between
/// steps (positions, velocities, forces, contacts) is consistent: breakage and
/// output read contacts computed at the positions they describe.

#include "lsdem/dynamics/BroadPhase.h"
#include "lsdem/dynamics/Effect.h"
#include "lsdem/dynamics/Motion.h"
#include "lsdem/dynamics/NarrowPhase.h"
#include "lsdem/dynamics/ParticleSetCoordinator.h"
#include "lsdem/dynamics/Particles.h"
#include "lsdem/dynamics/State.h"
#include "lsdem/dynamics/Wall.h"

#include <array>
#include <functional>
#include <limits>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace lsdem::dynamics {

/// A kinematic level-set body (jaw, bucket, platen) with prescribed motion.
template <int D>
struct ToolDef {
  std::string name;
  std::shared_ptr<const geometry::Shape<D>> shape;  ///< required
  Motion<D> motion;                                  ///< pose of the shape's body frame over time
  std::optional<BoundaryMaterial> material;          ///< its own contact material; absent: the grains'
};

/// An infinite plane wall, optionally translating at constant velocity.
template <int D>
struct PlaneDef {
  std::string name;
  Plane<D> plane;  ///< at t = 0
  std::optional<BoundaryMaterial> material;  ///< its own contact material; absent: the grains'
};

/// Opt-in density scaling of small fragments (STYLE 7). A fragment (a
/// particle with a parent) whose equivalent diameter is below
/// `belowDiameter` gets its mass and inertia, and with them its weight,
/// multiplied by the factor s = min(maxFactor, max(1, omega_i^2 / omega_ref^2)),
/// fixed when it enters the world: omega_i^2 = k_eff / m of the fragment and
/// omega_ref^2 the largest k_eff / m of the particles the scaling leaves alone
/// (so far in the run), so a scaled fragment no longer sets a shorter time step
/// than the unscaled particles do (unless the cap stops it). Mass balances,
/// removal records, size distributions and breakage use the true mass
/// (World::unscaledMass); the dynamics (inertia, weight, contact damping) and
/// the kinetic energy use the scaled one. The kinetic energy the scaling adds
/// to a moving fragment is booked in the ledger's addedEnergy.
struct DensityScalingDef {
  double belowDiameter = 0.0;  ///< m (> 0): fragments smaller than this are scaled
  double maxFactor = 100.0;    ///< >= 1: the largest factor applied
};

/// What sets the automatic time step: the particle whose stiffest contact,
/// over its mass, gives the fastest oscillation (TimeStep.h), and that contact.
struct TimeStepLimit {
  std::uint64_t id = 0;          ///< global id of the particle
  double mass = 0.0;             ///< its mass as the dynamics see it (density scaling included), kg
  double stiffness = 0.0;        ///< k_eff of its stiffest contact, N/m
  /// Linear law: the surface nodes of that contact's patch (a flat face
  /// engages all its nodes at once; TimeStep.h); 0 for Hertz.
  std::uint64_t patchNodes = 0;
  double diameter = 0.0;         ///< its equivalent diameter, m
  double spacing = 0.0;          ///< its grid spacing, m
  std::uint64_t nodes = 0;       ///< its surface nodes
  std::int32_t generation = 0;   ///< 0: an original particle; > 0: a fragment
  /// The contact: -1 particle on particle; j in [0, planes): plane j's own
  /// material; planes + k: tool k's own material.
  std::int32_t boundary = -1;
  double densityScale = 1.0;     ///< its density scaling factor (1: none)
  double criticalDt = 0.0;       ///< the critical step it gives, s

  /// @brief omega^2 = k / m of the particle, 1/s^2 (0: no limit yet).
  double omega2() const { return criticalDt > 0.0 ? stiffness / mass : 0.0; }
};

/// @brief Whether a particle of `omega2` = k / m and id `id` sets the step
/// before one of `thanOmega2` and `thanId`: the larger omega^2, and of equals
/// the lower id. (An order that does not depend on where the particles are
/// stored: one world and every part of a distributed run name the same
/// particle. A particle of omega^2 = 0 sets nothing.)
inline bool setsStepBefore(double omega2, std::uint64_t id, double thanOmega2, std::uint64_t thanId) {
  return omega2 > thanOmega2 || (omega2 == thanOmega2 && omega2 > 0.0 && id < thanId);
}

/// One change of the time step during a run.
struct TimeStepChange {
  double time = 0.0;    ///< s, when it changed
  double dt = 0.0;      ///< s, the new step
  TimeStepLimit limit;  ///< what set it
};

/// What the density scaling did so far (DensityScalingDef).
struct DensityScalingStats {
  std::uint64_t scaled = 0;      ///< fragments scaled so far (factor > 1)
  double largestFactor = 1.0;    ///< the largest factor applied
  std::uint64_t capped = 0;      ///< fragments whose factor hit maxFactor
  double referenceOmega2 = 0.0;  ///< omega_ref^2, 1/s^2 (0: no unscaled particle yet)
};

/// Everything that configures a world (STYLE 7). Effects are declared by
/// giving them a value; an absent effect is not built.
template <int D>
struct WorldDef {
  ContactLawDef contact;                    ///< contact law (friction and damping parts inside)
  BroadPhaseDef<D> broadPhase;              ///< Verlet skin
  double dt = 0.0;                          ///< s; 0: automatic, safety x the critical step, re-checked as particles are added
  double dtSafety = 0.2;                    ///< fraction of the critical step used or allowed
  bool forceDt = false;                     ///< accept a user dt above the safe step
  std::optional<Vec<D>> gravity;            ///< m/s^2
  std::optional<double> globalDamping;      ///< C_g, 1/s (Tables 1-2)
  std::optional<double> localDamping;       ///< Cundall alpha in [0, 1)
  std::optional<geometry::Box<D>> outflow;  ///< particles whose centroid leaves this box are removed
  /// With outflow: removed particles whose centroid lies in this box left
  /// through the discharge (reason "discharge"); the others are "outflow".
  std::optional<geometry::Box<D>> discharge;
  bool checkFinite = false;                 ///< check every state value for NaN/Inf each step (debug)
  /// The energy ledger's per-step booking (EnergyLedger): the work of
  /// gravity, boundaries and damping, and the contact losses. Off: only
  /// the kinetic and elastic energy are known (computed when read), the
  /// budget's other terms stay 0; the trajectory is the same bit for bit.
  bool energyLedger = true;
  std::optional<DensityScalingDef> densityScaling;  ///< opt-in; absent: no particle is scaled
};

/// The energy budget of a run, J. Work done on the particles counts positive.
/// Kinetic and elastic energy are those of the state after the last step;
/// gravity's work is exact for the drift (m g . dx); the loss of sliding
/// friction is booked when a shear spring is capped; contact dashpots, damping
/// effects and moving boundaries are booked over the two half kicks their
/// forces act through (the trapezoid rule in time), so they account for the
/// same instant as the kinetic energy; splitRelease books the springs' energy
/// that a change of the particle set between steps takes away.
struct EnergyLedger {
  double kineticTranslational = 0.0;
  double kineticRotational = 0.0;
  double elastic = 0.0;          ///< stored in contact springs now
  double gravityWork = 0.0;      ///< work of gravity on the particles so far
  double boundaryWork = 0.0;     ///< work of moving planes and tools on the particles so far
  double dampingLoss = 0.0;      ///< removed by global and local damping so far
  double contactLoss = 0.0;      ///< dissipated by contact damping and sliding friction so far
  double removedEnergy = 0.0;    ///< kinetic energy carried away by removed particles
  double addedEnergy = 0.0;      ///< kinetic energy brought by particles added after the start
  /// Elastic energy the contact springs lost when the particle set changed
  /// between steps, so far: the springs re-evaluated on the new set (a split
  /// parent's springs on its fragments, whose shear history starts afresh;
  /// the springs of particles that left: fines, outflow). In a breakage scene, the energy the
  /// fractures took. Negative if the new set stores more.
  double splitRelease = 0.0;
  double initial = 0.0;          ///< kinetic + elastic at the start

  double total() const { return kineticTranslational + kineticRotational + elastic; }
  /// @brief Energy now minus energy accounted for: 0 for an exact budget.
  double balanceError() const {
    return total() + dampingLoss + contactLoss + removedEnergy + splitRelease - initial - gravityWork - boundaryWork -
           addedEnergy;
  }
  /// @brief The energy scale of the run: the largest term of the budget, J (> 0).
  double scale() const;
  /// @brief balanceError relative to scale().
  double relativeBalanceError() const;
  /// @brief Adds every term of `other` (the parts of a distributed run sum their ledgers).
  void add(const EnergyLedger& other);
};

/// A particle taken out of the simulation (outflow, fines).
struct RemovedParticle {
  std::uint64_t id = 0;
  double time = 0.0;         ///< s
  double mass = 0.0;         ///< kg
  double volume = 0.0;       ///< m^D
  double sieveSize = 0.0;    ///< m (eq. 21)
  std::string reason;        ///< "outflow", "fines", ...
};

/// One particle's split, for World::replace: the fragments that enter as
/// particles, and the matter the split removes at once (fines) as removal
/// records with the kinetic energy each carried (J); replace() gives those
/// records their ids and time, and writes each child's id into its def.
template <int D>
struct Replacement {
  std::size_t parent = 0;  ///< index of the particle that leaves
  std::vector<ParticleDef<D>> children;
  std::vector<std::pair<RemovedParticle, double>> fines;
  /// How the children's contacts start (markBirth): empty, or one per child.
  std::vector<ChildBirth> births;
};

/// Stages of the step whose wall-clock time is reported. Energy: what the
/// energy ledger books every step (work of the half kicks, dashpot and
/// friction losses); the kinetic and elastic energy are summed when read.
enum class Stage { Integrate, Kinematics, BroadPhase, NarrowPhase, Accumulate, Effects, AfterStep, Energy, Count };
const char* stageName(Stage s);

template <int D>
class World {
 public:
  /// @note Throws std::invalid_argument for invalid parameters (the contact
  /// law's, dt < 0, safety not in (0, 1], damping out of range).
  explicit World(const WorldDef<D>& def);

  // ---- building ----
  /// @brief Adds a particle; re-checks the time step. Returns its index.
  /// In a distributed run a particle without an id (an effect's: a feed's,
  /// added in its afterStep) takes the run's next free id
  /// (ParticleSetCoordinator::takeId), and the world that keeps it as its
  /// own books the energy it brings once the worlds agree (after the effect).
  std::size_t addParticle(const ParticleDef<D>& def);
  /// @brief Adds a copy of a particle another world holds (a distributed
  /// run's mirror, a particle handed over, a view's copy), with its owner's
  /// mass (def.mass) and density scaling decision (`densityScale`,
  /// decidedDensityScale). Nothing is booked: the energy it brings is its
  /// owner's. Returns its index.
  std::size_t addCopy(const ParticleDef<D>& def, double densityScale);
  /// @brief Folds a particle that will only be added later (a feed's grains)
  /// into the automatic time step, so a world can start before it has any
  /// particle; the step never grows afterwards.
  /// @note Throws std::invalid_argument for a missing shape or a mass <= 0.
  void anticipateParticle(const ParticleDef<D>& def);
  /// @brief Removes particle `index`, recording it (for mass balance and size
  /// distributions) with `reason`. A ghost (setGhost) leaves without a
  /// record: its owner records it.
  void removeParticle(std::size_t index, const std::string& reason);
  /// @brief Takes particle `index` out without a removal record or any
  /// booking: it goes on elsewhere (a distributed run: a mirrored particle
  /// out of reach, or one that moved to another rank). Its contact history
  /// stays until the next force evaluation.
  void detachParticle(std::size_t index);
  /// @brief Replaces the contact history of particle `id`'s pairs
  /// (ContactSolver::adoptHistory): a distributed run hands it over with a
  /// particle that moves to another rank. The contacts are then stale until
  /// the next force evaluation.
  void adoptHistory(std::uint64_t id, const typename ContactSolver<D>::ParticleHistory& history) {
    contacts_.adoptHistory(id, history);
    forcesValid_ = false;
  }
  /// @brief adoptHistory for several particles at once
  /// (ContactSolver::adoptHistories: linear in the histories).
  void adoptHistories(std::span<const std::uint64_t> ids,
                      std::span<const typename ContactSolver<D>::ParticleHistory* const> histories) {
    contacts_.adoptHistories(ids, histories);
    forcesValid_ = false;
  }
  /// @brief Marks particle `index` as a ghost (or not): a mirror of a
  /// particle another rank of a distributed run owns and moves. Pairs of two
  /// ghosts are not computed (no force they give acts on a particle this
  /// world owns), and neither are a ghost's field forces (Effect::
  /// applyForces) nor its frames (io/Vtk.h: its owner's piece); the energy
  /// ledger books the terms of this world's own particles
  /// (their work, damping, kinetic energy, their half of a pair's dashpot
  /// work) and of the pairs whose lower-id particle is its own (springs,
  /// friction), so that the ledgers of a run's parts sum to the run's.
  /// A world without ghosts keeps no flags and pays nothing.
  void setGhost(std::size_t index, bool ghost);
  /// @brief Whether particle `index` is a ghost (setGhost).
  bool isGhost(std::size_t index) const { return !ghost_.empty() && ghost_[index] != 0; }
  /// @brief Sets the pose and velocities of particle `index` (a distributed
  /// run: a mirror of a particle another rank moves). The contacts are then
  /// stale until the next force evaluation.
  void setMotion(std::size_t index, const Vec<D>& position, const Orientation<D>& orientation, const Vec<D>& velocity,
                 const Spin<D>& angularVelocity);
  /// @brief Records a removal of matter that never became a particle (breakage
  /// fines): appends `r` to removed() and adds `kineticEnergy` (J) to the
  /// ledger's removedEnergy.
  void recordRemoval(const RemovedParticle& r, double kineticEnergy);
  std::size_t addTool(const ToolDef<D>& def);
  std::size_t addPlane(const PlaneDef<D>& def);
  /// @brief Declares one more effect (breakage plugs in here).
  void addEffect(std::unique_ptr<Effect<D>> effect);
  /// @brief Replaces particles by others (breakage): each parent leaves (no
  /// removal record: its matter goes on in its fragments), its fines are
  /// recorded as removed, then the children enter, in the order given, with
  /// their births (markBirth); the ledger books the kinetic energy this adds
  /// (the children's and the fines', less the parents') and what the fines
  /// carry away; then particlesChanged(). Ids: the fines of every split, in
  /// order, then the children of every split, from the next free id.
  /// Returns the children's indices, in order.
  ///
  /// In a distributed run (setCoordinator) the coordinator gives the ids (as
  /// one world holding the whole run would), the time step becomes the run's,
  /// and the other worlds' mirrors are brought up to the new set before this
  /// returns; a child whose centroid lies in another world's part is then
  /// that world's and a mirror here (isGhost).
  /// @note Throws std::out_of_range for a parent index out of range or given
  /// twice; with a coordinator, std::invalid_argument for parents not in
  /// ascending id and std::logic_error for a replace() outside the afterStep
  /// of an effect that declares Effect::replacesParticles, or a second one
  /// in it.
  std::vector<std::size_t> replace(std::vector<Replacement<D>>& splits);
  /// @brief Makes this world one part of a run spread over several (a
  /// distributed run; ParticleSetCoordinator.h): replace() then goes through
  /// `coordinator`, and after each effect that may replace or change
  /// particles (Effect::replacesParticles, changesParticles) every world
  /// takes part in the collective calls, whether it changed any or not
  /// (finishStep). Null (the default): a world of its
  /// own, which never calls one.
  void setCoordinator(ParticleSetCoordinator* coordinator) { coordinator_ = coordinator; }
  /// @brief Whether this world is one part of a distributed run (setCoordinator).
  bool isDistributed() const { return coordinator_ != nullptr; }
  /// @brief Whether `here` holds in any world of the run: `here` itself in a
  /// world of its own; collective in a distributed run (every world asks at
  /// the same point of its step). For effects that decide from the whole
  /// run's particles (Effect::changesParticles).
  bool anyWorld(bool here) { return coordinator_ ? coordinator_->largest(here ? 1.0 : 0.0) > 0.0 : here; }
  /// @brief Sets particle i's strength (breakage: eq. 12-13; infinite: unbreakable).
  void setStrength(std::size_t i, double strength) { particles_.strength.at(i) = strength; }
  /// @brief Tells the world particles were replaced in bulk: the broad phase
  /// rebuilds and the time step is re-checked (replace() calls it).
  void particlesChanged();
  /// @brief How particle `id`'s contacts found at the next evaluation start
  /// (a fragment just born; replace() calls it for its children, a
  /// distributed run for a child mirrored from its owner): the nodes of its
  /// new face start relaxed (ContactSolver::markNewborn), and it takes over
  /// its parent's rest overlaps (ContactSolver::inheritRestOverlap).
  void markBirth(std::uint64_t id, const ChildBirth& birth);

  // ---- running ----
  /// @brief Advances one step of dt(): beginStep() then finishStep().
  void step();
  /// @brief The first part of a step: the forces of the current state if
  /// they are stale, the opening half kick and the drift, tools and planes to
  /// the end of the step. Positions are then x(n+1), velocities v(n+1/2).
  /// A distributed run mirrors its particles between the two parts.
  void beginStep();
  /// @brief The rest of a step: forces at the new positions, the closing
  /// half kick, the clock, and the effects between steps.
  void finishStep();
  /// @brief Evaluates the contacts and forces of the particles as they are
  /// now, if they changed since the last evaluation (contactsCurrent() false);
  /// step() does it first anyway, so calling it between steps changes no
  /// result (to round-off in the shear springs, when the particles change
  /// again before the step and they are re-evaluated twice). The springs'
  /// energy the change took away is booked as EnergyLedger::splitRelease. Breakage calls it after a batch of splits
  /// to measure the fragments' springs.
  void refreshContacts();
  /// @brief Advances n steps.
  void run(std::uint64_t n);
  /// @brief The next step opens with the particles' forces and torques as
  /// they are, though particles may leave or become ghosts before it
  /// (detachParticle, setGhost): a distributed run spread from a checkpoint,
  /// whose parts step on with the forces the whole run evaluated, as the run
  /// would have. Call it while the contacts are current, before those
  /// changes: the opening half kick's work is worked out now, from the
  /// contact records that still describe the particles, and booked by the
  /// step. The records then stay stale until the step evaluates them.
  /// @note Throws std::logic_error when the contacts are not current.
  void keepForces();
  /// One particle of a run that a world shows (showRunOf), as the run's last
  /// force evaluation left it.
  struct ShownParticle {
    Vec<D> forceVelocity = Vec<D>::Zero();  ///< the velocity the evaluation saw (a step's half-step one)
    Spin<D> forceSpin = Rotation<D>::zeroSpin();
    Vec<D> force = Vec<D>::Zero();          ///< the force and torque it gave
    Spin<D> torque = Rotation<D>::zeroSpin();
    const typename ContactSolver<D>::ParticleHistory* history = nullptr;  ///< its contact history then
  };
  /// @brief Makes this world show the run of `run` at its current instant,
  /// for outputs: a distributed run's view on the rank that writes them,
  /// which nothing steps. Its particles must have been brought up to the
  /// run's beforehand (addParticle, detachParticle, setMotion, setStrength,
  /// adoptHistory). Works out its critical step over its particles, takes
  /// `run`'s clock, time step and its changes, tool poses and planes, and
  /// evaluates the contacts as the run last evaluated them (between steps:
  /// the shear springs keep their length), with the velocities that
  /// evaluation saw (`shown`, aligned with this world's particles: a step
  /// evaluates its forces with half-step velocities, which its closing half
  /// kick then changes). The evaluation gives the run's forces and springs
  /// to round-off only (a sliding spring is capped, then read back), so each
  /// particle then takes the run's own forces and contact history (its
  /// records stay current): this world's state, and a checkpoint of it, are
  /// the run's bit for bit. Last, `run`'s stage and effect timings.
  /// `touching`: the particle pairs in contact at the run's last evaluation
  /// (ids, the lower first), and `touchingTools` its particles touching a
  /// tool ({id, tool index}), both ascending. Only they are evaluated: a
  /// candidate pair the run found apart finds no contact here either, and a
  /// view that nothing steps has no separation certificates to spare its
  /// search.
  /// @note Throws std::invalid_argument when `run` has other tools, planes or
  /// effects, `shown` does not match the particles or the pairs are not
  /// ascending; std::logic_error when a particle's history does not fit the
  /// contacts found here.
  void showRunOf(const World& run, std::span<const ShownParticle> shown,
                 std::span<const std::array<ParticleId, 2>> touching,
                 std::span<const std::array<ParticleId, 2>> touchingTools);

  // ---- checkpoints ----
  /// @brief Writes the state between steps: particles (each shape as the number
  /// `shapeIndex` gives it), contact records and shear history, boundary loads,
  /// servo states and the tools' poses, time, step count, time step, energy
  /// ledger, removals, stage times and every effect's state, in order.
  void saveState(StateWriter& out,
                 const std::function<std::uint32_t(const std::shared_ptr<const geometry::Shape<D>>&)>& shapeIndex) const;
  /// @brief Restores what saveState wrote into a world built from the same
  /// definition, planes, tools and effects (same order). The next step then
  /// equals the saved world's next step bit for bit.
  /// @note Throws std::runtime_error when the state does not fit this world
  /// (other effects, tools or planes) or is truncated.
  void loadState(StateReader& in,
                 const std::function<std::shared_ptr<const geometry::Shape<D>>(std::uint32_t)>& shapeAt);

  // ---- state ----
  /// @brief The particles, read-only: the set changes only through
  /// addParticle, removeParticle, replace and setStrength, so that ids,
  /// contact history, broad phase, stiffness cache, time step and energy
  /// ledger stay consistent.
  const Particles<D>& particles() const { return particles_; }
  /// @brief The particles' force and torque accumulators, for force effects
  /// (Effect::applyForces), which add to them.
  std::span<Vec<D>> forces() { return particles_.force; }
  std::span<Spin<D>> torques() { return particles_.torque; }
  /// @brief Books work done on the particles by a field force (gravity), J.
  void addGravityWork(double joules) {
    if (def_.energyLedger) energy_.gravityWork += joules;
  }
  double time() const { return time_; }
  double dt() const { return dt_; }
  /// @brief The critical time step of the current particles (s).
  double criticalDt() const { return dtCritical_; }
  /// @brief What sets criticalDt() (meaningful once a particle is in).
  const TimeStepLimit& timeStepLimit() const { return limit_; }
  /// @brief Every change of dt() so far, the first included (the automatic
  /// step only falls; a user step changes once).
  const std::vector<TimeStepChange>& timeStepChanges() const { return dtChanges_; }
  /// @brief Particle i's true mass, kg: its mass without density scaling.
  double unscaledMass(std::size_t i) const;
  /// @brief Particle i's density scaling factor (1: not scaled).
  double densityScale(std::size_t i) const;
  /// @brief What the density scaling did (all zero without it).
  const DensityScalingStats& densityScaling() const { return scalingStats_; }
  /// @brief Particle i's density scaling as decided (0: not decided: not a
  /// small fragment, or no scaling), for a copy of the particle elsewhere.
  double decidedDensityScale(std::size_t i) const;
  /// @brief Gives particle i the decision `factor` (decidedDensityScale; 0:
  /// none) without touching its mass: a distributed run's mirror or view of
  /// a particle, whose mass came with it as its owner scaled it.
  void setDecidedDensityScale(std::size_t i, double factor);
  /// @brief Hands out no id below `next` from now on (a view of a
  /// distributed run: the run's next free id, past particles it never held).
  void reserveIdsBelow(ParticleId next) { particles_.reserveIdsBelow(next); }
  /// @brief Sets what the density scaling did (a view of a distributed run:
  /// the run's totals).
  void setDensityScalingStats(const DensityScalingStats& stats) { scalingStats_ = stats; }
  std::uint64_t steps() const { return steps_; }
  const WorldDef<D>& def() const { return def_; }
  const ContactSolver<D>& contacts() const { return contacts_; }
  /// @brief True when contacts() describes the particles as they are: false
  /// after particles were added, removed or replaced (breakage) since the last
  /// force evaluation, until the next step (contact records then hold stale
  /// particle indices).
  bool contactsCurrent() const { return forcesValid_; }
  const BroadPhase<D>& broadPhase() const { return broad_; }
  const std::vector<ToolDef<D>>& tools() const { return tools_; }
  const std::vector<ToolPose<D>>& toolPoses() const { return toolPoses_; }
  /// @brief The tools' poses at the checkpoint's time as the checkpointed run
  /// had them (loadState; empty before a load, and after a load of a state
  /// saved before they were kept). A resume whose tools' motions put a tool
  /// elsewhere then (an edited motion, forced) would move it at once.
  const std::vector<ToolPose<D>>& savedToolPoses() const { return savedToolPoses_; }
  const std::vector<Plane<D>>& planes() const { return planes_; }
  const std::vector<std::string>& planeNames() const { return planeNames_; }
  /// @brief Loads of the particles on planes and tools from the last step.
  const BoundaryLoads<D>& boundaryLoads() const { return loads_; }
  /// @brief Replaces the loads of the last step: a distributed run sets the
  /// loads summed over its ranks (parallel/DistributedWorld.h), which a servo
  /// platen reads at the next step. The sizes must be those of the planes
  /// and tools.
  void setBoundaryLoads(const BoundaryLoads<D>& loads);
  /// @brief The energy budget. Its kinetic and elastic energy are those of
  /// the state now, worked out at the first read after a change (a step, a
  /// change of the particles); the other terms are booked as the steps go.
  /// Without the ledger (WorldDef::energyLedger) those are 0. A part of a
  /// distributed run holds its share of the run's budget (setGhost).
  const EnergyLedger& energy() const {
    if (!energyCurrent_) refreshEnergy();
    return energy_;
  }
  /// @brief The run's energy scale (EnergyLedger::scale), J, against which
  /// breakage checks a split's energy: this world's; a part of a distributed
  /// run holds the whole run's as of its last split (setRunEnergyScale).
  double energyScale() const { return coordinator_ && runEnergyScale_ > 0.0 ? runEnergyScale_ : energy().scale(); }
  /// @brief Sets energyScale() of a part of a distributed run (its coordinator, after each split).
  void setRunEnergyScale(double joules) { runEnergyScale_ = joules; }
  /// @brief A part of a distributed run: the energy of the springs of split
  /// `parent`'s fragments on the new set, J, summed over the run (what
  /// breakage's energy check counts as a split's fragment springs); NaN for
  /// a parent not in the last batch of splits.
  double runFragmentSprings(ParticleId parent) const;
  /// @brief Sets runFragmentSprings, by parent id (its coordinator, after each batch of splits).
  void setRunFragmentSprings(std::vector<std::pair<ParticleId, double>> springs);
  /// @brief The terms of energy() booked as the run goes (work, losses,
  /// energy removed and added, splitRelease, initial), with the kinetic and
  /// elastic energy 0: what the parts of a distributed run sum.
  EnergyLedger bookedEnergy() const;
  /// @brief Sets the booked terms to those of `booked` (its kinetic and
  /// elastic energy are not read: energy() works them out from the state). A
  /// distributed run's view shows the sum of its parts'.
  void setBookedEnergy(const EnergyLedger& booked);
  /// @brief Starts this world's ledger from nothing: every booked term 0, and
  /// the springs taken as storing nothing at the last evaluation (from which
  /// a re-evaluation between steps books splitRelease). A part of a
  /// distributed run spread from a world that had run (resumed): the first
  /// part keeps the run's ledger, the others start from nothing.
  void resetLedger();
  /// (In (time, id) order: each step's records sorted by id.)
  const std::vector<RemovedParticle>& removed() const { return removed_; }
  /// @brief Names of the effects that run, in order.
  std::vector<std::string> effectNames() const;
  /// @brief The effects, in the order they were added.
  std::span<const std::unique_ptr<Effect<D>>> effects() const { return effects_; }
  /// @brief Wall-clock seconds spent in each stage so far; effects are also
  /// reported one by one in effectSeconds().
  const std::array<double, std::size_t(Stage::Count)>& stageSeconds() const { return stageSeconds_; }
  const std::vector<double>& effectSeconds() const { return effectSeconds_; }
  /// @brief Total (true) mass of the particles now, kg.
  double particleMass() const;
  /// @brief Total mass removed so far, kg.
  double removedMass() const;

 private:
  void computeForces(double dtClosing);
  void moveKinematicBodies(double t);
  /// Re-estimates the critical step: over all particles, or folding in only
  /// the particle just added.
  void updateTimeStep(bool lastAddedOnly);
  /// Sets dt from dtCritical_ (automatic: safety x critical, never growing; user: checked).
  void stepFromCritical();
  void checkFinite() const;
  /// The effective stiffness of a shape's stiffest contact (N/m) and which
  /// contact it is (TimeStepLimit::boundary).
  struct ShapeStiffness {
    double stiffness = 0.0;
    std::int32_t boundary = -1;
    std::uint64_t patchNodes = 0;
  };
  /// The effective contact stiffness of a shape, from the cache when the
  /// shape is one it still holds. Entries are keyed by the live shape, not by
  /// its address alone: a fragment shape freed by breakage or removal can have
  /// its address reused by a new shape, and a stale hit would give the new
  /// shape the old one's stiffness (so the time step would depend on the
  /// allocator, and with it on which thread freed what).
  ShapeStiffness shapeStiffness(const std::shared_ptr<const geometry::Shape<D>>& shape);
  /// A boundary got its own material: forget the cached stiffnesses and re-check the step.
  void boundaryMaterialsChanged();
  /// Density scaling of particle i if it is a small fragment not yet decided
  /// (DensityScalingDef); books the kinetic energy it adds.
  void scaleDensity(std::size_t i);
  /// After a replacement: the reference (the whole run's, collective in a
  /// distributed run), then the new small fragments' factors; forgets the
  /// particles that left.
  void scaleNewFragments();
  /// The TimeStepLimit of particle i (its stiffness must be current).
  TimeStepLimit limitOf(std::size_t i) const;
  void refreshEnergy() const;
  // addParticle and addCopy: `books` the kinetic energy it brings (after the start).
  std::size_t insertParticle(const ParticleDef<D>& def, bool books);

  WorldDef<D> def_;
  Particles<D> particles_;
  BroadPhase<D> broad_;
  ContactSolver<D> contacts_;
  // removeParticle without the record: the particle set and its derived state.
  void dropParticle(std::size_t index);
  std::vector<ToolDef<D>> tools_;
  std::vector<ToolPose<D>> toolPoses_;
  std::vector<ToolPose<D>> savedToolPoses_;  // loadState's (savedToolPoses)
  std::vector<Plane<D>> planes_;
  std::vector<Plane<D>> planesAtStart_;
  std::vector<std::string> planeNames_;
  BoundaryLoads<D> loads_;
  std::vector<std::unique_ptr<Effect<D>>> effects_;
  std::vector<double> effectSeconds_;
  std::array<double, std::size_t(Stage::Count)> stageSeconds_{};

  // Time step: per particle effective contact stiffness (N/m), cached per shape.
  std::vector<ShapeStiffness> stiffness_;
  struct CachedStiffness {
    std::weak_ptr<const geometry::Shape<D>> alive;  ///< expired once the shape is freed
    ShapeStiffness stiffness;
  };
  // By the shape's address, valid only while `alive`.
  std::unordered_map<const geometry::Shape<D>*, CachedStiffness> shapeStiffness_;
  std::size_t stiffnessSweepSize_ = 0;  // cache size after the last sweep of expired entries
  double dt_ = 0.0;
  double dtCritical_ = std::numeric_limits<double>::infinity();
  TimeStepLimit limit_;                   // what sets dtCritical_
  std::vector<TimeStepChange> dtChanges_; // every change of dt_
  // Density scaling: the factor of each fragment decided so far, by global id
  // (1 for a fragment left alone); empty without the option.
  std::map<std::uint64_t, double> densityScales_;
  DensityScalingStats scalingStats_;

  // Scratch for the broad phase.
  std::vector<double> radii_;
  // Ghost flags (setGhost), aligned with particles_; empty: no ghosts.
  std::vector<std::uint8_t> ghost_;
  // The candidate pairs evaluated, when not all are: without those of two
  // ghosts (with ghosts), and only those among `onlyPairs_` (showRunOf).
  std::vector<std::array<std::uint32_t, 2>> evaluatedPairs_;
  std::optional<std::span<const std::array<ParticleId, 2>>> onlyPairs_;

  // A distributed run (setCoordinator): null in a world of its own.
  ParticleSetCoordinator* coordinator_ = nullptr;
  bool coordinatedThisStep_ = false;  // replace() took part in this effect's collective calls
  bool replaceAllowed_ = false;       // an effect that replaces particles (Effect::replacesParticles) runs
  std::vector<SplitRequest> splitRequests_;
  std::vector<SplitIds> splitIds_;
  std::vector<BornParticle> born_;
  // While an effect that changes particles runs (Effect::changesParticles):
  // the particle set changed here, and the ids of the particles it added.
  bool effectChanged_ = false;
  std::vector<ParticleId> effectAdded_;
  // The rest of a step's collective calls once the run's batch is known (not
  // empty): the run's time step, then the mirrors.
  void finishCoordination(std::size_t dtChangesBefore, double dtBefore);
  // A distributed run: effect.afterStep, then the collective calls every
  // world makes after it (the replacement batch, the other changes).
  void afterStepCoordinated(Effect<D>& effect);

  double time_ = 0.0;
  std::uint64_t steps_ = 0;
  bool forcesValid_ = false;
  bool keepForces_ = false;  // keepForces(): the next beginStep does not evaluate the forces
  mutable EnergyLedger energy_;      // its kinetic and elastic energy: a cache refreshed when read
  mutable bool energyCurrent_ = false;  // that cache is of the state now
  // The ledger's damping, dashpot and boundary work follow the trapezoid rule in
  // time. Forces evaluated at the end of a step act through the closing half
  // kick of that step and the opening half kick of the next, so each half kick
  // books its half of their power: the closing half when the forces are
  // computed, the opening half at the start of the next step. Between the two
  // the particle set may change (breakage, removal) and the forces be
  // re-evaluated; the opening half then books the power of the forces that
  // really act. Booking a whole sample at once ran half a step ahead of the
  // state it is compared with, and a contact's first step (an impact: a large
  // dashpot power) showed as energy from nothing.
  // Powers of the last force evaluation, W: damping effects, moving
  // boundaries (on the particles).
  std::array<double, 2> lastPower_{};
  // The energy the contact springs of the last evaluation store, J: those
  // of the pairs whose lower-id particle is not a ghost (setGhost). What a
  // re-evaluation between steps books splitRelease from.
  double evaluatedElastic_ = 0.0;
  double runEnergyScale_ = 0.0;  // setRunEnergyScale
  std::vector<std::pair<ParticleId, double>> runFragmentSprings_;  // setRunFragmentSprings, by parent id
  // With ghosts: the loads of this world's own particles on planes and
  // tools (scratch of bookClosing).
  BoundaryLoads<D> ownLoads_;
  // Books a half kick's work into `into` (energy_, or keptOpening_).
  void bookHalfKick(double halfDt, double lead, EnergyLedger& into) const;
  // keepForces: the opening half kick's work, booked by the next beginStep.
  EnergyLedger keptOpening_;
  // The closing half of the ledger's booking after a force evaluation.
  void bookClosing(double dtClosing);
  std::vector<RemovedParticle> removed_;
};

extern template class World<2>;
extern template class World<3>;

}  // namespace lsdem::dynamics
