#pragma once
/// @file NarrowPhase.h
/// @brief The narrow phase and contact forces (eq. 3-4): surface nodes of one
/// body tested against the level set of the other, then the contact law
/// (ContactLaw.h) turned into per-node and per-pair forces, with the persistent
/// shear history friction needs.
///
/// Contact test (eq. 3): a surface node p of one body touches the other body
/// when phi_other(p) < 0; the overlap is -phi and the normal is the normalised
/// gradient of phi_other (eq. 4), pointing out of the other body. The contact
/// point is the node's world position.
///
/// Order independence of particle pairs. The paper tests the nodes of one
/// ("master") body against the level set of the other ("slave"); which body is
/// the master then changes the answer (a sharp corner pressed into a face is
/// seen by the corner's nodes, not by the face's). lsdem tests both directions
/// and weights each direction's node forces by 1/2: swapping the two bodies
/// swaps the two halves, so the forces come out equal and opposite to round-off,
/// and two identical bodies in symmetric contact get the total stiffness of a
/// one-sided test (each direction sees the same overlap, half the stiffness).
///
/// Boundaries are one-sided with weight 1: planes (exact, a dot product per
/// node) and kinematic level-set bodies (tools), whose level set the particle's
/// nodes are tested against. Tools are large (a jaw, a bucket), so their level
/// set resolves the contact geometry well, and their node counts are large, so
/// testing them against every nearby particle would cost far more than the
/// particle's nodes against the tool.
///
/// Cost. Per pair and direction the node owner's body frame is mapped to the
/// other body's grid frame by one composed rigid map (the other shape's
/// bodyToGrid, the inverse of its pose, the owner's pose). Bulk rejection
/// first: the owner's node tree (NodeTree.h, spheres over groups of nodes) is
/// walked from the root, and a cell whose sphere misses the other body's
/// bounding sphere or grid box, or lies wholly outside the other body by its
/// level set (phi at the centre > Shape::levelSetSlope() x radius), is skipped
/// with every node in it; against a plane, one dot product per cell. Walks
/// that found nothing, and the parts of walks that rejected, are not repeated
/// while the bodies have moved less than the margin they measured
/// (separation certificates; down to single nodes of the leaves kept, see
/// Certificate); once they have moved more, only the rejected cells whose
/// own margins the move used up (or one more move as large would) are
/// walked again (frontier walks). Only the
/// nodes of the leaves that remain are tested one by one: one D x D
/// matrix-vector product, a bounding-sphere test, a grid-box test and, only
/// for nodes near the other body, one multilinear look-up. A walk of the
/// tree (a whole walk, or the frontier cells walked again) goes level by
/// level in batches: a level's cells get their sphere and box tests, then
/// the survivors their look-ups, then the passed leaves' nodes likewise, in
/// loops that write every item and count the survivors instead of branching
/// on each outcome, so that the look-ups of a batch overlap. The test is exact,
/// so the contacts are those of testing every node; they are put back in node
/// order, so forces and sums are bitwise the same. The law's parts (normal model, formulation, friction, damping) are
/// template parameters of the kernel, chosen once per compute() call, so a part
/// the scene does not declare costs nothing per node.
///
/// Determinism. Pairs run in parallel (OpenMP); each pair writes only its own
/// records (node contacts go to per-thread buffers and are concatenated in
/// pair order afterwards, when first read), and accumulate() sums forces into
/// particles in pair order, so results are bitwise identical for any number
/// of threads.

#include "lsdem/dynamics/Contact.h"
#include "lsdem/dynamics/ContactLaw.h"
#include "lsdem/dynamics/Particles.h"
#include "lsdem/dynamics/State.h"
#include "lsdem/dynamics/Wall.h"
#include "lsdem/geometry/NodeTree.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <memory>
#include <mutex>
#include <span>
#include <type_traits>
#include <vector>

