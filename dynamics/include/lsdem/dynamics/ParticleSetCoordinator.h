#pragma once
/// @file ParticleSetCoordinator.h
/// @brief The hook through which the worlds of one run spread over several
/// processes agree on a change of the particle set (a distributed run,
/// parallel/DistributedWorld.h; docs/parallel.md "Breakage across ranks").
///
/// A world holds part of the run (its own particles and mirrors of others').
/// When an effect replaces particles (breakage: World::replace), the run's
/// global ids, its time step and every world's mirrors must come out as in
/// one world holding everything. World::replace hands its batch to the
/// coordinator, which agrees with the other worlds; a world that replaced
/// nothing takes part with an empty batch right after the same effect
/// (Effect::replacesParticles; World::finishStep), so every world makes the
/// same collective calls in the same order. Effects
/// that remove or add particles otherwise (outflow, feeds) change them in
/// every world alike (a world removes its mirrors of the particles that
/// leave: their owner records them) and agree after they ran
/// (effectChangedParticles). A world without a coordinator (a serial run)
/// never calls one and pays nothing.
///
/// No MPI here: the distributed implementation lives in parallel/.

#include <cstdint>
#include <span>
#include <vector>

namespace lsdem::dynamics {

struct TimeStepLimit;

/// One split of a world's batch, as World::replace announces it.
struct SplitRequest {
  std::uint64_t parent = 0;    ///< global id of the particle that leaves
  std::uint64_t fines = 0;     ///< removal records it makes (Replacement::fines)
  std::uint64_t children = 0;  ///< particles that enter (Replacement::children)
};

/// The global ids of one split: its fines take [firstFine, firstFine + fines)
/// and its children [firstChild, firstChild + children), in order.
struct SplitIds {
  std::uint64_t firstFine = 0;
  std::uint64_t firstChild = 0;
};

/// How a child's contacts start (breakage: springs born relaxed,
/// ContactSolver::markNewborn and inheritRestOverlap; NarrowPhase.h).
struct ChildBirth {
  /// A rest overlap the child takes over from its parent: of its own node
  /// (childOwns; key = the partner: a particle id or a plane / tool key), or
  /// of another particle's node inside it (key = that particle's id).
  struct Rest {
    std::uint64_t key = 0;
    std::uint32_t node = 0;
    double restOverlap = 0.0;  ///< m
    bool childOwns = true;
  };
  std::vector<std::uint32_t> newFaceNodes;  ///< its nodes on the cut (markNewborn)
  std::vector<Rest> rests;
};

/// A particle a world's replace() just added, for the coordinator.
struct BornParticle {
  std::uint64_t id = 0;
  const ChildBirth* birth = nullptr;  ///< how its contacts start; null: as any particle's
};

class ParticleSetCoordinator {
 public:
  virtual ~ParticleSetCoordinator() = default;
  /// @brief Collective, once per step and replacing effect in every world
  /// (Effect::replacesParticles): the global ids of this
  /// world's splits. The run's splits are numbered as one world would number
  /// them (World::replace): in ascending parent id, first every fine of every
  /// split, then every child.
  /// @param batch this world's splits, in ascending parent id (may be empty).
  /// @param ids filled, aligned with `batch`.
  /// @return The number of splits in the whole run this step (0: the run's
  /// particle set did not change, and nothing else is called this step).
  virtual std::uint64_t allocateIds(std::span<const SplitRequest> batch, std::vector<SplitIds>& ids) = 0;
  /// @brief Collective, after a step whose run batch was not empty: the run's
  /// time step, the smallest of the worlds' `dt` (s), and in `limit` what
  /// sets it (each world passes what sets the critical step of the particles
  /// it owns; the run's is the one first in setsStepBefore's order).
  virtual double agreeTimeStep(double dt, TimeStepLimit& limit) = 0;
  /// @brief Collective, after agreeTimeStep: brings every world's mirrors up
  /// to the new set (particles that left leave, `born` and their births
  /// reach the worlds that need them), then has each world evaluate its
  /// contacts on the new set (World::refreshContacts) and gives it the run's
  /// energy scale (World::setRunEnergyScale). May reorder this world's
  /// particles.
  virtual void particlesReplaced(std::span<const BornParticle> born) = 0;

  /// @brief Collective: the largest of the worlds' `here`. For what is
  /// decided from the whole run's particles: whether a feed's drop point is
  /// free (World::anyWorld), the density scaling's reference.
  virtual double largest(double here) = 0;
  /// @brief The run's next free global id, for a particle that an effect
  /// adds in every world alike (a feed). Not collective: every world asks
  /// in the same order and gets the same id.
  virtual std::uint64_t takeId() = 0;
  /// @brief Collective, after an effect that changes the particle set other
  /// than through World::replace (Effect::changesParticles: outflow, feeds)
  /// ran in every world. `changed`: this world's set changed; `added`: the
  /// ids of the particles the effect added here (every world added them
  /// alike). Each added particle stays where it is owned, and as a mirror
  /// where it is in reach; the other worlds drop it. When any world's set
  /// changed, every world's mirrors are brought up to date.
  /// @return Whether any world's set changed: every world then evaluates its
  /// contacts again, as one world does after a change.
  virtual bool effectChangedParticles(bool changed, std::span<const std::uint64_t> added) = 0;
};

}  // namespace lsdem::dynamics
