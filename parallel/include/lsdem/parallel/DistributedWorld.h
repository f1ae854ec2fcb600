#pragma once
/// @file DistributedWorld.h
/// @brief A world spread over MPI ranks by spatial domain decomposition
/// (docs/parallel.md).
///
/// Each rank holds a World<D> with the particles it owns (centroid in its
/// subdomain, Decomposition) and ghosts: mirrors of other ranks' particles
/// within reach of its subdomain, reach_i = r_i + r_max + skin (r: bounding
/// radii, r_max the largest in the run; in breakage runs the skin is at least
/// 4 cells of the coarsest grid, what a split looks at around its grain), so
/// every particle that can touch an owned one is present. A step is
///
///     world.beginStep()        half kick and drift of every local particle
///     exchange()               owners send poses and velocities to the ranks
///                              in reach (ghosts), and particles that left
///                              their subdomain to their new owner with their
///                              contact history: one message to and from each
///                              neighbouring subdomain (an all-to-all only when
///                              a particle must go farther, after a rebalance)
///     world.finishStep()       forces, closing half kick, clock
///
/// A pair with a ghost is computed on both ranks; each keeps the force on
/// its own particle (the pair law is symmetric in its inputs, so both get
/// the same numbers). Pairs of two ghosts are not computed (World::setGhost). The force on an owned particle is then the sum of the
/// same pair forces in the same order as in one world (the broad phase sorts
/// pairs by global id), so a distributed run equals the serial one bit for
/// bit. Ghosts are moved by their owners: what the local integrator does to
/// them is overwritten by the next exchange.
///
/// Shapes travel by content hash (FNV-1a of their binary grain form): a rank
/// sends a shape to another rank once, the first time one of its particles
/// is sent there; shapes every rank built from the scene are never sent.
///
/// Breakage (docs/parallel.md "Breakage across ranks"): each rank breaks its
/// own particles only (their grain stresses come from contacts it computes
/// whole). The rank's world is coordinated through this object
/// (dynamics::ParticleSetCoordinator): once per step every rank joins one
/// all-reduce of its split count and, when any rank split, an all-gather of
/// the splits (parent id, fines, children), so fragment and fines ids are
/// those one world would give (ascending parent id, fines
/// first); after a step with splits anywhere, the ranks take the smallest
/// time step and exchange at once (an extra exchange between steps), so
/// parents' mirrors leave, fragments' mirrors arrive (shapes once by hash)
/// with how their contacts start (new-face nodes, inherited rest overlaps),
/// a fragment whose centroid lies in another subdomain goes to its owner,
/// and every rank re-evaluates its contacts once, as one world does. A
/// breakage run equals the serial one bit for bit (tests/parallel/
/// test_breakage.cpp). gatherRemoved(), particleMass() and
/// gatherBreakageEvents() (BreakageLog.h) give the run's fines, mass balance
/// and breakage log.
///
/// Servo platens move by the load of the whole run: after each step every
/// rank sums the records of all ranks' own particles on the planes and tools
/// in the order one world does (boundaryLoads) and gives the sum to its
/// world (World::setBoundaryLoads), which the servo reads at the next step.
///
/// Outflow and feeds change the particle set alike on every rank
/// (ParticleSetCoordinator::effectChangedParticles): a particle that leaves
/// the outflow's box is removed by its owner, which records it, and by every
/// rank that mirrors it; a feed decides from the whole run whether its drop
/// point is free (one all-reduce per step), every rank adds the grain with
/// the run's next id, and it stays with its owner and where it is in reach.
/// After a change anywhere every rank exchanges at once and evaluates its
/// contacts again, as one world does.
///
/// Effects: a world's effects must declare Effect::distributable() (the
/// built-in ones do); the constructor refuses another, naming it.
///
/// Balance: the cuts are rebuilt when the most loaded rank's load passes
/// DistributedDef::rebalanceImbalance times the mean, the load being its
/// particles' surface nodes, or (Balance::Time) the wall time of its own
/// work (ExchangeStats::workSeconds). The cuts never change the motion.
///
/// Density scaling: after a batch of splits every rank takes the run's
/// reference (one all-reduce), scales its own new small fragments, and a
/// fragment's factor travels with it in every particle record.
///
/// The energy ledger: each rank's world books the terms of its own
/// particles and of the pairs whose lower-id particle is its own
/// (World::setGhost); the run's budget is their sum (energy(), and a view's
/// ledger). A breakage event's fragment springs (its energy check) are
/// summed over the ranks by the same rule after each batch of splits.

#include "lsdem/breakage/Breakage.h"
#include "lsdem/dynamics/World.h"
#include "lsdem/parallel/Decomposition.h"

#include <mpi.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <span>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace lsdem::parallel {