namespace lsdem::dynamics {

/// Total contact loads on the boundaries this step (what a platen servo or a
/// recorder reads), world frame.
template <int D>
struct BoundaryLoads {
  std::vector<Vec<D>> planeForce;   ///< force of the particles on each plane, N
  std::vector<Spin<D>> planeTorque; ///< torque of the particles on each plane about Plane::point, N m
  std::vector<Vec<D>> toolForce;    ///< force of the particles on each tool, N
  std::vector<Spin<D>> toolTorque;  ///< torque of the particles on each tool about ToolPose::position, N m
};

/// @brief The radius about a shape's centroid within which a node of
/// another body can find it inside (world units): the bounding sphere of its
/// level set as the narrow phase reads it, Shape::boundingRadius() for the
/// multilinear look-up, Shape::cubicBoundingRadius() for the tricubic one.
/// The broad phase's radius and the narrow phase's sphere tests.
template <int D>
double lookupRadius(const geometry::Shape<D>& shape, LevelSetInterpolation interpolation) {
  return interpolation == LevelSetInterpolation::Tricubic ? shape.cubicBoundingRadius() : shape.boundingRadius();
}

/// The contact dashpot's part of one PairContact (pairDashpots() is aligned
/// with pairContacts()): what the energy ledger needs to book the dashpot's
/// work exactly (World.h), since the dashpot's force depends on the velocity.
template <int D>
struct PairDashpot {
  Vec<D> force = Vec<D>::Zero();              ///< dashpot force on a, N (b gets -force), world frame
  Spin<D> torqueA = Rotation<D>::zeroSpin();  ///< its torque on a about a's centroid, N m
  Spin<D> torqueB = Rotation<D>::zeroSpin();  ///< particle pairs: torque of -force on b about b's centroid, N m (0 for boundaries)
  double power = 0.0;          ///< sum over nodes of c_i v_n^2 at the sampled velocities, W (part of dissipatedPower)
  double boundaryPower = 0.0;  ///< plane and tool pairs: sum over nodes of the node's dashpot force . the boundary's velocity there, W (0 for particle pairs)
};
// No padding: written raw to checkpoints (State.h).
static_assert(sizeof(PairDashpot<2>) == 6 * sizeof(double));
static_assert(sizeof(PairDashpot<3>) == 11 * sizeof(double));

namespace detail {

/// Per-node working values of the contact solver (internal): what the law
/// reads besides the NodeContact, dropped after the step.
template <int D>
struct NodeWork {
  double stiffness = 0.0;          ///< stiffness factor: direction weight x (1 | w_i / w_ref); k_i = kn x this
  double area = 0.0;               ///< direction weight x node weight w_i (m in 2D, m^2 in 3D)
  double gradient = 1.0;           ///< |grad phi| of the other body's level set at the node (1 for planes)
  std::int64_t history = -1;       ///< its record in the pair's history, or -1
};

/// A tree leaf a certificate keeps (internal), with its margins: its
/// cell's, then its nodes' (the node tree's leaf size; a larger leaf's
/// further nodes have none), in cells of the other's grid, relative to the
/// certificate's map (Certificate; collectLevelSet in NarrowPhase.cpp). A
/// cell margin m > 0: the cell's test rejects it until a move of m; m < 0:
/// it passes until a move of -m; 0: test it. `leastNode` is the least of
/// its nodes' margins (0 when it has nodes without a slot, which are always
/// tested): while it holds, no node of the leaf is tested.
struct KeptLeaf {
  static constexpr std::uint32_t kNodeSlots = geometry::NodeTree<3>::kLeafSize;
  std::uint32_t cell = 0;
  float cellMargin = 0.0f;
  std::array<float, kNodeSlots> nodeMargin{};
  float leastNode = 0.0f;
};

/// A tree cell a certified walk rejected (internal; Certificate): how far
/// the owner may move, in cells of the other's grid and relative to the
/// certificate's map, before the cell's test could pass.
struct RejectedCell {
  std::uint32_t cell = 0;
  float margin = 0.0f;
};

/// A separation certificate (internal; ContactSolver::setSeparationCertificates):
/// when the composed map of the walk of `owner`'s nodes against `other`'s
/// level set (owner body -> other's grid cells) was (map, shift), the node
/// tree was covered by two lists (together every node once, in no set
/// order): the frontier (cells whose
/// test rejected them, `frontierCount` from `frontierFirst` of thread
/// `leafThread`'s frontier list, each with its margin) and the leaves kept
/// (`leafCount` from `leafFirst` of its leaf list, with their cells' and
/// nodes' margins). A margin is a lower bound of how far every point of
/// the cell (node) must move relative to that grid before its test could
/// pass. So while the owner has moved less than `restClearance` (the
/// frontier's least margin), testing the kept leaves finds every contact; a
/// leaf's cell or node whose margin exceeds the move cannot pass its test
/// either, and is not tested. Once it has moved more, only the frontier
/// cells whose margins it exceeds (or one more move as large would) are
/// walked again (a frontier walk: the
/// certificate is then re-made at the new map, with what was not tested
/// keeping its margin less the move). When the walk found no contact, no
/// node at all can reach the other before a move of `clearance` cells (0:
/// it found one) and the walk is spared. `ownerShape` null: no certificate.
template <int D>
struct Certificate {
  std::uint64_t owner = 0, other = 0;  ///< global ids, in the walk's direction
  const void* ownerShape = nullptr;    ///< the shapes it was made for
  const void* otherShape = nullptr;
  Mat<D> map = Mat<D>::Zero();
  Vec<D> shift = Vec<D>::Zero();
  double clearance = 0.0;      ///< cells of the other's grid
  double restClearance = 0.0;  ///< cells of the other's grid
  std::uint32_t leafThread = 0, leafFirst = 0, leafCount = 0;
  std::uint32_t frontierFirst = 0, frontierCount = 0;
  /// Entries (frontier and kept leaves) of the last whole walk: a frontier
  /// walk refines the lists and never coarsens them, so once they hold more
  /// than twice as many the tree is walked whole again.
  std::uint32_t wholeEntries = 0;
};

/// The allocator of the solver's record arrays (internal): a resize leaves
/// the new records unwritten where they are plain data (doubles, integers,
/// fixed-size Eigen vectors), because the solver resizes an array only to
/// fill it whole at once (gather() copies the runs of several threads in
/// parallel); writing zeros first would be one more pass over memory.
template <class T>
struct RecordAllocator : std::allocator<T> {
  template <class U>
  struct rebind {
    using other = RecordAllocator<U>;
  };
  RecordAllocator() = default;
  template <class U>
  RecordAllocator(const RecordAllocator<U>&) noexcept {}
  /// Without a value: nothing written (allocate() began the records' lifetime).
  template <class U>
  void construct(U* p) noexcept {
    static_assert(std::is_trivially_destructible_v<U> && std::is_standard_layout_v<U>, "records are plain data");
    (void)p;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};
template <class T>
using Records = std::vector<T, RecordAllocator<T>>;

/// Output buffers of one thread (internal); aligned so threads do not share
/// cache lines. The per-node outputs are the solver's own arrays' layout
/// (nodes, shear, preload, keys), so where one thread's buffers hold exactly
/// the first run of the output (every task ran on it, or it took the front
/// of the first part and nothing else), gather() swaps them in.
template <int D>
struct alignas(64) ThreadBuffers {
  Records<PairContact<D>> pairs;
  Records<PairDashpot<D>> dashpots;  ///< aligned with pairs
  Records<NodeContact<D>> nodes;
  Records<NodeWork<D>> work;             ///< aligned with nodes
  Records<Vec<D>> shear;                 ///< aligned with nodes: shear displacement after this step, world frame, m
  Records<double> preload;               ///< aligned with nodes: the spring's rest overlap (markNewborn), m
  Records<std::uint32_t> keys;           ///< aligned with nodes: their node keys (owner bit, node index)
  bool anyPreload = false;               ///< some preload is > 0
  std::uint64_t nodeChecks = 0;
  std::uint64_t cellChecks = 0;  ///< node-tree cells tested (bulk rejection)
  std::uint64_t certifiedWalks = 0;  ///< walks a separation certificate spared
  std::uint64_t leafWalks = 0;       ///< walks that tested only the leaves a certificate kept
  std::uint64_t frontierWalks = 0;   ///< walks that tested the kept leaves and part of a certificate's frontier
  /// The leaves and frontiers of the certificates made this step (and the
  /// last step's, read by any thread this step).
  std::vector<KeptLeaf> leaves, previousLeaves;
  /// (A rebasing walk grows the frontier by the old one's size and writes
  /// the entries it carries: Records leaves the resize unwritten.)
  Records<RejectedCell> frontier, previousFrontier;
  // Scratch of the walks made in batches (NarrowPhase.cpp): cell and node
  // lists, survivors, leaves, the points tested, margins and look-ups.
  std::vector<std::uint32_t> batchCells, batchLive, batchLeaves, batchNodes, batchOwners;
  std::vector<Vec<D>> batchPoints;
  std::vector<double> batchValues;
  /// The node-level records of this thread's runs that the output does not
  /// hold yet (ContactSolver::pending_, which says which; older ones where
  /// the last compute() left this thread none), swapped out of nodes /
  /// shear / preload / keys, so the next compute() writes its own there
  /// while reading these as its history.
  Records<NodeContact<D>> heldNodes;
  Records<Vec<D>> heldShear;
  Records<double> heldPreload;
  Records<std::uint32_t> heldKeys;
  // Scratch of sortByNode.
  std::vector<std::uint32_t> order;
  std::vector<NodeContact<D>> nodeScratch;
  std::vector<NodeWork<D>> workScratch;
};

/// A mutex that copies as a new one (internal): lets ContactSolver, which
/// holds one, stay copyable.
struct CopyLock {
  std::mutex mutex;
  CopyLock() = default;
  CopyLock(const CopyLock&) {}
  CopyLock& operator=(const CopyLock&) { return *this; }
};

/// Where one task's records went (internal): thread buffer ranges and output offsets.
struct TaskOutput {
  std::uint32_t thread = 0;
  std::uint32_t firstPair = 0, pairCount = 0;  ///< in the thread's buffer
  std::uint32_t firstNode = 0, nodeCount = 0;  ///< in the thread's buffer
  std::uint64_t outPair = 0, outNode = 0;      ///< in the solver's output
  std::uint32_t cost = 0;                      ///< tests made plus weighted records (ContactSolver::splitIntoBlocks)
};

/// The tasks of one part of a step's list not yet taken (internal;
/// ContactSolver::run): two threads share a part, one taking chunks of
/// consecutive tasks from its front, the other from its back, until they
/// meet. Front and back (one past the last) in one word, changed by
/// compare-and-swap.
struct alignas(64) TaskCursor {
  std::atomic<std::uint64_t> bounds{0};
  TaskCursor() = default;
  // (Scratch: a copy takes the value, so the solver stays copyable.)
  TaskCursor(const TaskCursor& other) : bounds(other.bounds.load(std::memory_order_relaxed)) {}
  TaskCursor& operator=(const TaskCursor& other) {
    bounds.store(other.bounds.load(std::memory_order_relaxed), std::memory_order_relaxed);
    return *this;
  }
  void reset(std::uint32_t front, std::uint32_t back) {
    bounds.store(std::uint64_t(front) | (std::uint64_t(back) << 32), std::memory_order_relaxed);
  }
  /// @brief Takes up to `chunk` (>= 1) tasks from the back or the front:
  /// their range [first, last), empty when none is left.
  std::array<std::uint32_t, 2> take(std::uint32_t chunk, bool fromBack) {
    std::uint64_t now = bounds.load(std::memory_order_relaxed);
    for (;;) {
      const std::uint32_t front = std::uint32_t(now), back = std::uint32_t(now >> 32);
      if (front >= back) return {0, 0};
      const std::uint32_t count = std::min(chunk, back - front);
      const std::array<std::uint32_t, 2> range = fromBack ? std::array{back - count, back}
                                                          : std::array{front, front + count};
      const std::uint64_t next = fromBack ? (std::uint64_t(front) | (std::uint64_t(back - count) << 32))
                                          : (std::uint64_t(front + count) | (std::uint64_t(back) << 32));
      if (bounds.compare_exchange_weak(now, next, std::memory_order_relaxed, std::memory_order_relaxed)) return range;
    }
  }
};

/// One pair's shear history (internal): key and its node contacts in the
/// previous step's output (nodeContacts(), nodeShear()).
struct HistoryPair {
  std::uint64_t idA = 0;    ///< global id of particle a
  std::uint64_t other = 0;  ///< global id of b, or a tagged plane / tool index
  std::uint32_t first = 0, count = 0;
};
static_assert(sizeof(HistoryPair) == 24);  // no padding: written raw to checkpoints (State.h)

/// A rest overlap a node contact found without history starts with
/// (internal; ContactSolver::markNewborn, inheritRestOverlap).
struct BirthNode {
  std::uint64_t id = 0;        ///< the node owner's global id
  std::uint64_t other = 0;     ///< the partner's history key (HistoryPair::other or a particle id); kAnyPartner: any
  std::uint32_t node = 0;      ///< node index in the owner's shape
  std::uint32_t reserved = 0;  ///< zero: no padding in checkpoints
  double restOverlap = 0.0;    ///< m; infinity: the overlap it is found with
};
static_assert(sizeof(BirthNode) == 32);
inline constexpr std::uint64_t kAnyPartner = ~std::uint64_t(0);

}  // namespace detail

/// @brief Finds the node contacts of particle pairs, particles and planes, and
/// particles and tools, and computes their forces with one contact law; owns
/// the shear history (friction) and all scratch buffers, so a step allocates
/// nothing once the buffers have grown to the problem's size.
///
/// Use per step: compute(...) at the new positions, then accumulate(particles)
/// (after zeroing the particles' forces and before the integrator's kick).
///
/// Shear history is keyed by (global id of a, global id of b | plane index |
/// tool index, owner side, node index), so it survives particles being removed
/// or reordered; a node contact that is absent in one step loses its history.
///
/// Springs born relaxed (markNewborn). A node on a fragment's new face can be
/// born inside another body (the cut runs through a contact). Its node
/// contact then starts with a rest overlap delta_0 = its overlap at birth, and
/// its spring acts on delta - delta_0 only; delta_0 follows the node out
/// (delta_0 = min(delta_0, delta) each step) and is gone when the contact
/// ends. So a split puts no energy into springs that did not exist before it
/// (docs/breakage.md, "Energy check"). The history is kept whenever a contact
/// carries a rest overlap, with or without friction.
/// Planes and tools are keyed by their index in the lists passed to compute(),
/// which must therefore keep their order between steps.
template <int D>
class ContactSolver {
 public:
  /// A candidate particle pair (indices into Particles), a = lower global id.
  using Pair = std::array<std::uint32_t, 2>;

  /// @brief A solver for one contact law.
  /// @note Throws std::invalid_argument for an invalid law (validateContactLaw).
  explicit ContactSolver(const ContactLawDef& law);

  /// @brief The law this solver applies.
  const ContactLawDef& law() const { return law_; }

  /// @brief Gives plane `index` (its place in the planes passed to compute())
  /// its own contact material; a plane without one meets the grains with the
  /// law's constants. @note Throws std::invalid_argument as boundaryConstants.
  void setPlaneMaterial(std::size_t index, const BoundaryMaterial& material);
  /// @brief The same for tool `index`.
  void setToolMaterial(std::size_t index, const BoundaryMaterial& material);
  /// @brief The constants of contacts with plane `index` / tool `index`:
  /// its material's, or null when it has none (the law's apply).
  const ContactConstants* planeConstants(std::size_t index) const;
  const ContactConstants* toolConstants(std::size_t index) const;

  /// @brief Switches the law's friction on or off for the next compute()
  /// calls (ContactLawDef::frictionFrom). Off, the law is frictionless and the
  /// shear history is dropped; switched on, the shear springs start from zero.
  /// No effect on a law without friction.
  void setFrictionActive(bool active) { frictionActive_ = active; }

  /// @brief Whether compute() applies friction: the law has it and it is active.
  bool frictionOn() const { return law_.hasFriction && frictionActive_; }