struct DistributedDef {
  /// What a rank's load is, for the decomposition.
  enum class Balance {
    /// The surface nodes of the particles it owns (the same cuts in every
    /// run of a scene).
    Nodes,
    /// The wall time of its own work since the last check (the step less
    /// the time it waited for other ranks and exchanged), spread over its
    /// particles by their nodes: a rank on a slower core, or with a denser
    /// part of the bed, gets fewer nodes at the next rebalance. The cuts
    /// then differ from run to run; the results do not (docs/parallel.md).
    Time,
  };
  Balance balance = Balance::Nodes;
  /// Rebuild the decomposition when the most loaded rank's load exceeds
  /// this times the mean; 0: never.
  double rebalanceImbalance = 1.25;
  /// Steps between two checks of the imbalance.
  std::uint64_t rebalanceEvery = 200;
};

/// What the exchanges did so far, on this rank.
struct ExchangeStats {
  std::uint64_t steps = 0;
  std::uint64_t ghostsSent = 0;      ///< particle records sent as ghosts, summed over steps
  std::uint64_t migrations = 0;      ///< particles this rank handed to another owner
  std::uint64_t shapesSent = 0;
  std::uint64_t bytesSent = 0;
  std::uint64_t messagesSent = 0;    ///< non-empty messages to other ranks
  /// Exchanges with the neighbouring subdomains only (point to point), and
  /// those that needed every rank (an all-to-all: after a rebalance, or a
  /// particle out of its subdomain by more than a neighbour's range).
  std::uint64_t neighbourExchanges = 0;
  std::uint64_t globalExchanges = 0;
  std::uint64_t neighbours = 0;      ///< the neighbouring subdomains now
  std::uint64_t rebalances = 0;
  double seconds = 0.0;              ///< wall time in the exchanges
  /// Wall time of this rank's own work in its steps: the steps less the
  /// time in the exchanges and the other collectives of a step (where a
  /// rank waits for the others).
  double workSeconds = 0.0;
  double stepSeconds = 0.0;          ///< wall time of the steps
};

template <int D>
class DistributedWorld : private dynamics::ParticleSetCoordinator {
 public:
  using ParticleId = dynamics::ParticleId;

  /// One particle's motion state, for gather().
  struct ParticleState {
    ParticleId id = 0;
    Vec<D> position = Vec<D>::Zero();
    dynamics::Orientation<D> orientation = dynamics::Rotation<D>::identity();
    Vec<D> velocity = Vec<D>::Zero();
    dynamics::Spin<D> angularVelocity = dynamics::Rotation<D>::zeroSpin();
  };

  /// @brief Spreads `world` over the ranks of `comm`. Every rank passes a
  /// world built alike from the same scene (same particles, planes, tools,
  /// effects), or restored alike from the same checkpoint (a resumed run:
  /// any rank count can resume any run's checkpoint); each keeps its own
  /// particles and their ghosts and drops the rest. The world must outlive this object and be stepped only through it.
  /// The energy ledger of a world that had run (a resumed one) stays rank
  /// 0's, the other ranks' start from nothing (World::resetLedger); a
  /// resumed world's first step opens with the forces it holds
  /// (World::keepForces).
  /// @note Throws std::invalid_argument when the worlds differ between ranks
  /// or an effect does not declare Effect::distributable() (see the file comment).
  DistributedWorld(MPI_Comm comm, dynamics::World<D>& world, const DistributedDef& def = {});
  ~DistributedWorld() override;
  DistributedWorld(const DistributedWorld&) = delete;
  DistributedWorld& operator=(const DistributedWorld&) = delete;

  /// @brief Advances one step (collective: every rank calls it).
  void step();
  void run(std::uint64_t n);