  /// @brief Separation certificates on or off (on by default): a node walk
  /// that found no contact is not repeated while neither body has moved
  /// relative to the other by the clearance the walk measured (the bound:
  /// collectLevelSet in NarrowPhase.cpp; README "Separation certificates").
  /// Exact: the contacts and
  /// forces are the same either way, only nodeChecks() and cellChecks() drop.
  void setSeparationCertificates(bool on) {
    certificatesOn_ = on;
    if (!on) {
      certificates_.clear();
      previousCertificates_.clear();
    }
  }
  /// @brief Limits the particles' tool contacts the next compute()s look for
  /// to `pairs` ({particle id, tool index}, ascending), or lifts the limit
  /// (nullopt). A world that shows another's run (World::showRunOf) knows
  /// which particles touch a tool and need not search the others; the span
  /// must outlive the limit.
  void limitToolPairs(std::optional<std::span<const std::array<std::uint64_t, 2>>> pairs) { toolPairs_ = pairs; }
  /// @brief Node walks (one per pair and direction) the certificates spared in the last compute().
  std::uint64_t certifiedWalks() const { return certifiedWalks_; }
  /// @brief Node walks that tested only the tree leaves a certificate kept
  /// (the rest of the tree certified clear) in the last compute().
  std::uint64_t leafWalks() const { return leafWalks_; }
  /// @brief Node walks past the least margin of their certificate's
  /// frontier in the last compute(): they tested the kept leaves and walked
  /// again only the frontier cells whose margins the motion had used up
  /// (or nearly: see collectLevelSet), none when every margin held.
  std::uint64_t frontierWalks() const { return frontierWalks_; }

  /// @brief Computes the node contacts and forces of the candidate pairs, of
  /// every particle against every plane and against every tool, at the current
  /// state of `particles`; fills pairContacts() and nodeContacts() and updates
  /// the shear history. Does not touch particles.force (see accumulate()).
  /// @param particles particle state (positions, orientations, velocities, masses, shapes, ids).
  /// @param pairs candidate pairs (the broad phase's), each in canonical order:
  ///   particles.id[a] < particles.id[b]. Pairs whose bounding spheres do not
  ///   overlap are skipped at the cost of one distance test.
  /// @param planes plane walls (unit normals).
  /// @param tools kinematic level-set bodies (non-null shapes).
  /// @param dt time step, s, > 0: the shear displacement increment is v_t dt.
  /// @param advanceShear false re-evaluates the contacts of the state the
  ///   last compute() saw (after particles were split, added or removed
  ///   between steps): the shear springs keep their length instead of taking
  ///   another increment.
  /// @note Throws std::invalid_argument for dt <= 0 or not finite, an index out
  /// of range, a pair not in canonical order, a plane normal not of unit length
  /// (within 1e-6) or a tool without a shape; nothing is changed then.
  void compute(const Particles<D>& particles, const std::vector<Pair>& pairs, const std::vector<Plane<D>>& planes,
               const std::vector<ToolPose<D>>& tools, double dt, bool advanceShear = true);