  int rank() const { return rank_; }
  int ranks() const { return ranks_; }
  const DistributedDef& def() const { return def_; }
  /// @brief This rank's world: its own particles and its ghosts.
  const dynamics::World<D>& world() const { return world_; }
  /// @brief Whether local particle `index` is this rank's own (else a ghost).
  bool owned(std::size_t index) const { return !world_.isGhost(index); }
  /// @brief Particles this rank owns.
  std::size_t ownedCount() const;
  /// @brief Particles of the whole run (collective).
  std::uint64_t globalCount() const;
  const Decomposition<D>& decomposition() const { return decomposition_; }
  const ExchangeStats& stats() const { return stats_; }
  /// @brief How many times the run's particle set changed so far (a batch of
  /// splits, or a removal or an addition by an effect, on any rank): the same
  /// on every rank.
  std::uint64_t particleSetChanges() const { return particleSetChanges_; }
  /// @brief The loads of the particles on planes and tools of the whole run
  /// (collective): the same numbers on every rank, summed in the order one
  /// world sums them while its particles are in id order (bit for bit the
  /// serial loads; at round-off after splits).
  dynamics::BoundaryLoads<D> boundaryLoads() const;
  /// @brief Every particle's state, sorted by id, on rank `root` (empty on
  /// the others; collective).
  std::vector<ParticleState> gather(int root) const;
  /// @brief Every removal record of the run (breakage fines, outflow), sorted by
  /// (time, id) as one world records them, on rank `root` (empty on the
  /// others; collective). `from`: leave out the first `from` records of each
  /// rank (those every rank held at the start of a resumed run).
  std::vector<dynamics::RemovedParticle> gatherRemoved(int root, std::size_t from = 0) const;
  /// @brief The run's energy budget, on every rank (collective): the ranks'
  /// ledgers (World::energy, each of its own particles and pairs: setGhost)
  /// summed in rank order; to round-off one world's.
  dynamics::EnergyLedger energy() const;
  /// @brief The true mass of the run's particles, kg, summed over the ranks
  /// (collective; to round-off the serial World::particleMass, another order).
  double particleMass() const;
  /// @brief The run's breakage log: every rank's events of `effect` (this
  /// rank's world's Breakage), sorted by (time, parent id) as one world
  /// applies them, on rank `root` (empty on the others; collective).
  std::vector<breakage::BreakageEvent<D>> gatherBreakageEvents(const breakage::Breakage<D>& effect, int root) const;
  /// @brief The run's breakage log and totals into `into` on rank `root`
  /// (Breakage::mergeLogs of every rank's `effect`, each started from `base`;
  /// collective).
  void gatherBreakage(const breakage::Breakage<D>& effect, const breakage::Breakage<D>& base,
                      breakage::Breakage<D>& into, int root) const;
  /// @brief Brings `view` up to the whole run now, on rank `root`: a world
  /// built from the same scene that nothing steps, which a run's outputs read
  /// (docs/parallel.md "lsdem run on N ranks"). Every rank sends its own
  /// particles with their contact history (their shapes once, by hash) and
  /// the pairs in contact; the view's particles no longer in the run leave
  /// it, the others take the run's state, new ones enter in ascending id;
  /// then World::showRunOf evaluates their contacts as the ranks did, the
  /// pairs in contact only. Collective; `view` is touched on `root` only.
  void updateView(dynamics::World<D>& view, int root);

 private:
  // Sends every owned particle to the ranks in reach (and to its new owner);
  // `born`: particles just born here, whose births go along.
  void exchange(std::span<const dynamics::BornParticle> born = {});
  // dynamics::ParticleSetCoordinator (breakage runs only).
  std::uint64_t allocateIds(std::span<const dynamics::SplitRequest> batch,
                            std::vector<dynamics::SplitIds>& ids) override;
  double agreeTimeStep(double dt, dynamics::TimeStepLimit& limit) override;
  void particlesReplaced(std::span<const dynamics::BornParticle> born) override;
  double largest(double here) override;
  std::uint64_t takeId() override;
  bool effectChangedParticles(bool changed, std::span<const std::uint64_t> added) override;
  void rebalance();
  // Local particle `i`, which this rank holds as its own: stays so when its
  // centroid is in this rank's part, else becomes a ghost when in reach or
  // leaves (a new world's particles, a feed's grain).
  void place(std::size_t i);
  // Whether `here` holds on any rank (collective).
  bool anyRank(bool here);
  // The shapes of particles `list` that rank `q` lacks, into `w` (then q holds them).
  void putShapes(dynamics::StateWriter& w, int q, std::span<const std::size_t> list);
  // Reads putShapes' shapes, sent by rank `q`.
  void getShapes(dynamics::StateReader& r, int q);
  // The shape of hash `hash` (particle `id` from rank `from`), received or built here.
  std::shared_ptr<const geometry::Shape<D>> receivedShape(std::uint64_t hash, ParticleId id, int from) const;
  void checkSameWorldEverywhere() const;
  // The neighbours of this subdomain: those within 2 (r_max + skin), the
  // same on every rank (decomposition_ and r_max are the run's).
  void updateNeighbours();
  // skin_ from the world's broad-phase skin (or 0.1 r_max), at least 4 of
  // the coarsest cells in a run that splits; the same on every rank (r_max
  // and the coarsest grid are the run's).
  void updateSkin();
  // Sends each neighbour its bytes (every neighbour gets one message, maybe
  // empty) and returns what each neighbour sent here (empty for the others).
  std::vector<std::vector<char>> neighbourExchange(const std::vector<dynamics::StateWriter>& out);
  std::uint64_t shapeHash(const std::shared_ptr<const geometry::Shape<D>>& shape);
  double reach(std::size_t index) const;
  // Local particle `index`'s bounding radius (the tricubic one when larger).
  double radius(std::size_t index) const;
  // After a split on another rank, this rank's contacts wait for its next
  // evaluation: evaluates them now, on the same state (nothing that follows
  // changes; one world evaluated them at once).
  void refreshStaleContacts();
  // The run's loads (boundaryLoads) into this rank's world, for its servo
  // platens (collective).
  void reduceLoads();
  // Every rank's `bytes`, in rank order, on rank `root` (empty on the
  // others), or on every rank for kAllRanks (collective).
  static constexpr int kAllRanks = -1;
  std::vector<std::vector<char>> gatherBytes(const std::vector<char>& bytes, int root) const;
  // Local particle `index`'s cost in the decomposition: its surface nodes (at least 1).
  double weight(std::size_t index) const;
  // Counts the wall time of its scope, a collective of the step, as waited
  // (not this rank's work, ExchangeStats::workSeconds); one inside another
  // counts once.
  class Waiting {
   public:
    explicit Waiting(DistributedWorld& w);
    ~Waiting();
    Waiting(const Waiting&) = delete;
    Waiting& operator=(const Waiting&) = delete;