  /// @brief Adds the forces and torques of the last compute() into
  /// `particles` (force, torque), pair by pair in output order (a fixed order,
  /// so sums are the same for any thread count), and returns the total loads
  /// on the planes and tools.
  /// @note `particles` must hold the same particles as at compute(); throws
  /// std::invalid_argument when its size differs.
  const BoundaryLoads<D>& accumulate(Particles<D>& particles);
  /// @brief The loads on the planes and tools of the last compute() from the
  /// particles whose flag in `skip` is 0 (all when it is empty), summed as
  /// accumulate() sums them, into `out`, which it returns. A part of a
  /// distributed run: the loads of its own particles (skip: its ghosts).
  const BoundaryLoads<D>& boundaryLoadsOf(const std::vector<std::uint8_t>& skip, BoundaryLoads<D>& out) const;
  /// @brief Adds the spring energy of each pair of the last compute() (J) to
  /// the groups of its particles, once per group: `groupOf[i]` is particle
  /// i's group (an index into `sums`), < 0 for none; a plane's or tool's
  /// pair counts for its particle. Pairs whose particle a is flagged in
  /// `skipA` (all counted when it is empty) are left out: a part of a
  /// distributed run counts the pairs whose lower-id particle it owns.
  /// Breakage's fragment springs per split.
  void addSpringsByGroup(std::span<const std::int64_t> groupOf, const std::vector<std::uint8_t>& skipA,
                         std::span<double> sums) const;

  /// @brief Touching pairs of the last compute(), in order: particle pairs (in
  /// candidate order), then particle-plane contacts (by particle, then plane),
  /// then particle-tool contacts (by particle, then tool). For plane and tool
  /// records `b` is the plane / tool index and `torqueB` is the torque on the
  /// plane about Plane::point / on the tool about ToolPose::position.
  std::span<const PairContact<D>> pairContacts() const { return pairs_; }
  /// @brief The particle-pair records of pairContacts().
  std::span<const PairContact<D>> particleContacts() const { return {pairs_.data(), particlePairCount_}; }
  /// @brief The particle-plane records of pairContacts().
  std::span<const PairContact<D>> planeContacts() const {
    return {pairs_.data() + particlePairCount_, planePairCount_};
  }
  /// @brief The particle-tool records of pairContacts().
  std::span<const PairContact<D>> toolContacts() const {
    return {pairs_.data() + particlePairCount_ + planePairCount_, pairs_.size() - particlePairCount_ - planePairCount_};
  }
  /// @brief The dashpot's part of each record of pairContacts() (aligned with
  /// it); all zero when the law has no damping.
  std::span<const PairDashpot<D>> pairDashpots() const { return dashpots_; }
  /// @brief Node contacts of the last compute(); pair k owns
  /// [pairContacts()[k].firstNode, + nodeCount). Within a pair: the nodes of a
  /// inside b (ownerIsB = 0) by node index, then those of b inside a.
  /// @note After a compute() on several threads, the first call (of this,
  /// nodeShear() or nodePreload()) copies the other threads' records into
  /// one array, on all threads (OpenMP; one thread inside a parallel
  /// region), under a lock; later calls only return it.
  std::span<const NodeContact<D>> nodeContacts() const {
    copyPendingRecords();
    return nodes_;
  }
  /// @brief Shear displacement of each node contact after the last compute()
  /// (world frame, m; in the tangent plane), aligned with nodeContacts(); empty
  /// when the law has no friction.
  std::span<const Vec<D>> nodeShear() const {
    copyPendingRecords();
    return shear_;
  }

  /// @brief Rest overlap of each node contact after the last compute() (m),
  /// aligned with nodeContacts(): 0 but for springs born relaxed.
  std::span<const double> nodePreload() const {
    copyPendingRecords();
    return preload_;
  }

  /// @brief Bytes the record arrays hold (capacity): the output of the last
  /// compute() and the threads' buffers it was gathered from.
  std::size_t recordBytes() const;

  /// @brief Marks nodes of particle `particleId` as born this step (a
  /// fragment's new face, breakage::Fragment::cutFaceNodes): in the next
  /// compute(), a node contact of one of them that has no history starts
  /// relaxed, with its overlap as its rest overlap (see the class comment).
  /// The marks are used by that compute() and then dropped.
  /// @param nodes node indices in the particle's shape.
  void markNewborn(std::uint64_t particleId, std::span<const std::uint32_t> nodes);

  /// @brief A rest overlap a fragment takes over from its parent: in the
  /// next compute(), node `node` of particle `particleId`, found without
  /// history in contact with `partner` (a particle id, or a key from
  /// restOverlaps()), starts with rest overlap min(`restOverlap`, its overlap).
  /// Used by that compute() and then dropped, like markNewborn.
  void inheritRestOverlap(std::uint64_t particleId, std::uint64_t partner, std::uint32_t node, double restOverlap);

  /// A node contact of the last compute() with a rest overlap.
  struct RestOverlap {
    std::uint64_t owner = 0;    ///< global id of the node's owner
    std::uint64_t partner = 0;  ///< the other body: a particle id, or an opaque plane / tool key
    std::uint32_t node = 0;     ///< node index in the owner's shape
    double restOverlap = 0.0;   ///< m
  };
  /// @brief The node contacts with a rest overlap in the pairs of particle
  /// `index` (its nodes in other bodies and theirs in it), as of the last
  /// compute(): what its fragments take over (breakage) when it breaks.
  std::vector<RestOverlap> restOverlaps(const Particles<D>& particles, std::size_t index) const;

  /// @brief Elastic energy stored in all contact springs after the last compute(), J.
  double elasticEnergy() const { return elasticEnergy_; }
  /// @brief Power dissipated by contact damping and sliding friction in the last compute(), W.
  double dissipatedPower() const { return dissipatedPower_; }
  /// @brief Nodes tested one by one against a level set or plane in the last
  /// compute() (those of node-tree leaves that bulk rejection kept, less
  /// those a certificate's node margins cleared).
  std::uint64_t nodeChecks() const { return nodeChecks_; }
  /// @brief Node-tree cells tested in the last compute() (bulk rejection; one
  /// level-set look-up each against a level set, one dot product against a plane).
  std::uint64_t cellChecks() const { return cellChecks_; }
  /// @brief Wall seconds the last compute() took to put the threads' records
  /// into one output in task order (part of its time; about 0 on one thread,
  /// whose buffers become the output: the other threads' records are copied).
  double gatherSeconds() const { return gatherSeconds_; }
  /// @brief Node contacts carrying shear history into the next compute().
  std::size_t historySize() const { return history_.empty() ? 0 : nodes_.size(); }
  /// @brief Forgets every shear history (e.g. after a restart without it).
  void clearHistory() { history_.clear(); }

  /// One particle's contact history: the node contacts of its pairs (with
  /// particles, planes and tools) that the next compute() carries on, with
  /// their shear and rest overlaps. What moves with a particle to another
  /// solver (a distributed run: the particle moves to another rank).
  struct ParticleHistory {
    std::vector<detail::HistoryPair> pairs;  ///< first: offset into nodes
    std::vector<NodeContact<D>> nodes;
    std::vector<Vec<D>> shear;    ///< aligned with nodes; empty without friction
    std::vector<double> preload;  ///< aligned with nodes; empty without rest overlaps
  };
  /// @brief The history of particle `id`'s pairs as of the last compute()
  /// (empty without friction and rest overlaps).
  ParticleHistory particleHistory(std::uint64_t id) const;
  /// @brief particleHistory() of each of `ids` (ascending), in one pass over
  /// the history: linear in the history and the ids.
  /// @note Throws std::invalid_argument when `ids` is not strictly ascending.
  std::vector<ParticleHistory> particleHistories(std::span<const std::uint64_t> ids) const;
  /// @brief Replaces the history of particle `id`'s pairs by `history`
  /// (from particleHistory() of a solver of the same law), for the next
  /// compute(). The records of the last compute() are stale afterwards
  /// (compute() again before reading them).
  void adoptHistory(std::uint64_t id, const ParticleHistory& history);
  /// @brief adoptHistory for several particles at once (`ids[k]` takes
  /// `histories[k]`), in time linear in the histories: a pair whose two
  /// particles are both adopted is taken once, from the first that holds it.
  /// @note Throws std::invalid_argument when the spans differ in length.
  void adoptHistories(std::span<const std::uint64_t> ids, std::span<const ParticleHistory* const> histories);
  /// @brief Writes `histories` (particleHistory() of particles `ids` in
  /// solvers of the same law) over this solver's own history of their pairs,
  /// where its last compute() found the same pairs with the same node
  /// contacts (a re-evaluation of the state the histories were taken from):
  /// the node records, shear springs and rest overlaps become theirs bit for
  /// bit, and the records stay current. Linear in the histories. Returns
  /// false, changing nothing, when the pairs or node contacts differ.
  bool overwriteHistories(std::span<const std::uint64_t> ids, std::span<const ParticleHistory* const> histories);

  /// @brief Writes the output of the last compute() (records, shear history,
  /// totals, loads): what the next compute() and the readers of this step need.
  void saveState(StateWriter& out) const;
  /// @brief Reads back what saveState wrote (same law; particles restored alike).
  void loadState(StateReader& in);

 private:
  template <NormalModel Normal, ForceFormulation Formulation, bool Friction, bool Damping>
  void run(const Particles<D>& particles, const std::vector<Pair>& pairs, const std::vector<Plane<D>>& planes,
           const std::vector<ToolPose<D>>& tools, double dt, double shearDt);
  void gather(const Particles<D>& particles, std::size_t particlePairTasks, std::size_t planeTasks);
  // blocks_ = the bounds of `parts` parts of consecutive tasks of about equal estimated cost.
  void splitIntoBlocks(std::size_t taskCount, std::size_t parts);
  // runs_ = the bounds of the runs of consecutive tasks whose records lie
  // one after the other in one thread's buffers (what gather() moves at once).
  void findRuns();
  // The history key of record k's b (HistoryPair::other): a particle's id, or a tagged plane / tool index.
  std::uint64_t partnerKey(const Particles<D>& particles, std::size_t k) const;