   private:
    DistributedWorld& world_;
    std::chrono::steady_clock::time_point start_;
  };

  // A duplicate of the caller's communicator, this object's own (so the
  // exchange's point-to-point messages never meet the caller's), freed with
  // it, also when the constructor throws.
  struct OwnComm {
    MPI_Comm comm = MPI_COMM_NULL;
    explicit OwnComm(MPI_Comm from);
    ~OwnComm();
    OwnComm(const OwnComm&) = delete;
    OwnComm& operator=(const OwnComm&) = delete;
  };
  OwnComm ownComm_;
  MPI_Comm comm_;
  dynamics::World<D>& world_;
  DistributedDef def_;
  int rank_ = 0, ranks_ = 1;
  Decomposition<D> decomposition_;
  // The subdomains within neighbourRange_ of this one (ascending; flags by
  // rank), for decomposition_ and the range they were found for
  // (updateNeighbours).
  std::vector<int> neighbours_;
  std::vector<std::uint8_t> isNeighbour_;
  double neighbourRange_ = -1.0;
  bool decompositionChanged_ = true;
  double largestRadius_ = 0.0;       // r_max
  double skin_ = 0.0;                // grows with r_max and the coarsest grid (updateSkin), never shrinks
  double coarsestSpacing_ = 0.0;     // the coarsest grid spacing in the run so far
  bool breaks_ = false;              // an effect splits particles (the skin covers 4 of the coarsest cells)
  std::uint64_t particleSetChanges_ = 0;  // particleSetChanges()
  double waitedSeconds_ = 0.0;       // in the step's collectives so far (Waiting)
  int waitingDepth_ = 0;             // Waiting scopes open now
  double workAtCheck_ = 0.0;         // stats_.workSeconds at the last check of the balance
  double speed_ = 0.0;               // Balance::Time: nodes per second of own work, last measured (0: never)
  bool servo_ = false;               // a tool is a servo platen: its load is the run's (reduceLoads)
  bool loadsReduced_ = false;        // the world's loads are the run's for its contacts now
  bool coordinated_ = false;         // the world changes its particle set (breakage, outflow, feeds): world_.setCoordinator(this)
  dynamics::ParticleId nextId_ = 0;  // the run's next free global id (coordinated runs)
  // The last batch of splits (allocateIds), in ascending parent id: each
  // split's parent and first child id; its children end at batchEnd_.
  std::vector<dynamics::ParticleId> batchParents_, batchFirstChild_;
  dynamics::ParticleId batchEnd_ = 0;
  // Shapes by content hash, and the hash of each shape this rank holds.
  std::unordered_map<std::uint64_t, std::shared_ptr<const geometry::Shape<D>>> shapes_;
  // By the shape's address, valid only while `alive` (breakage frees shapes,
  // and a new one can take a freed one's address).
  struct HashedShape {
    std::uint64_t hash = 0;
    std::weak_ptr<const geometry::Shape<D>> alive;
  };
  std::unordered_map<const geometry::Shape<D>*, HashedShape> hashOf_;
  // The shapes each rank is known to hold (built from the scene, or sent).
  std::vector<std::unordered_set<std::uint64_t>> shapesAt_;
  ExchangeStats stats_;
  // The velocities of the local particles the last step evaluated its forces
  // with; empty when the particles changed since (a split evaluates again).
  std::vector<Vec<D>> forceVelocity_;
  std::vector<dynamics::Spin<D>> forceSpin_;
};

extern template class DistributedWorld<2>;
extern template class DistributedWorld<3>;

}  // namespace lsdem::parallel