  ContactLawDef law_;
  bool frictionActive_ = true;
  // Constants of boundaries with their own material, by plane / tool index.
  std::vector<std::optional<ContactConstants>> planeConstants_, toolConstants_;
  // Output of the last compute(); nodes_ / shear_ with history_ are also the history.
  detail::Records<PairContact<D>> pairs_;
  detail::Records<PairDashpot<D>> dashpots_;  // aligned with pairs_; not part of the saved state
  // The node-level output (nodes_, shear_, preload_, historyKeys_) is sized
  // by gather(), which fills only the first run's part (or swaps it in):
  // the other runs' records stay in their threads' held buffers (pending_)
  // until a reader asks for the arrays (copyPendingRecords, which a const
  // reader may call: hence mutable). The next compute() reads its history
  // from either place, so a step whose node records nobody reads copies
  // none (on one thread there is nothing to copy).
  mutable detail::Records<NodeContact<D>> nodes_;
  mutable detail::Records<Vec<D>> shear_;
  mutable detail::Records<double> preload_;  // aligned with nodes_
  mutable std::vector<detail::TaskOutput> pending_;  // runs in output order (outNode), held by their threads
  mutable detail::CopyLock pendingLock_;
  // Copies the pending runs' records into the node-level output (none left after).
  void copyPendingRecords() const;
  std::vector<detail::BirthNode> newborn_;  // sorted by (id, node); for the next compute()
  std::vector<detail::HistoryPair> history_;  // sorted by (idA, other)
  // Node keys of nodes_ (owner bit and node index), aligned with it while
  // history_ is kept: the history merge reads these, not the 88-byte records
  // (filled as gather() copies the records; rebuilt from them on loadState()).
  mutable detail::Records<std::uint32_t> historyKeys_;
  void buildHistoryKeys();
  // Appends `history`'s pairs to the history (none of them held already) and sorts it.
  void appendHistory(const ParticleHistory& history);
  // The pairs of `histories` in one history, a pair two of them hold once.
  static ParticleHistory mergedHistory(std::span<const ParticleHistory* const> histories);
  void buildHistoryKeysFor(std::size_t count);  // historyKeys_ of the first `count` records of nodes_
  // Separation certificates: a cache, not saved with the state (a restored
  // run makes them afresh, with the same contacts). Two slots per candidate
  // pair, in the pairs' order (2k: a's nodes in b, 2k + 1: b's in a), then
  // one per particle and tool, so a walk finds its last certificate at its
  // own slot while the Verlet list is unchanged; after the list changed,
  // through certificateOrder_ (the previous step's certificates by (owner,
  // other)). Walks against planes have none (a plane test is one dot
  // product per tree cell).
  bool certificatesOn_ = true;
  std::optional<std::span<const std::array<std::uint64_t, 2>>> toolPairs_;  // limitToolPairs
  std::vector<detail::Certificate<D>> certificates_, previousCertificates_;
  std::vector<std::array<std::uint32_t, 2>> certificatePairs_;  // the pairs certificates_ was made for
  std::vector<std::uint32_t> certificateOrder_;
  std::uint64_t certifiedWalks_ = 0, leafWalks_ = 0, frontierWalks_ = 0;
  std::size_t particlePairCount_ = 0, planePairCount_ = 0;
  std::size_t particleCount_ = 0, planeCount_ = 0, toolCount_ = 0;
  double elasticEnergy_ = 0.0, dissipatedPower_ = 0.0;
  std::uint64_t nodeChecks_ = 0, cellChecks_ = 0;
  double gatherSeconds_ = 0.0;  // the last compute()'s gather(), wall seconds
  // Scratch reused between steps.
  std::vector<Mat<D>> rotations_;  // each particle's, this compute()
  std::vector<detail::ThreadBuffers<D>> threads_;
  std::vector<detail::TaskOutput> tasks_;
  std::vector<std::size_t> blocks_;        // task bounds of the parts, two threads each, this compute()
  std::vector<detail::TaskCursor> cursors_;  // per part: its tasks not yet taken
  std::vector<std::size_t> runs_;          // task bounds of the runs of records (findRuns)
  std::vector<std::uint32_t> taskCost_;    // the last compute()'s cost per task
  std::vector<double> blockSeconds_;       // the last compute()'s seconds of work per part (all threads)
  std::vector<double> threadSeconds_;      // per thread and part, this compute()
  std::vector<double> blockRate_, estimate_;  // scratch of splitIntoBlocks
  BoundaryLoads<D> loads_;
};

extern template class ContactSolver<2>;
extern template class ContactSolver<3>;

}  // namespace lsdem::dynamics
