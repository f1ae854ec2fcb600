#include "lsdem/dynamics/NarrowPhase.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <unordered_set>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace lsdem::dynamics {
namespace {

using detail::BirthNode;
using detail::kAnyPartner;
using detail::HistoryPair;
using detail::NodeWork;
using detail::TaskOutput;
using detail::ThreadBuffers;
using geometry::Box;
using geometry::Grid;
using geometry::Rigid;
using geometry::Shape;

// Tags in the second half of a history key for boundaries (global ids stay below 2^62).
constexpr std::uint64_t kPlaneTag = std::uint64_t(1) << 62;
constexpr std::uint64_t kToolTag = std::uint64_t(2) << 62;
// Node keys order the node contacts of a pair: ownerIsB in the top bit, then the node index.
constexpr std::uint32_t kOwnerIsBBit = std::uint32_t(1) << 31;

// Threads the parallel loops may use, and the calling thread's index.
int threadCount() {
#ifdef _OPENMP
  return omp_get_max_threads();
#else
  return 1;
#endif
}
int threadIndex() {
#ifdef _OPENMP
  return omp_get_thread_num();
#else
  return 0;
#endif
}
double wallSeconds() {
#ifdef _OPENMP
  return omp_get_wtime();
#else
  return 0.0;
#endif
}
// Cost units of a task (ContactSolver::splitIntoBlocks) besides its tests:
// each node record it writes, and the task itself.
constexpr std::uint64_t kRecordCost = 16;
constexpr std::uint64_t kTaskCost = 32;

template <int D>
std::uint32_t nodeKey(const NodeContact<D>& c) {
  return (c.ownerIsB ? kOwnerIsBBit : 0u) | c.node;
}

// Law constants of one compute() call (gStar > 0: Mindlin's tangential stiffness).
struct LawConstants {
  double kn = 0.0, ks = 0.0, mu = 0.0, zeta = 0.0, eStar = 0.0, gStar = 0.0, dt = 0.0;
  double shearDt = 0.0;  // dt, or 0 when re-evaluating an unchanged state
};

// The constants of contacts with a boundary: its own material's, or (null) the law's.
LawConstants boundaryLaw(const LawConstants& law, const ContactConstants* material) {
  if (material == nullptr) return law;
  LawConstants out = law;
  out.kn = material->kn;
  out.ks = material->ks;
  out.mu = material->friction;
  out.eStar = material->eStar;
  out.gStar = law.gStar > 0.0 ? material->gStar : 0.0;
  return out;
}

// A pair's node contacts of the previous step (its shear history), by node key.
template <int D>
struct HistoryView {
  const std::uint32_t* keys = nullptr;  // their node keys (nodeKey), ascending
  const NodeContact<D>* nodes = nullptr;
  const Vec<D>* shear = nullptr;    // null without friction
  const double* preload = nullptr;  // null when no contact carried a rest overlap
  std::uint32_t count = 0;
};

// The birth records of a pair's two bodies (ContactSolver::markNewborn,
// inheritRestOverlap), each list ascending by node; empty for a body without
// any (and for boundaries). keyOfB is b's key as a's partner, idA a's as b's.
struct NewbornView {
  std::span<const BirthNode> a, b;
  std::uint64_t keyOfB = 0, idA = 0;
  bool empty() const { return a.empty() && b.empty(); }
  // The rest overlap a node contact without history starts with: 0 without a record.
  template <int D>
  double restOverlap(const NodeContact<D>& c) const {
    const std::span<const BirthNode> list = c.ownerIsB ? b : a;
    const std::uint64_t partner = c.ownerIsB ? idA : keyOfB;
    auto it = std::lower_bound(list.begin(), list.end(), c.node,
                               [](const BirthNode& n, std::uint32_t node) { return n.node < node; });
    double rest = 0.0;
    for (; it != list.end() && it->node == c.node; ++it) {
      if (it->other == partner || it->other == kAnyPartner) rest = std::max(rest, it->restOverlap);
    }
    return std::min(rest, c.overlap);
  }
};

// Stiffness factor of a node: w_i x weightToFactor when area weighted (the
// direction weight / w_ref), else the constant weightToFactor (the direction
// weight x the owner's node stiffness scale).
template <ForceFormulation Formulation>
double stiffnessFactor(double nodeWeight, double weightToFactor) {
  if constexpr (Formulation == ForceFormulation::PerNode) {
    (void)nodeWeight;
    return weightToFactor;
  } else {
    return nodeWeight * weightToFactor;
  }
}

// The per-shape constant of stiffnessFactor for one direction of a pair.
template <int D, ForceFormulation Formulation>
double weightToFactorOf(const Shape<D>& owner, double directionWeight) {
  if constexpr (Formulation == ForceFormulation::PerNode) {
    return directionWeight * owner.nodeStiffnessScale();
  } else {
    return directionWeight / referenceNodeWeight<D>(owner.contactSpacing());
  }
}

// Puts the node contacts buf.nodes[first, end) (and their work records) in
// ascending node order: the tree visits nodes in its own order, the output
// and the shear-history merge want node order (NarrowPhase.h). Within one
// direction every record has the same owner, so the node index is the key.
template <int D>
void sortByNode(ThreadBuffers<D>& buf, std::size_t first) {
  const std::size_t end = buf.nodes.size();
  bool sorted = true;
  for (std::size_t j = first + 1; j < end && sorted; ++j) sorted = buf.nodes[j - 1].node < buf.nodes[j].node;
  if (sorted) return;
  const std::size_t n = end - first;
  buf.order.resize(n);
  for (std::size_t j = 0; j < n; ++j) buf.order[j] = std::uint32_t(j);
  std::sort(buf.order.begin(), buf.order.end(),
            [&](std::uint32_t a, std::uint32_t b) { return buf.nodes[first + a].node < buf.nodes[first + b].node; });
  buf.nodeScratch.assign(buf.nodes.begin() + std::ptrdiff_t(first), buf.nodes.end());
  buf.workScratch.assign(buf.work.begin() + std::ptrdiff_t(first), buf.work.end());
  for (std::size_t j = 0; j < n; ++j) {
    buf.nodes[first + j] = buf.nodeScratch[buf.order[j]];
    buf.work[first + j] = buf.workScratch[buf.order[j]];
  }
}

// Copies records [lo, hi) of a run that starts at `first` in `source` to
// the run's place in `target`, which starts at `out`, as bytes: the
// records are plain data (RecordAllocator; Eigen's fixed-size members are
// arrays of doubles, as checkpoints also treat them), and std::copy would
// copy them member by member (Eigen's vectors are not trivially
// copyable): 20-30 % longer.
template <class Source, class Target>
void copyRecords(const Source& source, std::size_t first, Target& target, std::size_t out, std::size_t lo,
                 std::size_t hi) {
  using Record = typename Source::value_type;
  static_assert(std::is_same_v<Record, typename Target::value_type>);
  static_assert(std::is_standard_layout_v<Record> && std::is_trivially_destructible_v<Record>,
                "records are plain data");
  if (hi <= lo) return;
  std::memcpy(static_cast<void*>(target.data() + out + lo), static_cast<const void*>(source.data() + first + lo),
              (hi - lo) * sizeof(Record));
}

// Copies `total` records that lie in `runCount` runs (sizeOf(r): run r's
// count) in equal shares, one per thread (all threads when there are more
// than 4096): copy(r, lo, hi) copies records [lo, hi) of run r.
template <class SizeOf, class Copy>
void copyInShares(std::size_t runCount, std::size_t total, std::size_t threads, const SizeOf& sizeOf,
                  const Copy& copy) {
  const std::ptrdiff_t shares = total > 4096 ? std::ptrdiff_t(std::max<std::size_t>(threads, 1)) : 1;
#pragma omp parallel for schedule(static) if (shares > 1)
  for (std::ptrdiff_t share = 0; share < shares; ++share) {
    const std::size_t from = total * std::size_t(share) / std::size_t(shares);
    const std::size_t to = total * std::size_t(share + 1) / std::size_t(shares);
    std::size_t at = 0;  // records of the runs before this one
    for (std::size_t r = 0; r < runCount && at < to; ++r) {
      const std::size_t count = sizeOf(r);
      // The part [lo, hi) of [at, at + count) in this share, as offsets in the run.
      const std::size_t lo = std::clamp(from, at, at + count) - at, hi = std::clamp(to, at, at + count) - at;
      at += count;
      if (hi > lo) copy(r, lo, hi);
    }
  }
}

// Grows scratch `v` to at least n entries (never shrinks it: the walks'
// scratch keeps the largest size any walk needed).
template <class V>
void atLeast(V& v, std::size_t n) {
  if (v.size() < n) v.resize(n);
}

// The walk's ids, the certificate the last compute() left for them (null:
// none) and the slot this compute() leaves its own in (cleared by the caller).
template <int D>
struct CertificateKey {
  std::uint64_t owner = 0, other = 0;
  const detail::Certificate<D>* previous = nullptr;
  const detail::KeptLeaf* previousLeaves = nullptr;  // its leaves
  const detail::RejectedCell* previousFrontier = nullptr;  // its frontier
  detail::Certificate<D>* out = nullptr;
  std::uint32_t thread = 0;  // the calling thread's index
};

// Slack of a certificate, cells: far above the round-off of the composed
// maps and the margins below, far below any motion that matters.
constexpr double kCertificateSlack = 1e-6;

// eq. 3-4 for one direction: appends to `buf` the nodes of `owner` (pose Ro, xo)
// inside the level set of `other` (pose Rt, xt), with normals of sign
// `normalSign` x grad phi_other (so they point from b towards a), in node
// order, and returns the number of nodes tested one by one.
//
// Bulk rejection (NodeTree.h): a tree cell's sphere (centre c, radius r) is
// mapped to the other body's grid frame and skipped, with every node in it,
// when it misses the other body's bounding sphere, misses its grid box grown
// by r, or phi_other(c') > L r, with c' the point of the grid box closest to
// c (c itself when inside) and L = other.levelSetSlope() the largest
// |grad phi| of the interpolant in the box: a node y in the box is no farther
// from c' than from c (projection onto a convex set), the segment from c' to
// y stays in the box, so phi(y) >= phi(c') - L r > 0; nodes outside the box
// are never tested. So none of the cell's nodes can touch. The test is
// exact (no contact is lost); nodes of surviving leaves go through the same
// per-node test as without the tree, so the contacts are the same.
//
// Separation certificate (`key` non-null): a walk that finds no contact
// records the map and the smallest margin of its rejections, in cells: a
// cell or node outside the bounding sphere or the box, its distance beyond
// it (a lower bound for the box: the largest excess along an axis); a cell
// rejected by the slope bound, (phi(c') - L r) / L, since a node y' moved by
// d from the cell is within d + r of c' and phi(y') >= phi(c') - L (d + r);
// a single node with phi >= 0, phi / L (both ends of its segment in the box,
// which is convex). No node can then be found inside before some node has
// moved by the margin relative to the other's grid, so the next walk is
// spared while the composed map has moved less (README "Separation
// certificates").
//
// Cubic: the node look-up is the Catmull-Rom interpolant
// (Grid::cubicValueAtCells). The rejections keep their multilinear tests,
// with E = other.cubicMargin() taken off: where the multilinear value
// exceeds E the cubic is positive, so a cell is rejected when
// phi(c') - L r > E, a node is rejected without the cubic look-up when
// phi_lin > E (its certificate margin (phi_lin - E) / L; a node nearer than
// that gets none), and the bounding sphere is Shape::cubicBoundingRadius().
// A node with phi_lin <= E is still rejected without the cubic look-up when
// phi_lin exceeds its cell's own margin E_c <= E (Shape::CubicLookup); it
// keeps the larger certificate margin of min((phi_lin - E_1) / L, 1 cell),
// with E_1 the largest cell margin within one cell (CubicLookup::nearSteps),
// and min((phi_lin - E_c) / L, its distance from its cell's faces), since
// E_c holds while it stays in its cell. A node whose cubic value is phi >= 0
// keeps phi / L_c, L_c >= |grad| of the cubic in the box (CubicLookup::slope).
// (Taking the near margin for nodes cleared by E as well spared 2.6% of the
// node tests but cost more than it saved: measured, not kept.)
template <int D, ForceFormulation Formulation, bool Cubic>
std::uint64_t collectLevelSet(const Shape<D>& owner, const Mat<D>& Ro, const Vec<D>& xo, const Shape<D>& other,
                              const Mat<D>& Rt, const Vec<D>& xt, double directionWeight, double normalSign,
                              std::uint8_t ownerIsB, ThreadBuffers<D>& buf, const CertificateKey<D>* key) {
  // One composed map per direction: owner body -> world -> other body ->
  // other grid -> cells of the other grid (grid coordinates, so a look-up
  // needs no conversion: Grid::valueAtCells): `map` and `shift` below, which
  // are `turn` and `offset` divided by the spacing.
  const Rigid<D>& toGrid = other.bodyToGrid();
  const Grid<D>& grid = other.grid();
  const double h = grid.spacing();
  const Mat<D> RtT = Rt.transpose();
  const Mat<D> turn = toGrid.rotation * RtT * Ro;
  const Vec<D> offset = toGrid.rotation * (RtT * (xo - xt)) + toGrid.translation - grid.origin();
  const double slope = other.levelSetSlope();
  const geometry::NodeTree<D>& tree = owner.nodeTree();
  if (tree.cells.empty()) return 0;

  // Separation certificate (above): the walk is spared while no
  // point of the owner has moved, relative to the other's grid, by the
  // clearance the last walk measured. |x| <= |c_root| + r_root bounds the
  // nodes' distance from the owner's origin, so a node moved at most
  // ||map - map_0||_F rho + |shift - shift_0| cells.
  const bool certify = key != nullptr && slope > 0.0;
  const detail::Certificate<D>* previous = nullptr;
  double rho = 0.0;
  if (certify && key->previous && key->previous->ownerShape == &owner && key->previous->otherShape == &other) {
    previous = key->previous;
    rho = tree.cells[0].centre.norm() + tree.cells[0].radius;
    // Spared? Most walks of a settled or slow bed are, so the test comes
    // before anything else a walk needs, and takes the map as turn and
    // offset times 1 / h: within a few units of round-off of map and shift
    // (divided by h: 12 divisions in 3D, which held up every walk), far inside
    // the certificate's slack.
    const double perCell = 1.0 / h;
    const double bound = (turn * perCell - previous->map).norm() * rho + (offset * perCell - previous->shift).norm();
    if (bound + kCertificateSlack < previous->clearance) {
      // Spared; its leaves and frontier move to this step's lists with it.
      *key->out = *previous;
      key->out->leafThread = key->thread;
      key->out->leafFirst = std::uint32_t(buf.leaves.size());
      key->out->frontierFirst = std::uint32_t(buf.frontier.size());
      buf.leaves.insert(buf.leaves.end(), key->previousLeaves, key->previousLeaves + previous->leafCount);
      buf.frontier.insert(buf.frontier.end(), key->previousFrontier, key->previousFrontier + previous->frontierCount);
      ++buf.certifiedWalks;
      return 0;
    }
  }
  const Mat<D> map = turn / h;
  const Vec<D> shift = offset / h;
  double moved = previous ? (map - previous->map).norm() * rho + (shift - previous->shift).norm() : 0.0;
  // Gradient per cell -> world normal pointing from b towards a.
  const Mat<D> gradToWorld = normalSign * (Rt * toGrid.rotation.transpose());
  // Cheap rejections, in cells: the other body's bounding sphere (centred on
  // its centroid, the grid-frame image of the body origin) and its node box.
  const Vec<D> upper = (grid.dims() - 1).template cast<double>().matrix();
  const Vec<D> centre = (toGrid.translation - grid.origin()) / h;
  constexpr LevelSetInterpolation interpolation = Cubic ? LevelSetInterpolation::Tricubic
                                                        : LevelSetInterpolation::Trilinear;
  const double reach = lookupRadius(other, interpolation) / h;
  // The tricubic look-up's margins (taken once: the first call is synchronised).
  const typename Shape<D>::CubicLookup* cubic = Cubic ? &other.cubicLookup() : nullptr;
  const double cubicMargin = Cubic ? cubic->margin : 0.0;
  const double reach2 = reach * reach;
  // Round-off of the look-up and of the mapped centre, far below any overlap that matters.
  const double margin = 1e-9 * h;
  const double weightToFactor = weightToFactorOf<D, Formulation>(owner, directionWeight);
  const std::vector<Vec<D>>& nodes = owner.nodes().positions;
  const std::vector<double>& weights = owner.nodes().weights;
  const std::size_t first = buf.nodes.size();
  const double perSlopeCell = certify ? 1.0 / (slope * h) : 0.0;
  [[maybe_unused]] const double perCubicSlopeCell = certify && Cubic ? 1.0 / (cubic->slope * h) : 0.0;
  std::uint64_t tested = 0;
  // How far g may move (cells) and stay in the cell cellAtCells(g): its
  // distance from the cell's nearest face.
  [[maybe_unused]] const auto withinCell = [&grid](const Vec<D>& g) {
    double d = 1.0;
    for (int a = 0; a < D; ++a) {
      const double f = g[a] - double(std::clamp(int(g[a]), 0, grid.dims()[a] - 2));
      d = std::min({d, f, 1.0 - f});
    }
    return d;
  };
  // How far g lies beyond the node box along its worst axis (<= 0 inside).
  const auto beyondBox = [upper](const Vec<D>& g) {
    return std::max((-g.array()).maxCoeff(), (g.array() - upper.array()).maxCoeff());
  };
  using Cell = typename geometry::NodeTree<D>::Cell;
  // A tree cell's sphere in the other's grid (cells): centre g, radius r,
  // squared distance from the other's bounding sphere's centre, and how far
  // it lies beyond the node box along its worst axis. Its first two tests:
  // rejected when apart2 > (reach + r)^2, or when outside > 0.
  struct PlacedCell {
    Vec<D> g;
    double r, apart2, outside;
  };
  const auto placeCell = [map, shift, centre, h, beyondBox](const Cell& cell) {
    const Vec<D> g = map * cell.centre + shift;
    const double r = cell.radius / h;
    return PlacedCell{g, r, (g - centre).squaredNorm(), beyondBox(g) - r};
  };
  // The slope bound of a cell of radius `radius` (world units) placed at g:
  // rejected when slopeAbove(value at slopePoint(g), radius) > 0. The bound
  // holds along segments in the grid box, and only nodes in the box are
  // tested: a centre outside the box is replaced by its closest point of
  // the box, no farther from any node in the box.
  const auto slopePoint = [upper](const Vec<D>& g) -> Vec<D> { return g.cwiseMax(Vec<D>::Zero()).cwiseMin(upper); };
  const auto slopeAbove = [slope, margin, cubicMargin](double value, double radius) {
    double above = value - (slope * radius + margin);
    if constexpr (Cubic) above -= cubicMargin;
    return above;
  };
  // A tree cell's test: true when none of its nodes can touch. With
  // certificates, `clear` gets its margin in cells: for a rejected cell, how
  // far it may move before its test could pass; for a passed leaf, how far
  // before it could be rejected (the least of its three tests' slack), so
  // that a leaf walk need not make it again before then. (The batched walk,
  // walkCells, makes the same tests with the same margins.)
  const auto cellRejected = [&](const Cell& cell, double& clear) {
    const PlacedCell c = placeCell(cell);
    if (c.apart2 > (reach + c.r) * (reach + c.r)) {
      if (certify) clear = std::sqrt(c.apart2) - reach - c.r;
      return true;
    }
    if (c.outside > 0.0) {
      clear = c.outside;
      return true;
    }
    const double above = slopeAbove(grid.valueAtCells(slopePoint(c.g)), cell.radius);
    if (above > 0.0) {
      clear = above * perSlopeCell;
      return true;
    }
    // (Only a leaf's is kept: KeptLeaf.)
    if (certify && cell.child == 0) {
      clear = std::min({reach + c.r - std::sqrt(c.apart2), -c.outside, -above * perSlopeCell});
    }
    return false;
  };
  // The world normal of a node's gradient `grad` (cells) in `normal`, and
  // its length: 0 where the gradient is zero (a medial point: the node has
  // no normal and no record). (Tested squared: the outcome need not wait
  // for the square root.)
  const auto normalOf = [&](const Vec<D>& grad, Vec<D>& normal) {
    normal = gradToWorld * grad;
    const double length2 = normal.squaredNorm();
    return length2 > 0.0 ? std::sqrt(length2) : 0.0;
  };
  // Node i's records, inside at phi < 0 with world normal `normal` of
  // length `length` > 0 (normalOf).
  const auto contactOf = [&](std::uint32_t i, double phi, const Vec<D>& normal, double length) {
    return NodeContact<D>{Ro * nodes[i] + xo, normal / length, Vec<D>::Zero(), -phi, i, ownerIsB};
  };
  const auto workOf = [&](std::uint32_t i, double length) {
    return NodeWork<D>{stiffnessFactor<Formulation>(weights[i], weightToFactor), directionWeight * weights[i],
                       length / h, -1};
  };
  // The records of the trilinear nodes at tree positions ks[at[c]], c <
  // count, known to be inside, with values phis[c] and gradients grads[c].
  // Written in place (Records leaves a resize unwritten).
  [[maybe_unused]] const auto recordNodes = [&](const std::uint32_t* ks, const std::uint32_t* at, std::uint32_t count,
                                                const double* phis, const Vec<D>* grads) {
    std::size_t n = buf.nodes.size();
    buf.nodes.resize(n + count);
    buf.work.resize(n + count);
    for (std::uint32_t c = 0; c < count; ++c) {
      const double phi = phis[c];
      Vec<D> normal;
      const double length = normalOf(grads[c], normal);
      if (!(length > 0.0)) continue;
      const std::uint32_t i = tree.order[ks[at[c]]];
      // (Made where they go: assigned, they were made in a temporary and
      // then copied.)
      ::new (static_cast<void*>(&buf.nodes[n])) NodeContact<D>(contactOf(i, phi, normal, length));
      ::new (static_cast<void*>(&buf.work[n])) NodeWork<D>(workOf(i, length));
      ++n;
    }
    buf.nodes.resize(n);
    buf.work.resize(n);
  };
  // One node (tree position k): appends its contact, or returns its margin
  // in cells (how far it may move before the test that rejected it could
  // pass; with certificates only, else 0); 0 for a contact and for a node
  // inside without a normal.
  const auto testNode = [&](std::uint32_t k) -> double {
    const std::uint32_t i = tree.order[k];
    const Vec<D>& x = nodes[i];
    const Vec<D> g = map * x + shift;
    const double apart2 = (g - centre).squaredNorm();
    if (apart2 > reach2) return certify ? std::sqrt(apart2) - reach : 0.0;
    const double outside = beyondBox(g);
    if (outside > 0.0) return certify ? outside : 0.0;
    // The value; the gradient, from the same corners, only for the few nodes inside.
    Vec<D> grad;
    double phi;
    if constexpr (Cubic) {
      // The multilinear value first: above the cubic margin the cubic is
      // positive (Shape::cubicMargin), and most nodes tested are there;
      // above its cell's margin too.
      const double linear = grid.valueAtCells(g) - margin;
      const double clear = linear - cubicMargin;
      if (clear > 0.0) return clear * perSlopeCell;  // 0 without certificates
      const std::size_t cell = grid.cellAtCells(g);
      if (linear > cubic->cellMargin(cell)) {
        if (!certify) return 0.0;
        return std::max(std::min((linear - cubic->nearMargin(cell)) * perSlopeCell, 1.0),
                        std::min((linear - cubic->cellMargin(cell)) * perSlopeCell, withinCell(g)));
      }
      phi = grid.cubicValueAtCellsGradientBelow(g, 0.0, grad);
      if (!(phi < 0.0)) return certify ? (phi - margin) * perCubicSlopeCell : 0.0;
    } else {
      phi = grid.valueAtCellsGradientBelow(g, 0.0, grad);
      if (!(phi < 0.0)) return certify ? (phi - margin) * perSlopeCell : 0.0;
    }
    Vec<D> normal;
    const double length = normalOf(grad, normal);
    if (!(length > 0.0)) return 0.0;
    // Whole records, not value-initialised then written field by field.
    if constexpr (Cubic) {
      // (Appended from an lvalue: another std::vector member than the
      // trilinear path's, which GCC then keeps inlined there as before.)
      const NodeContact<D> record = contactOf(i, phi, normal, length);
      buf.nodes.push_back(record);
    } else {
      buf.nodes.push_back(contactOf(i, phi, normal, length));
    }
    buf.work.push_back(workOf(i, length));
    return 0.0;
  };
  // Walks and node tests in batches. A batch's loop takes no branch on a
  // test's outcome: it writes every item and counts the survivors, so the
  // look-ups of one batch overlap instead of each waiting for the branch
  // before it. The tests are cellRejected's and testNode's, in the same
  // arithmetic, with the same margins, so walks find the same contacts and
  // certificates bit for bit. Scratch (ThreadBuffers::batch*): every list
  // holds each cell or node of the tree at most once.
  const std::size_t cellSpace = tree.cells.size() + 2, nodeSpace = std::max(cellSpace, nodes.size());
  // (Sized by the walks that use them: a leaf walk does not.)
  const auto sizeScratch = [&] {
    atLeast(buf.batchCells, 2 * cellSpace);
    atLeast(buf.batchLeaves, cellSpace);
    atLeast(buf.batchLive, nodeSpace);
    atLeast(buf.batchNodes, nodeSpace);
    atLeast(buf.batchOwners, nodeSpace);
    atLeast(buf.batchPoints, nodeSpace);
    atLeast(buf.batchValues, 4 * nodeSpace);
  };
  // The subtrees of the cells batchCells[0, count), level by level: each
  // level's cells get their sphere and box tests, then the survivors their
  // slope bound's look-up. Returns how many leaves passed, in batchLeaves;
  // with certificates (Certify), their margins (cellRejected's `clear`) in
  // batchValues[cellSpace + l], and each rejected cell is given to
  // rejected(cell, clear).
  const auto walkCells = [&]<bool Certify>(std::uint32_t count, auto rejected) __attribute__((noinline)) {
    std::uint32_t* level = buf.batchCells.data();
    std::uint32_t* next = level + cellSpace;
    std::uint32_t* const live = buf.batchLive.data();
    std::uint32_t* const leaves = buf.batchLeaves.data();
    std::uint32_t* const out = buf.batchNodes.data();  // rejected cells (Certify)
    Vec<D>* const at = buf.batchPoints.data();
    double* const partial = buf.batchValues.data();           // a survivor's least margin of the first two tests
    double* const leafClear = partial + cellSpace;             // a passed leaf's margin
    double* const outClear = partial + 2 * cellSpace;          // a rejected cell's margin
    double* const values = partial + 3 * cellSpace;            // a survivor's look-up
    std::uint32_t leafCount = 0;
    // (Local copies: a store to the scratch lists cannot then change them,
    // and they stay in registers.)
    const auto placeCell_ = placeCell;
    const auto slopePoint_ = slopePoint;
    const auto slopeAbove_ = slopeAbove;
    const double reach_ = reach, perSlopeCell_ = perSlopeCell;
    const Cell* const cells = tree.cells.data();
    while (count > 0) {
      buf.cellChecks += count;
      std::uint32_t near = 0, outCount = 0;
      for (std::uint32_t j = 0; j < count; ++j) {
        const PlacedCell c = placeCell_(cells[level[j]]);
        // (Both tests made, joined by &: no branch.)
        const bool inSphere = !(c.apart2 > (reach_ + c.r) * (reach_ + c.r)), nearBox = !(c.outside > 0.0);
        const bool reached = inSphere & nearBox;
        if constexpr (Certify) {
          const double root = std::sqrt(c.apart2);
          out[outCount] = level[j];
          outClear[outCount] = inSphere ? c.outside : root - reach_ - c.r;
          outCount += !reached;
          partial[near] = std::min(reach_ + c.r - root, -c.outside);
        }
        live[near] = level[j];
        at[near] = slopePoint_(c.g);
        near += reached;
      }
      if constexpr (Certify) {
        for (std::uint32_t j = 0; j < outCount; ++j) rejected(out[j], outClear[j]);
        outCount = 0;
      }
      grid.valuesAtCells(at, near, values);
      std::uint32_t nextCount = 0;
      for (std::uint32_t j = 0; j < near; ++j) {
        const Cell& cell = cells[live[j]];
        const double above = slopeAbove_(values[j], cell.radius);
        const bool passed = !(above > 0.0), leaf = cell.child == 0;
        if constexpr (Certify) {
          out[outCount] = live[j];
          outClear[outCount] = above * perSlopeCell_;
          outCount += !passed;
          leafClear[leafCount] = std::min(partial[j], -above * perSlopeCell_);
        }
        leaves[leafCount] = live[j];
        leafCount += passed & leaf;
        next[nextCount] = cell.child;
        next[nextCount + 1] = cell.child + 1;
        nextCount += 2 * std::uint32_t(passed & !leaf);
      }
      if constexpr (Certify) {
        for (std::uint32_t j = 0; j < outCount; ++j) rejected(out[j], outClear[j]);
      }
      std::swap(level, next);
      count = nextCount;
    }
    return leafCount;
  };
  // The nodes at tree positions ks[0, n) tested as testNode tests them: the
  // records of those inside are appended; with certificates each one's
  // margin (testNode's return) goes to margins[j]. With Gradients, one
  // look-up gives every candidate's value and gradient (Grid::
  // valuesAndGradientsAtCells), so those inside need no second one; else
  // the values first, and the gradients of those inside from a second
  // batch of look-ups.
  const auto testNodes = [&]<bool Gradients>(const std::uint32_t* ks, std::uint32_t n, double* margins) __attribute__((noinline)) {
    std::uint32_t* const live = buf.batchLive.data();
    Vec<D>* const at = buf.batchPoints.data();
    std::uint32_t candidates = 0;
    const Mat<D> map_ = map;
    const Vec<D> shift_ = shift, centre_ = centre;
    const double reach_ = reach, reach2_ = reach2, perSlopeCell_ = perSlopeCell, margin_ = margin;
    const auto beyondBox_ = beyondBox;
    const Vec<D>* const positions = nodes.data();
    const std::uint32_t* const order = tree.order.data();
    for (std::uint32_t j = 0; j < n; ++j) {
      const Vec<D> g = map_ * positions[order[ks[j]]] + shift_;
      const double apart2 = (g - centre_).squaredNorm();
      const double outside = beyondBox_(g);
      const bool inSphere = !(apart2 > reach2_), inBox = !(outside > 0.0);
      if (certify) margins[j] = inSphere ? outside : std::sqrt(apart2) - reach_;
      live[candidates] = j;
      at[candidates] = g;
      candidates += inSphere & inBox;
    }
    if constexpr (Cubic) {
      for (std::uint32_t c = 0; c < candidates; ++c) {
        const double m = testNode(ks[live[c]]);
        if (certify) margins[live[c]] = m;
      }
    } else {
      // (margins, where given, are batchValues[0, n): the values go after them.)
      double* const values = buf.batchValues.data() + nodeSpace;
      if constexpr (Gradients) {
        // (Written over the points: at[c] is candidate c's gradient from here.)
        grid.valuesAndGradientsAtCells(at, candidates, values, at);
      } else {
        grid.valuesAtCells(at, candidates, values);
      }
      std::uint32_t inside = 0;
      for (std::uint32_t c = 0; c < candidates; ++c) {
        const double phi = values[c];
        if (certify) margins[live[c]] = (phi - margin_) * perSlopeCell_;
        live[inside] = live[c];
        at[inside] = at[c];
        if constexpr (Gradients) values[inside] = phi;
        inside += phi < 0.0;
      }
      if (certify) {
        for (std::uint32_t c = 0; c < inside; ++c) margins[live[c]] = 0.0;
      }
      // Without Gradients, those inside get theirs now, in one batch (the
      // same values again, bit for bit).
      if constexpr (!Gradients) grid.valuesAndGradientsAtCells(at, inside, values, at);
      recordNodes(ks, live, inside, values, at);
    }
  };
  // The order of the leaves batchLeaves[0, count) in the tree, in
  // batchLive (each level's leaves are in order; the levels interleave):
  // taken in it, their nodes' records come in node order, as a leaf walk's
  // after them do.
  const auto orderLeaves = [&](std::uint32_t count) {
    std::uint32_t* const byBegin = buf.batchLive.data();
    for (std::uint32_t l = 0; l < count; ++l) byBegin[l] = l;
    std::sort(byBegin, byBegin + count, [&](std::uint32_t x, std::uint32_t y) {
      return tree.cells[buf.batchLeaves[x]].begin < tree.cells[buf.batchLeaves[y]].begin;
    });
    return byBegin;
  };
  if (!certify) {
    sizeScratch();
    buf.batchCells[0] = 0;
    const std::uint32_t leafCount = walkCells.template operator()<false>(1, [](std::uint32_t, double) {});
    const std::uint32_t* const byBegin = orderLeaves(leafCount);
    std::uint32_t n = 0;
    for (std::uint32_t l = 0; l < leafCount; ++l) {
      const Cell& cell = tree.cells[buf.batchLeaves[byBegin[l]]];
      for (std::uint32_t k = cell.begin; k < cell.end; ++k) buf.batchNodes[n++] = k;
    }
    tested = n;
    testNodes.template operator()<false>(buf.batchNodes.data(), n, nullptr);
    sortByNode(buf, first);
    return tested;
  }
  // A certified walk covers the tree with two lists (see
  // Certificate): the frontier, cells rejected with their margins, and the
  // leaves kept, with a margin per node and for the leaf's cell: the same
  // when its test rejected it, or minus the margin by which it passed (its
  // test cannot reject it before a move that large: it is not made, the
  // nodes are tested), or 0 (make it). What the map has not moved by as
  // much as its margin cannot change its test's outcome now, and is not
  // tested. A whole walk is the case of a frontier of the root alone, with
  // margin 0.
  //
  // Rebasing: a walk whose move reaches the frontier's least margin walks
  // again the frontier cells whose margins it reaches (or one more move as
  // large would, below), and the certificate
  // is re-made at this step's map; what is not tested keeps its margin less
  // the move (a point that moves d from here has moved at most d + moved
  // from the old map). Otherwise (a leaf walk) the frontier stays as it is
  // and the margins stay relative to the certificate's map: a margin m
  // measured now bounds the one there from below by m - moved.
  constexpr std::uint32_t kSlots = detail::KeptLeaf::kNodeSlots;
  // A margin m > 0 stored as a float no larger than it (a float rounds
  // within 2^-24 of m; none certifies more than 1e30 cells); 0 for m <= 0
  // (and NaN), which certifies nothing.
  constexpr double kLowering = 1.0 - 0x1p-20;
  const auto lowered = [](double m) { return m > 0.0 ? float(std::min(m * kLowering, 1e30)) : 0.0f; };
  const bool rebase = previous == nullptr || !(moved + kCertificateSlack < previous->restClearance);
  // A frontier walk refines the lists and never merges them back: once they
  // hold more than twice the entries of the last whole walk, walk it whole.
  if (previous && rebase &&
      previous->frontierCount + previous->leafCount > 2 * std::uint64_t(previous->wholeEntries) + 8) {
    previous = nullptr;
  }
  if (!previous) moved = 0.0;
  const detail::RejectedCell wholeTree{0, 0.0f};
  const std::span<const detail::RejectedCell> oldFrontier =
      previous ? std::span(key->previousFrontier, previous->frontierCount) : std::span(&wholeTree, 1);
  const std::span<const detail::KeptLeaf> oldLeaves =
      previous ? std::span(key->previousLeaves, previous->leafCount) : std::span<const detail::KeptLeaf>();
  const double movedBound = moved + kCertificateSlack;  // a margin above this still holds
  const double carried = rebase ? moved : 0.0;          // what a margin not measured again loses
  const double measuredLoss = rebase ? 0.0 : moved;     // what a margin measured now loses
  // The least margins: of the frontier, and of the kept leaves' cells and nodes.
  double clearFrontier = std::numeric_limits<double>::infinity();
  double clearLeaves = std::numeric_limits<double>::infinity();
  const std::uint32_t leafFirst = std::uint32_t(buf.leaves.size());
  const std::uint32_t frontierFirst = std::uint32_t(buf.frontier.size());
  const auto addFrontier = [&](std::uint32_t cell, double m) {
    buf.frontier.push_back({cell, lowered(m)});
    clearFrontier = std::min(clearFrontier, m);
  };
  // The nodes to test (tree position, and the index in buf.leaves of their
  // leaf): those of the leaves a walk passes, and those of kept leaves whose
  // margins no longer hold; tested in one batch once the walk is done, with
  // one look-up each for the value and gradient. Taken one by one, a kept
  // leaf's nodes each waited for their grid corners in turn; in the batch,
  // without a branch between them, those waits overlap. Where the grids do
  // not fit in the caches (fragments re-gridded finer: three grains 3D in
  // its crushing stage) the retests spend most of their time there.
  sizeScratch();
  std::uint32_t* const queued = buf.batchNodes.data();
  std::uint32_t* const owners = buf.batchOwners.data();
  std::uint32_t queuedCount = 0;
  const auto queue = [&](std::uint32_t k, std::size_t leaf) {
    queued[queuedCount] = k;
    owners[queuedCount] = std::uint32_t(leaf);
    ++queuedCount;
  };
  // Where a leaf's least node margin starts, before its slots' margins:
  // 0 for a leaf with nodes beyond its slots (tested every walk).
  const auto leastNodeFrom = [](const Cell& cell) {
    return cell.end - cell.begin > kSlots ? 0.0f : std::numeric_limits<float>::infinity();
  };
  // A leaf the walk passed (margin `passed`): kept, its nodes queued.
  const auto keepLeaf = [&](std::uint32_t index, double passed) {
    const typename geometry::NodeTree<D>::Cell& cell = tree.cells[index];
    // (The cubic path appends a copy: see the node records above.)
    if constexpr (Cubic) {
      buf.leaves.push_back(detail::KeptLeaf{});
    } else {
      buf.leaves.emplace_back();
    }
    detail::KeptLeaf& kept = buf.leaves.back();
    kept.cell = index;
    kept.cellMargin = -lowered(passed - measuredLoss);
    // (Its nodes' margins, and their least, come with the batch's tests below.)
    kept.leastNode = leastNodeFrom(cell);
    tested += cell.end - cell.begin;
    for (std::uint32_t k = cell.begin; k < cell.end; ++k) queue(k, buf.leaves.size() - 1);
  };
  // A kept leaf: its cell and nodes tested where their margins do not hold.
  // Rebasing, a leaf whose cell is rejected joins the frontier.
  const auto retestLeaf = [&](const detail::KeptLeaf& old) {
    const double cellClear = double(old.cellMargin);
    if (movedBound < cellClear) {
      if (rebase) return addFrontier(old.cell, cellClear - carried);
      buf.leaves.push_back(old);
      clearLeaves = std::min(clearLeaves, cellClear);
      return;
    }
    const typename geometry::NodeTree<D>::Cell& cell = tree.cells[old.cell];
    float cellMargin = old.cellMargin;
    if (!(movedBound < -cellClear)) {
      ++buf.cellChecks;
      double clear = 0.0;
      if (cellRejected(cell, clear)) {
        if (rebase) return addFrontier(old.cell, clear);
        buf.leaves.emplace_back(old).cellMargin = lowered(clear - measuredLoss);
        clearLeaves = std::min(clearLeaves, clear - measuredLoss);
        return;
      }
      cellMargin = -lowered(clear - measuredLoss);
    } else if (rebase) {
      cellMargin = -lowered(-cellClear - carried);
    }
    // (Changed in the list's own copy: a local one written field by field,
    // then copied whole, had its copy wait for those stores to land.)
    detail::KeptLeaf& kept = buf.leaves.emplace_back(old);
    kept.cellMargin = cellMargin;
    const std::uint32_t slots = std::min(cell.end - cell.begin, kSlots);
    if (movedBound < double(old.leastNode)) {
      // Every node's margin holds: none is tested. (The least of the
      // margins less `carried`, lowered, is the least of those lowered
      // one by one: both steps keep the order.)
      const double m = double(old.leastNode) - carried;
      clearLeaves = std::min(clearLeaves, m);
      if (rebase) {
        for (std::uint32_t j = 0; j < slots; ++j) kept.nodeMargin[j] = lowered(double(old.nodeMargin[j]) - carried);
        kept.leastNode = lowered(m);
      }
      return;
    }
    const std::size_t index = buf.leaves.size() - 1;
    for (std::uint32_t k = cell.begin; k < cell.end; ++k) {
      const std::uint32_t j = k - cell.begin;
      if (j < kSlots && movedBound < double(old.nodeMargin[j])) {
        const double m = double(old.nodeMargin[j]) - carried;
        clearLeaves = std::min(clearLeaves, m);
        if (rebase) kept.nodeMargin[j] = lowered(m);
        continue;
      }
      ++tested;
      // (Its margin comes with the batch, below: none until then.)
      if (j < kSlots) kept.nodeMargin[j] = std::numeric_limits<float>::infinity();
      queue(k, index);
    }
    float least = leastNodeFrom(cell);
    for (std::uint32_t j = 0; j < slots; ++j) least = std::min(least, kept.nodeMargin[j]);
    kept.leastNode = least;
  };
  if (!rebase) {
    // A leaf walk: the frontier holds, as it is.
    buf.frontier.insert(buf.frontier.end(), oldFrontier.begin(), oldFrontier.end());
    clearFrontier = previous->restClearance;
    for (const detail::KeptLeaf& old : oldLeaves) retestLeaf(old);
    ++buf.leafWalks;
  } else {
    // The frontier, then the kept leaves: together they cover the tree
    // once, so the order is free (the contacts are sorted by node below).
    // The frontier cells walked again are the roots of one batched walk:
    // its rejected cells join the frontier, its leaves that pass are kept.
    // (Also walked again when one more move as large would use its margin
    // up: measured afresh, a margin is mostly larger than one carried less
    // the move's bound, and the certificate holds longer. The discharge:
    // 3.5-5 % less time than walking only those used up.) Without a branch
    // on the outcome: each cell is written to both lists and counted in
    // one, and the least margin carried is kept in a local (clearFrontier,
    // which the lambdas share, would go through memory for each cell).
    const std::size_t base = buf.frontier.size();
    buf.frontier.resize(base + oldFrontier.size());
    detail::RejectedCell* const carriedTo = buf.frontier.data() + base;
    std::uint32_t* const rootsTo = buf.batchCells.data();
    std::uint32_t carriedCount = 0, roots = 0;
    double leastCarried = clearFrontier;
    for (const detail::RejectedCell& old : oldFrontier) {
      const double m = double(old.margin);
      const bool carry = movedBound + moved < m;
      // (lowered(m - carried) for a cell carried, whose m - carried is
      // above movedBound > 0 and below 1e30; written for every cell.)
      carriedTo[carriedCount] = {old.cell, float((m - carried) * kLowering)};
      carriedCount += carry;
      rootsTo[roots] = old.cell;
      roots += !carry;
      leastCarried = carry ? std::min(leastCarried, m - carried) : leastCarried;
    }
    buf.frontier.resize(base + carriedCount);
    clearFrontier = leastCarried;
    const std::uint32_t leafCount = walkCells.template operator()<true>(
        roots, [&](std::uint32_t cell, double clear) { addFrontier(cell, clear - measuredLoss); });
    const std::uint32_t* const byBegin = orderLeaves(leafCount);
    for (std::uint32_t l = 0; l < leafCount; ++l) {
      keepLeaf(buf.batchLeaves[byBegin[l]], buf.batchValues[cellSpace + byBegin[l]]);
    }
    for (const detail::KeptLeaf& old : oldLeaves) retestLeaf(old);
    if (previous) ++buf.frontierWalks;
  }
  // The queued nodes, in one batch; their margins to their leaves.
  if (queuedCount > 0) {
    double* const margins = buf.batchValues.data();
    testNodes.template operator()<true>(queued, queuedCount, margins);
    double leastNode = clearLeaves;  // (a local, as leastCarried above)
    for (std::uint32_t e = 0; e < queuedCount; ++e) {
      const double m = margins[e] - measuredLoss;
      leastNode = std::min(leastNode, m);
      detail::KeptLeaf& kept = buf.leaves[owners[e]];
      const std::uint32_t j = queued[e] - tree.cells[kept.cell].begin;
      if (j < kSlots) {
        kept.nodeMargin[j] = lowered(m);
        kept.leastNode = std::min(kept.leastNode, kept.nodeMargin[j]);
      }
    }
    clearLeaves = leastNode;
  }
  detail::Certificate<D> made = previous ? *previous : detail::Certificate<D>{};
  if (rebase) {
    made.owner = key->owner;
    made.other = key->other;
    made.ownerShape = &owner;
    made.otherShape = &other;
    made.map = map;
    made.shift = shift;
  }
  made.restClearance = clearFrontier;
  made.clearance = buf.nodes.size() > first ? 0.0 : std::min(clearFrontier, clearLeaves);
  made.leafThread = key->thread;
  made.leafFirst = leafFirst;
  made.leafCount = std::uint32_t(buf.leaves.size()) - leafFirst;
  made.frontierFirst = frontierFirst;
  made.frontierCount = std::uint32_t(buf.frontier.size()) - frontierFirst;
  if (!previous) made.wholeEntries = made.leafCount + made.frontierCount;
  *key->out = made;
  sortByNode(buf, first);
  return tested;
}

// A particle's nodes against a plane (one-sided, weight 1); `offset` is the
// signed distance of the particle's centroid from the plane. A tree cell
// whose sphere lies wholly on the free side is skipped (one dot product).
// Returns the number of nodes tested one by one.
template <int D, ForceFormulation Formulation>
std::uint64_t collectPlane(const Shape<D>& owner, const Mat<D>& Ro, const Vec<D>& xo, const Plane<D>& plane,
                           double offset, ThreadBuffers<D>& buf) {
  // The plane normal in the owner's body frame: distance = offset + nb . x_body.
  const Vec<D> nb = Ro.transpose() * plane.normal;
  const double weightToFactor = weightToFactorOf<D, Formulation>(owner, 1.0);
  const geometry::NodeTree<D>& tree = owner.nodeTree();
  const std::vector<Vec<D>>& nodes = owner.nodes().positions;
  const std::vector<double>& weights = owner.nodes().weights;
  const std::size_t first = buf.nodes.size();
  if (tree.cells.empty()) return 0;
  // Level by level, as the level-set walks (collectLevelSet's walkCells):
  // a level's loop takes no branch on a cell's test, so a resting grain's
  // walk, whose cells pass and fail in no pattern, does not stall on
  // mispredicted branches. Scratch: each list holds a cell or node at most
  // once.
  const std::size_t cellSpace = tree.cells.size() + 2;
  atLeast(buf.batchCells, 2 * cellSpace);
  atLeast(buf.batchLeaves, cellSpace);
  atLeast(buf.batchLive, nodes.size());
  std::uint32_t* level = buf.batchCells.data();
  std::uint32_t* next = level + cellSpace;
  std::uint32_t* const leaves = buf.batchLeaves.data();
  const typename geometry::NodeTree<D>::Cell* const cells = tree.cells.data();
  const Vec<D> nb_ = nb;
  const double offset_ = offset;
  std::uint32_t count = 1, leafCount = 0;
  level[0] = 0;
  // A cell is skipped when its sphere lies wholly on the free side.
  while (count > 0) {
    buf.cellChecks += count;
    std::uint32_t nextCount = 0;
    for (std::uint32_t j = 0; j < count; ++j) {
      const typename geometry::NodeTree<D>::Cell& cell = cells[level[j]];
      const bool passed = !(offset_ + nb_.dot(cell.centre) > cell.radius * (1.0 + 1e-12)), leaf = cell.child == 0;
      leaves[leafCount] = level[j];
      leafCount += passed & leaf;
      next[nextCount] = cell.child;
      next[nextCount + 1] = cell.child + 1;
      nextCount += 2 * std::uint32_t(passed & !leaf);
    }
    std::swap(level, next);
    count = nextCount;
  }
  // The passed leaves' nodes below the plane (tree positions), then their records.
  std::uint32_t* const inside = buf.batchLive.data();
  std::uint32_t insideCount = 0;
  std::uint64_t tested = 0;
  const Vec<D>* const positions = nodes.data();
  const std::uint32_t* const order = tree.order.data();
  for (std::uint32_t l = 0; l < leafCount; ++l) {
    const typename geometry::NodeTree<D>::Cell& cell = cells[leaves[l]];
    tested += cell.end - cell.begin;
    for (std::uint32_t k = cell.begin; k < cell.end; ++k) {
      inside[insideCount] = k;
      insideCount += offset_ + nb_.dot(positions[order[k]]) < 0.0;
    }
  }
  std::size_t n = buf.nodes.size();
  buf.nodes.resize(n + insideCount);
  buf.work.resize(n + insideCount);
  for (std::uint32_t c = 0; c < insideCount; ++c, ++n) {
    const std::uint32_t i = order[inside[c]];
    const Vec<D>& x = positions[i];
    NodeContact<D>& record = *::new (static_cast<void*>(&buf.nodes[n])) NodeContact<D>();
    record.point = Ro * x + xo;
    record.normal = plane.normal;
    record.overlap = -(offset_ + nb_.dot(x));
    record.node = i;
    NodeWork<D>& w = *::new (static_cast<void*>(&buf.work[n])) NodeWork<D>();
    w.stiffness = stiffnessFactor<Formulation>(weights[i], weightToFactor);
    w.area = weights[i];
  }
  sortByNode(buf, first);
  return tested;
}

// The dashpot at the edge of a contact. The integrator samples a node's force
// once per step, and the sample stands for the impulse over the step around
// it; the elastic force vanishes at the edge of contact, but the dashpot
// force c v_n does not, so a sample taken in the first or last step of a
// contact would charge a whole step of dashpot impulse for the fraction of the
// step the node actually touched, and the restitution would depend on where
// in a step the contact starts and ends (by up to +-zeta omega dt / e). With
// r = overlap / (|v_n| dt) the contact began (or ends) r steps before (after)
// the sample; when r < 1 this is its first (last) sample, which stands for
// 1/2 + r steps of contact (in [1/2, 3/2]); otherwise it stands for one step.
// Exact for a contact entered and left at constant normal speed.
inline double boundaryWeight(double overlap, double normalSpeed, double dt) {
  const double travel = std::abs(normalSpeed) * dt;
  return overlap < travel ? 0.5 + overlap / travel : 1.0;
}

// The contact law for one pair (a, b) whose node contacts are
// buf.nodes[begin, end): normal force (linear per node or Hertz per pair),
// damping, friction with history; fills each node's force and shear, and
// appends the pair's record and its dashpot's to buf.
// `invMassSum` = 1/ma + 1/mb (1/ma against a boundary); `centreB` is the point
// b's torque is taken about; b's material velocity at x is
// vbAtA + wb x (x - xa) (vbAtA: at a's centroid xa; wb: b's spin, 0 for a
// plane); `Boundary`: b is a plane or tool.
template <int D, NormalModel Normal, bool Friction, bool Damping, bool Boundary>
void applyLaw(ThreadBuffers<D>& buf, std::size_t begin, std::uint32_t a, std::uint32_t b, const LawConstants& law,
              double invMassSum, double hertzRadius, const Vec<D>& xa, const Vec<D>& va, const Spin<D>& wa,
              const Vec<D>& centreB, const Vec<D>& vbAtA, const Spin<D>& wb, const HistoryView<D>& history,
              const NewbornView& newborn) {
  const std::size_t end = buf.nodes.size();
  PairContact<D> rec;
  rec.a = a;
  rec.b = b;
  rec.firstNode = std::uint32_t(begin);
  rec.nodeCount = std::uint32_t(end - begin);
  PairDashpot<D> dash;
  // The per-node outputs of the pair's node contacts: node keys, rest
  // overlaps, shear (below).
  buf.keys.resize(end);
  buf.preload.resize(end, 0.0);
  if constexpr (Friction) buf.shear.resize(end);
  for (std::size_t j = begin; j < end; ++j) buf.keys[j] = nodeKey(buf.nodes[j]);
  // Each node contact's record in the history (both lists ascend by node key)
  // and its spring's rest overlap: carried (and drawn in with the node), or
  // its overlap at birth for a node born this step (NarrowPhase.h).
  if (history.count > 0 || !newborn.empty()) {
    std::uint32_t cursor = 0;
    for (std::size_t j = begin; j < end; ++j) {
      const NodeContact<D>& c = buf.nodes[j];
      NodeWork<D>& w = buf.work[j];
      const std::uint32_t key = buf.keys[j];
      while (cursor < history.count && history.keys[cursor] < key) ++cursor;
      double preload = 0.0;
      if (cursor < history.count && history.keys[cursor] == key) {
        w.history = cursor;
        if (history.preload) preload = std::min(history.preload[cursor], c.overlap);
      } else if (!newborn.empty()) {
        preload = newborn.restOverlap(c);
      }
      buf.preload[j] = preload;
      buf.anyPreload = buf.anyPreload || preload > 0.0;
    }
  }
  // Pair-level normal stiffness K; for Hertz also the force and its spreading weights w_i delta_i.
  double stiffness = 0.0, hertz = 0.0, deepest = 0.0, spreadTotal = 0.0;
  if constexpr (Normal == NormalModel::Linear) {
    (void)hertzRadius;
    for (std::size_t j = begin; j < end; ++j) stiffness += buf.work[j].stiffness;
    stiffness *= law.kn;
  } else {
    for (std::size_t j = begin; j < end; ++j) {
      const double overlap = buf.nodes[j].overlap - buf.preload[j];
      deepest = std::max(deepest, overlap);
      spreadTotal += buf.work[j].area * overlap;
    }
    hertz = hertzForce(law.eStar, hertzRadius, deepest);
    stiffness = hertzStiffness(law.eStar, hertzRadius, deepest);
  }
  // Mindlin: the pair's no-slip tangential stiffness, shared like the Hertz force.
  double mindlin = 0.0;
  if constexpr (Normal == NormalModel::Hertz && Friction) mindlin = mindlinStiffness(law.gStar, hertzRadius, deepest);
  // Dashpot of the pair, C = 2 zeta sqrt(m_eff K), shared like the stiffness.
  double damping = 0.0;
  if constexpr (Damping) {
    if (invMassSum > 0.0) damping = dampingCoefficient(law.zeta, 1.0 / invMassSum, stiffness);
  } else {
    (void)invMassSum;
  }

  // Node by node: normal, damping and friction forces, summed into the
  // pair (in locals, written to the records once).
  double elastic = 0.0, power = 0.0;
  Vec<D> sumForce = Vec<D>::Zero(), dashForce = Vec<D>::Zero();
  Spin<D> torqueA = Rotation<D>::zeroSpin(), dashTorqueA = Rotation<D>::zeroSpin();
  double dashPower = 0.0;
  NodeContact<D>* const nodes = buf.nodes.data();
  const NodeWork<D>* const work = buf.work.data();
  const double* const preloads = buf.preload.data();
  Vec<D>* const shears = Friction ? buf.shear.data() : nullptr;
  // Velocity of a's material point relative to b's at arm r from xa:
  // relative0 + spin x r (both bodies rigid).
  const Vec<D> relative0 = va - vbAtA;
  const Spin<D> spin = wa - wb;
  for (std::size_t j = begin; j < end; ++j) {
    NodeContact<D>& c = nodes[j];
    const NodeWork<D>& w = work[j];
    const Vec<D> arm = c.point - xa;
    const double overlap = c.overlap - preloads[j];  // the spring's own compression
    // Elastic normal force and the node's share of the pair's stiffness.
    double fn = 0.0, share = 0.0;
    if constexpr (Normal == NormalModel::Linear) {
      // F = k delta grad phi (eq. 4 takes the gradient itself as the normal):
      // the force of the potential k phi^2 / 2, so undamped, frictionless
      // contacts conserve energy even where the interpolated level set is not
      // exactly a distance (|grad phi| != 1 deep inside or near corners).
      const double k = law.kn * w.stiffness;
      fn = k * overlap * w.gradient;
      share = stiffness > 0.0 ? k / stiffness : 0.0;
      elastic += 0.5 * k * overlap * overlap;
    } else {
      share = spreadTotal > 0.0 ? w.area * overlap / spreadTotal : 0.0;
      fn = hertz * share;
    }
    Vec<D> force;
    if constexpr (Damping || Friction) {
      // Velocity of a's material point relative to b's at the contact point.
      const Vec<D> vrel = relative0 + Rotation<D>::velocityAt(spin, arm);
      const double vn = vrel.dot(c.normal);
      // Dashpot opposing the normal relative velocity, weighted by the part of
      // the step the node is in contact (see boundaryWeight).
      if constexpr (Damping) {
        const double cn = damping * share * boundaryWeight(overlap, vn, law.dt);
        // No tensile contact force: a separating dashpot may cancel the
        // spring's push but never pull (ContactLaw.h); the ledger books the
        // dashpot force actually applied.
        const double fdn = std::max(-cn * vn, -fn);
        fn += fdn;
        const double p = -fdn * vn;
        power += p;
        // The dashpot's own force and moments, for the energy ledger.
        const Vec<D> fd = fdn * c.normal;
        dashForce += fd;
        dashTorqueA += Rotation<D>::moment(arm, fd);
        dashPower += p;
      }
      force = fn * c.normal;
      if constexpr (Friction) {
        // Previous shear of this node contact (both lists ascend by node key),
        // turned into the current tangent plane with its length kept.
        Vec<D> shear = Vec<D>::Zero();
        double oldEnergy = 0.0, old2 = 0.0;  // Mindlin: the spring's energy at its old stiffness, |s|^2
        if (w.history >= 0 && history.shear) {
          const std::size_t cursor = std::size_t(w.history);
          const Vec<D>& old = history.shear[cursor];
          shear = old - old.dot(c.normal) * c.normal;
          old2 = old.squaredNorm();
          const double projected2 = shear.squaredNorm();
          if (projected2 > 0.0) shear *= std::sqrt(old2 / projected2);
          if constexpr (Normal == NormalModel::Hertz) {
            // The old spring force is k_t,old s_old (also when it slid), so its
            // energy k_t,old |s_old|^2 / 2 = |f_t,old| |s_old| / 2.
            if (mindlin > 0.0) {
              const NodeContact<D>& prev = history.nodes[cursor];
              const Vec<D> ftOld = prev.force - prev.force.dot(prev.normal) * prev.normal;
              oldEnergy = 0.5 * ftOld.norm() * std::sqrt(old2);
            }
          }
        }
        // Add this step's tangential displacement; spring force capped by Coulomb.
        shear += law.shearDt * (vrel - vn * c.normal);
        const double kt = law.ks * w.stiffness + mindlin * share;
        // Mindlin: the stiffness change's energy at the old displacement is a
        // loss of the contact, not work of the bodies (ContactLaw.h).
        if constexpr (Normal == NormalModel::Hertz) {
          if (mindlin > 0.0) power += (oldEnergy - 0.5 * kt * old2) / law.dt;
        }
        Vec<D> ft = -kt * shear;
        const double cap = law.mu * std::max(fn, 0.0);
        // Compared squared: the square root only for a sliding node.
        double ft2 = ft.squaredNorm();
        if (ft2 > cap * cap) {
          // Sliding: the force sits on the cap, the spring is shortened to match,
          // and the slip (|ft| - cap) / kt dissipates cap x slip.
          const double ftNorm = std::sqrt(ft2);
          power += cap * (ftNorm - cap) / (kt * law.dt);
          const double scale = cap / ftNorm;
          ft *= scale;
          shear *= scale;
          ft2 = ft.squaredNorm();
        }
        // The spring's energy k_t |s|^2 / 2 (= |f_t|^2 / (2 k_t): f_t = -k_t s, sliding or not).
        elastic += 0.5 * kt * shear.squaredNorm();
        shears[j] = shear;
        force += ft;
      }
    } else {
      force = fn * c.normal;
    }
    // This node's force on a, and its moment about a's centroid.
    c.force = force;
    sumForce += force;
    torqueA += Rotation<D>::moment(arm, force);
  }
  // The moments on b about its reference point, from the sums: a node's arm
  // about it is its arm about a's centroid plus (xa - centreB).
  const Vec<D> fromB = xa - centreB;
  rec.force = sumForce;
  rec.torqueA = torqueA;
  rec.torqueB = -(torqueA + Rotation<D>::moment(fromB, sumForce));
  if constexpr (Damping) {
    dash.force = dashForce;
    dash.torqueA = dashTorqueA;
    // What the energy ledger reads (World.cpp): b's moment for a particle
    // pair; for a boundary, the dashpot's work rate on it, sum fd . (vbAtA +
    // wb x r) = F_d . vbAtA + wb . (sum r x fd).
    if constexpr (Boundary) {
      dash.boundaryPower = dashForce.dot(vbAtA) + Rotation<D>::dot(wb, dashTorqueA);
    } else {
      dash.torqueB = -(dashTorqueA + Rotation<D>::moment(fromB, dashForce));
    }
    dash.power = dashPower;
  }
  if constexpr (Normal == NormalModel::Hertz) elastic += 0.4 * hertz * deepest;
  rec.elasticEnergy = elastic;
  rec.dissipatedPower = power;
  buf.pairs.push_back(rec);
  buf.dashpots.push_back(dash);
}

// Calls f(std::true_type) or f(std::false_type): a runtime flag made a template argument.
template <class F>
void withFlag(bool flag, F&& f) {
  if (flag) {
    f(std::true_type{});
  } else {
    f(std::false_type{});
  }
}

// Birth records by owner id, then node (NewbornView's look-up order).
void sortBirthRecords(std::vector<BirthNode>& records) {
  std::stable_sort(records.begin(), records.end(), [](const BirthNode& x, const BirthNode& y) {
    return x.id < y.id || (x.id == y.id && x.node < y.node);
  });
}

bool keyLess(const HistoryPair& h, std::uint64_t idA, std::uint64_t other) {
  return h.idA < idA || (h.idA == idA && h.other < other);
}

// The order of certificateOrder_: by (owner, other), as keyLess orders history_.
template <int D>
bool certificateLess(const detail::Certificate<D>& c, std::uint64_t owner, std::uint64_t other) {
  return c.owner < owner || (c.owner == owner && c.other < other);
}

// Appends pair `p` of a history to `to` with its node records, shear springs
// and rest overlaps, read from arrays aligned with `nodes` (p.first indexes
// them; an empty `shear` or `preload` gives zeros where `to` keeps one).
template <class History, class Nodes, class Shears, class Preloads>
void appendHistoryPair(History& to, detail::HistoryPair p, const Nodes& nodes, const Shears& shear,
                       const Preloads& preload, bool withShear, bool withPreload) {
  using Shear = typename decltype(to.shear)::value_type;
  const std::size_t from = p.first, to0 = to.nodes.size();
  p.first = std::uint32_t(to0);
  to.pairs.push_back(p);
  to.nodes.insert(to.nodes.end(), nodes.begin() + from, nodes.begin() + from + p.count);
  if (withShear) {
    if (shear.empty()) {
      to.shear.resize(to.nodes.size(), Shear::Zero());
    } else {
      to.shear.insert(to.shear.end(), shear.begin() + from, shear.begin() + from + p.count);
    }
  }
  if (withPreload) {
    if (preload.empty()) {
      to.preload.resize(to.nodes.size(), 0.0);
    } else {
      to.preload.insert(to.preload.end(), preload.begin() + from, preload.begin() + from + p.count);
    }
  }
}

}  // namespace

template <int D>
ContactSolver<D>::ContactSolver(const ContactLawDef& law) : law_(law) {
  validateContactLaw(law_);
}

template <int D>
void ContactSolver<D>::markNewborn(std::uint64_t particleId, std::span<const std::uint32_t> nodes) {
  for (std::uint32_t node : nodes) {
    newborn_.push_back(BirthNode{particleId, kAnyPartner, node, 0, std::numeric_limits<double>::infinity()});
  }
}

template <int D>
void ContactSolver<D>::inheritRestOverlap(std::uint64_t particleId, std::uint64_t partner, std::uint32_t node,
                                          double restOverlap) {
  if (!(restOverlap > 0.0)) return;
  newborn_.push_back(BirthNode{particleId, partner, node, 0, restOverlap});
}

template <int D>
std::uint64_t ContactSolver<D>::partnerKey(const Particles<D>& particles, std::size_t k) const {
  const std::uint32_t b = pairs_[k].b;
  if (k < particlePairCount_) return particles.id[b];
  return (k < particlePairCount_ + planePairCount_ ? kPlaneTag : kToolTag) | std::uint64_t(b);
}

template <int D>
std::vector<typename ContactSolver<D>::RestOverlap> ContactSolver<D>::restOverlaps(const Particles<D>& particles,
                                                                                   std::size_t index) const {
  std::vector<RestOverlap> out;
  if (preload_.empty()) return out;
  copyPendingRecords();
  for (std::size_t k = 0; k < pairs_.size(); ++k) {
    const PairContact<D>& rec = pairs_[k];
    const bool particlePair = k < particlePairCount_;
    if (rec.a != index && !(particlePair && rec.b == index)) continue;
    const std::uint64_t keyOfB = partnerKey(particles, k);
    const std::uint64_t idA = particles.id[rec.a];
    for (std::uint32_t q = rec.firstNode; q < rec.firstNode + rec.nodeCount; ++q) {
      if (!(preload_[q] > 0.0)) continue;
      const NodeContact<D>& c = nodes_[q];
      out.push_back(RestOverlap{c.ownerIsB ? keyOfB : idA, c.ownerIsB ? idA : keyOfB, c.node, preload_[q]});
    }
  }
  return out;
}

template <int D>
void ContactSolver<D>::setPlaneMaterial(std::size_t index, const BoundaryMaterial& material) {
  const ContactConstants c = boundaryConstants(law_, material);
  if (planeConstants_.size() <= index) planeConstants_.resize(index + 1);
  planeConstants_[index] = c;
}

template <int D>
void ContactSolver<D>::setToolMaterial(std::size_t index, const BoundaryMaterial& material) {
  const ContactConstants c = boundaryConstants(law_, material);
  if (toolConstants_.size() <= index) toolConstants_.resize(index + 1);
  toolConstants_[index] = c;
}

template <int D>
const ContactConstants* ContactSolver<D>::planeConstants(std::size_t index) const {
  return index < planeConstants_.size() && planeConstants_[index] ? &*planeConstants_[index] : nullptr;
}

template <int D>
const ContactConstants* ContactSolver<D>::toolConstants(std::size_t index) const {
  return index < toolConstants_.size() && toolConstants_[index] ? &*toolConstants_[index] : nullptr;
}

template <int D>
void ContactSolver<D>::compute(const Particles<D>& particles, const std::vector<Pair>& pairs,
                               const std::vector<Plane<D>>& planes, const std::vector<ToolPose<D>>& tools, double dt,
                               bool advanceShear) {
  // Check the inputs before anything changes.
  if (!(dt > 0.0) || !std::isfinite(dt)) {
    std::ostringstream msg;
    msg << "contact solver: dt must be > 0 s, got " << dt;
    throw std::invalid_argument(msg.str());
  }
  const std::size_t n = particles.size();
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const auto [a, b] = pairs[k];
    if (a >= n || b >= n || !(particles.id[a] < particles.id[b])) {
      std::ostringstream msg;
      msg << "contact solver: pair " << k << " = (" << a << ", " << b << ") is out of range (" << n
          << " particles) or not in canonical order (id of a < id of b)";
      throw std::invalid_argument(msg.str());
    }
  }
  for (std::size_t j = 0; j < planes.size(); ++j) {
    const double length = planes[j].normal.norm();
    if (!(std::abs(length - 1.0) <= 1e-6)) {
      std::ostringstream msg;
      msg << "contact solver: plane " << j << " normal must be a unit vector, |n| = " << length;
      throw std::invalid_argument(msg.str());
    }
  }
  for (std::size_t j = 0; j < tools.size(); ++j) {
    if (tools[j].shape == nullptr) {
      throw std::invalid_argument("contact solver: tool " + std::to_string(j) + " has no shape");
    }
  }
  particleCount_ = n;
  planeCount_ = planes.size();
  toolCount_ = tools.size();

  // Run the kernel compiled for the law's parts.
  const auto withNormal = [&](auto next) {
    if (law_.normal == NormalModel::Hertz) {
      next(std::integral_constant<NormalModel, NormalModel::Hertz>{});
    } else {
      next(std::integral_constant<NormalModel, NormalModel::Linear>{});
    }
  };
  const auto withFormulation = [&](auto next) {
    if (law_.formulation == ForceFormulation::AreaWeighted) {
      next(std::integral_constant<ForceFormulation, ForceFormulation::AreaWeighted>{});
    } else {
      next(std::integral_constant<ForceFormulation, ForceFormulation::PerNode>{});
    }
  };
  // Birth records in look-up order (added in any order since the last compute()).
  if (!newborn_.empty()) sortBirthRecords(newborn_);
  withNormal([&](auto normal) {
    withFormulation([&](auto formulation) {
      withFlag(frictionOn(), [&](auto friction) {
        withFlag(law_.hasDamping, [&](auto damping) {
          this->template run<decltype(normal)::value, decltype(formulation)::value, decltype(friction)::value,
                             decltype(damping)::value>(particles, pairs, planes, tools, dt,
                                                              advanceShear ? dt : 0.0);
        });
      });
    });
  });

  // Concatenate the per-thread records in task order; totals and history.
  const double gatherStart = wallSeconds();
  gather(particles, pairs.size(), planes.empty() ? 0 : n);
  gatherSeconds_ = wallSeconds() - gatherStart;
}

template <int D>
template <NormalModel Normal, ForceFormulation Formulation, bool Friction, bool Damping>
void ContactSolver<D>::run(const Particles<D>& p, const std::vector<Pair>& pairs, const std::vector<Plane<D>>& planes,
                           const std::vector<ToolPose<D>>& tools, double dt, double shearDt) {
  const ContactConstants grains = lawConstants(law_);
  LawConstants law;
  law.kn = grains.kn;
  law.ks = grains.ks;
  law.mu = grains.friction;
  law.zeta = law_.dampingRatio;
  law.eStar = Normal == NormalModel::Hertz ? grains.eStar : 0.0;
  law.gStar = Normal == NormalModel::Hertz && Friction ? grains.gStar : 0.0;
  law.dt = dt;
  law.shearDt = shearDt;

  // The look-up in the other body's level set, chosen once per compute():
  // one direction's walk (collectLevelSet) with it.
  const bool cubic = law_.interpolation == LevelSetInterpolation::Tricubic;
  const auto collect = [cubic](const Shape<D>& owner, const Mat<D>& Ro, const Vec<D>& xo, const Shape<D>& other,
                               const Mat<D>& Rt, const Vec<D>& xt, double directionWeight, double normalSign,
                               std::uint8_t ownerIsB, ThreadBuffers<D>& buf, const CertificateKey<D>* key) {
    return cubic ? collectLevelSet<D, Formulation, true>(owner, Ro, xo, other, Rt, xt, directionWeight, normalSign,
                                                         ownerIsB, buf, key)
                 : collectLevelSet<D, Formulation, false>(owner, Ro, xo, other, Rt, xt, directionWeight, normalSign,
                                                          ownerIsB, buf, key);
  };

  // Tasks: one per candidate pair, then one per particle for the planes and one for the tools.
  const std::size_t n = p.size();
  const std::size_t pairTasks = pairs.size();
  const std::size_t planeTasks = planes.empty() ? 0 : n;
  const std::size_t toolTasks = tools.empty() ? 0 : n;
  tasks_.resize(pairTasks + planeTasks + toolTasks);
  // (The last step's pending records are this step's history: where a
  // thread holding some would go, they are copied first.)
  if (threads_.size() > std::size_t(threadCount())) copyPendingRecords();
  threads_.resize(std::size_t(threadCount()));
  for (ThreadBuffers<D>& buf : threads_) {
    buf.pairs.clear();
    buf.dashpots.clear();
    buf.nodes.clear();
    buf.work.clear();
    buf.shear.clear();
    buf.preload.clear();
    buf.keys.clear();
    buf.anyPreload = false;
    buf.nodeChecks = 0;
    buf.cellChecks = 0;
    buf.certifiedWalks = 0;
    buf.leafWalks = 0;
    buf.frontierWalks = 0;
    std::swap(buf.leaves, buf.previousLeaves);
    buf.leaves.clear();
    std::swap(buf.frontier, buf.previousFrontier);
    buf.frontier.clear();
  }
  // Every particle's rotation matrix, once (a pair task reads two).
  rotations_.resize(n);
  const std::ptrdiff_t particleCount = std::ptrdiff_t(n);
#pragma omp parallel for schedule(static) if (particleCount > 4096)
  for (std::ptrdiff_t i = 0; i < particleCount; ++i) rotations_[std::size_t(i)] = p.rotation(std::size_t(i));
  // Certificates: last step's become the previous; a slot per pair and
  // direction for this step's. Where the pairs are not last step's (a
  // rebuilt Verlet list, particles added or removed), the previous ones are
  // found by their ids instead of their slot.
  const bool certify = certificatesOn_;
  if (certify) {
    std::swap(certificates_, previousCertificates_);
    certificates_.resize(2 * pairTasks + toolTasks * tools.size());
    certificateOrder_.clear();
    if (certificatePairs_ != pairs) {
      for (std::uint32_t q = 0; q < previousCertificates_.size(); ++q) {
        if (previousCertificates_[q].ownerShape) certificateOrder_.push_back(q);
      }
      std::sort(certificateOrder_.begin(), certificateOrder_.end(), [&](std::uint32_t x, std::uint32_t y) {
        return certificateLess(previousCertificates_[x], previousCertificates_[y].owner, previousCertificates_[y].other);
      });
      certificatePairs_ = pairs;
    }
  }
  // The lists of last step's certificate `c` in its thread's buffers, or
  // false: none, or the lists are gone (the thread count may have changed).
  const auto previousLists = [&](const detail::Certificate<D>& c, const detail::KeptLeaf*& leaves,
                                 const detail::RejectedCell*& frontier) {
    if (!c.ownerShape || c.leafThread >= threads_.size()) return false;
    const ThreadBuffers<D>& buffers = threads_[c.leafThread];
    if (std::size_t(c.leafFirst) + c.leafCount > buffers.previousLeaves.size()) return false;
    if (std::size_t(c.frontierFirst) + c.frontierCount > buffers.previousFrontier.size()) return false;
    leaves = buffers.previousLeaves.data() + c.leafFirst;
    frontier = buffers.previousFrontier.data() + c.frontierFirst;
    return true;
  };
  // The walk (owner in other) of task k's slot `slot`: its last certificate, its slot for this step's.
  const auto certificateKey = [&](std::size_t slot, std::uint64_t owner, std::uint64_t other) {
    CertificateKey<D> key{owner, other, nullptr, nullptr, nullptr, &certificates_[slot], std::uint32_t(threadIndex())};
    key.out->ownerShape = nullptr;
    const auto matches = [&](const detail::Certificate<D>& c) {
      return c.owner == owner && c.other == other && previousLists(c, key.previousLeaves, key.previousFrontier);
    };
    if (slot < previousCertificates_.size() && matches(previousCertificates_[slot])) {
      key.previous = &previousCertificates_[slot];
    } else if (!certificateOrder_.empty()) {
      const auto it = std::lower_bound(certificateOrder_.begin(), certificateOrder_.end(), 0,
                                       [&](std::uint32_t q, int) {
                                         return certificateLess(previousCertificates_[q], owner, other);
                                       });
      if (it != certificateOrder_.end() && matches(previousCertificates_[*it])) key.previous = &previousCertificates_[*it];
    }
    return key;
  };

  // Before pair task k: the certificates of task k + 2 and the lists of
  // task k + 1's (a chunk runs its tasks in order; task k + 1's
  // certificates were asked for by task k - 1). Read after a whole walk's
  // other traffic, they missed the cache (3-4 % of the discharge's time).
  const auto prefetchCertificates = [&](std::size_t k) {
    const auto prefetchLines = [](const void* first, std::size_t bytes) {
      const char* at = static_cast<const char*>(first);
      for (std::size_t byte = 0; byte < bytes; byte += 64) __builtin_prefetch(at + byte);
    };
    if (2 * k + 5 < previousCertificates_.size()) {
      prefetchLines(&previousCertificates_[2 * k + 4], 2 * sizeof(detail::Certificate<D>));
    }
    for (std::size_t slot = 2 * k + 2; slot < std::min(2 * k + 4, previousCertificates_.size()); ++slot) {
      const detail::Certificate<D>& c = previousCertificates_[slot];
      const detail::KeptLeaf* leaves = nullptr;
      const detail::RejectedCell* frontier = nullptr;
      if (!previousLists(c, leaves, frontier)) continue;
      // (The first 256 bytes of each: most lists are shorter.)
      prefetchLines(frontier, std::min<std::size_t>(c.frontierCount * sizeof(detail::RejectedCell), 256));
      prefetchLines(leaves, std::min<std::size_t>(c.leafCount * sizeof(detail::KeptLeaf), 256));
    }
  };

  // The previous step's node contacts of a pair key: shear (friction) and
  // rest overlaps (history_ is empty when there are neither).
  const bool withPreload = !preload_.empty();
  const auto historyOf = [&](std::uint64_t idA, std::uint64_t other) {
    HistoryView<D> view;
    if (history_.empty()) return view;
    const auto it = std::lower_bound(history_.begin(), history_.end(), 0,
                                     [&](const HistoryPair& h, int) { return keyLess(h, idA, other); });
    if (it != history_.end() && it->idA == idA && it->other == other) {
      // In the output arrays, or in the held buffers of a pending run (a
      // pair's records lie in one run).
      std::size_t q = it->first;
      const std::uint32_t* keys = historyKeys_.data();
      const NodeContact<D>* nodes = nodes_.data();
      const Vec<D>* shear = shear_.data();
      const double* preload = preload_.data();
      if (!pending_.empty() && q >= pending_.front().outNode) {
        const auto run = std::upper_bound(pending_.begin(), pending_.end(), q,
                                          [](std::size_t at, const TaskOutput& r) { return at < r.outNode; }) -
                         1;
        const ThreadBuffers<D>& held = threads_[run->thread];
        q = q - run->outNode + run->firstNode;
        keys = held.heldKeys.data();
        nodes = held.heldNodes.data();
        shear = held.heldShear.data();
        preload = held.heldPreload.data();
      }
      view.keys = keys + q;
      view.nodes = nodes + q;
      if (Friction && !shear_.empty()) view.shear = shear + q;
      if (withPreload) view.preload = preload + q;
      view.count = it->count;
    }
    return view;
  };
  // The nodes of a particle born this step, ascending.
  const auto newbornOf = [&](std::uint64_t id) -> std::span<const BirthNode> {
    if (newborn_.empty()) return {};
    const auto first = std::lower_bound(newborn_.begin(), newborn_.end(), id,
                                        [](const BirthNode& n, std::uint64_t key) { return n.id < key; });
    auto last = first;
    while (last != newborn_.end() && last->id == id) ++last;
    return {first, last};
  };
  // Particle pairs: both directions, each weighted 1/2 (order independence, see the header).
  const auto pairTask = [&](std::size_t k, ThreadBuffers<D>& buf) {
      const std::uint32_t ia = pairs[k][0], ib = pairs[k][1];
      const Shape<D>& sa = *p.shape[ia];
      const Shape<D>& sb = *p.shape[ib];
      const Vec<D>& xa = p.position[ia];
      const Vec<D>& xb = p.position[ib];
      CertificateKey<D> ab, ba;
      if (certify) {
        prefetchCertificates(k);
        ab = certificateKey(2 * k, p.id[ia], p.id[ib]);
        ba = certificateKey(2 * k + 1, p.id[ib], p.id[ia]);
      }
      // Bounding spheres apart: no node can touch.
      const double reach = lookupRadius(sa, law_.interpolation) + lookupRadius(sb, law_.interpolation);
      if ((xb - xa).squaredNorm() > reach * reach) return;
      // Nodes of a in b, then nodes of b in a.
      const Mat<D>& Ra = rotations_[ia];
      const Mat<D>& Rb = rotations_[ib];
      const std::size_t begin = buf.nodes.size();
      const CertificateKey<D>* abKey = certify ? &ab : nullptr;
      const CertificateKey<D>* baKey = certify ? &ba : nullptr;
      buf.nodeChecks += collect(sa, Ra, xa, sb, Rb, xb, 0.5, 1.0, 0, buf, abKey);
      buf.nodeChecks += collect(sb, Rb, xb, sa, Ra, xa, 0.5, -1.0, 1, buf, baKey);
      if (buf.nodes.size() == begin) return;
      // The law on the pair's node contacts.
      double radius = 0.0;
      if constexpr (Normal == NormalModel::Hertz) {
        radius = combinedRadius(equivalentRadius<D>(sa.volume()), equivalentRadius<D>(sb.volume()));
      }
      const Vec<D>& vb = p.velocity[ib];
      const Spin<D>& wb = p.angularVelocity[ib];
      applyLaw<D, Normal, Friction, Damping, false>(buf, begin, ia, ib, law, p.invMass[ia] + p.invMass[ib], radius, xa,
                                                    p.velocity[ia], p.angularVelocity[ia], xb,
                                                    Vec<D>(vb + Rotation<D>::velocityAt(wb, xa - xb)), wb,
                                                    historyOf(p.id[ia], p.id[ib]),
                                                    NewbornView{newbornOf(p.id[ia]), newbornOf(p.id[ib]), p.id[ib], p.id[ia]});
  };

  // Particles against planes: one-sided, exact distances.
  const auto planeTask = [&](std::size_t i, ThreadBuffers<D>& buf) {
      const Shape<D>& s = *p.shape[std::size_t(i)];
      const Vec<D>& x = p.position[std::size_t(i)];
      for (std::size_t j = 0; j < planes.size(); ++j) {
        const Plane<D>& plane = planes[j];
        // Centroid farther from the plane than the bounding radius: no node can touch.
        const double offset = plane.signedDistance(x);
        if (offset > s.boundingRadius()) continue;
        const std::size_t begin = buf.nodes.size();
        buf.nodeChecks += collectPlane<D, Formulation>(s, rotations_[std::size_t(i)], x, plane, offset, buf);
        if (buf.nodes.size() == begin) continue;
        const double radius = Normal == NormalModel::Hertz ? equivalentRadius<D>(s.volume()) : 0.0;
        applyLaw<D, Normal, Friction, Damping, true>(buf, begin, std::uint32_t(i), std::uint32_t(j),
                                                     boundaryLaw(law, planeConstants(j)), p.invMass[std::size_t(i)],
                                                     radius, x, p.velocity[std::size_t(i)],
                                                     p.angularVelocity[std::size_t(i)], plane.point, plane.velocity,
                                                     Rotation<D>::zeroSpin(),
                                                     historyOf(p.id[std::size_t(i)], kPlaneTag | std::uint64_t(j)),
                                                     NewbornView{newbornOf(p.id[std::size_t(i)]), {}, kPlaneTag | std::uint64_t(j), 0});
      }
  };

  // Particles against tools: the particle's nodes in the tool's level set, weight 1.
  const auto toolTask = [&](std::size_t i, ThreadBuffers<D>& buf) {
      const Shape<D>& s = *p.shape[std::size_t(i)];
      const Vec<D>& x = p.position[std::size_t(i)];
      for (std::size_t j = 0; j < tools.size(); ++j) {
        const ToolPose<D>& tool = tools[j];
        const Shape<D>& ts = *tool.shape;
        // Its certificate's slot: after the pairs', by particle, then tool
        // (made, and so cleared, for every walk, made or skipped).
        CertificateKey<D> key;
        if (certify) key = certificateKey(2 * pairTasks + std::size_t(i) * tools.size() + j, p.id[std::size_t(i)],
                                          kToolTag | std::uint64_t(j));
        // (A view: only the tool contacts its run found; limitToolPairs.)
        if (toolPairs_ && !std::binary_search(toolPairs_->begin(), toolPairs_->end(),
                                              std::array<std::uint64_t, 2>{p.id[std::size_t(i)], j})) {
          continue;
        }
        // Bounding spheres apart: no node can touch.
        const double reach = s.boundingRadius() + lookupRadius(ts, law_.interpolation);
        if ((tool.position - x).squaredNorm() > reach * reach) continue;
        const std::size_t begin = buf.nodes.size();
        const Mat<D> toolRotation = Rotation<D>::matrix(tool.orientation);
        buf.nodeChecks += collect(s, rotations_[std::size_t(i)], x, ts, toolRotation, tool.position, 1.0, 1.0, 0, buf,
                                  certify ? &key : nullptr);
        if (buf.nodes.size() == begin) continue;
        double radius = 0.0;
        if constexpr (Normal == NormalModel::Hertz) {
          radius = combinedRadius(equivalentRadius<D>(s.volume()), equivalentRadius<D>(ts.volume()));
        }
        applyLaw<D, Normal, Friction, Damping, true>(buf, begin, std::uint32_t(i), std::uint32_t(j),
                                                     boundaryLaw(law, toolConstants(j)), p.invMass[std::size_t(i)],
                                                     radius, x, p.velocity[std::size_t(i)],
                                                     p.angularVelocity[std::size_t(i)], tool.position,
                                                     tool.velocityAt(x), tool.angularVelocity,
                                                     historyOf(p.id[std::size_t(i)], kToolTag | std::uint64_t(j)),
                                                     NewbornView{newbornOf(p.id[std::size_t(i)]), {}, kToolTag | std::uint64_t(j), 0});
      }
  };

  // Task k (pairs, then planes, then tools) on the calling thread's
  // buffers: where its records went, and what it cost (tests made and
  // records written: the next step's split into blocks weighs by it).
  const auto runTask = [&](std::size_t k) {
    ThreadBuffers<D>& buf = threads_[std::size_t(threadIndex())];
    TaskOutput& out = tasks_[k];
    out.thread = std::uint32_t(threadIndex());
    out.firstPair = std::uint32_t(buf.pairs.size());
    out.firstNode = std::uint32_t(buf.nodes.size());
    const std::uint64_t checks = buf.nodeChecks + buf.cellChecks;
    if (k < pairTasks) {
      pairTask(k, buf);
    } else if (k < pairTasks + planeTasks) {
      planeTask(k - pairTasks, buf);
    } else {
      toolTask(k - pairTasks - planeTasks, buf);
    }
    out.pairCount = std::uint32_t(buf.pairs.size()) - out.firstPair;
    out.nodeCount = std::uint32_t(buf.nodes.size()) - out.firstNode;
    out.cost = std::uint32_t(std::min<std::uint64_t>(buf.nodeChecks + buf.cellChecks - checks + kRecordCost * out.nodeCount +
                                                          kTaskCost,
                                                      std::numeric_limits<std::uint32_t>::max()));
  };

  // The task list is cut into parts of about equal estimated cost, one per
  // two threads. In a part, one thread takes chunks of consecutive tasks
  // from the front and the other from the back until they meet, so the
  // two finish together whatever their speeds, without an estimate. Chunks
  // keep a thread's records of consecutive tasks contiguous in its buffers,
  // and gather() moves them in bulk (or not at all: the first thread's
  // run from task 0 stays where it is). A thread whose part is done helps
  // with the others (more than two threads), from its own end.
  const bool share = pairTasks > 32 || planeTasks > 256 || toolTasks > 256;
  const std::size_t workers = share ? threads_.size() : 1;
  splitIntoBlocks(tasks_.size(), (workers + 1) / 2);
  const std::size_t blockCount = blocks_.size() - 1;
  cursors_.resize(blockCount);
  for (std::size_t b = 0; b < blockCount; ++b) cursors_[b].reset(std::uint32_t(blocks_[b]), std::uint32_t(blocks_[b + 1]));
  // About 64 chunks per thread, at most 8 tasks each: a chunk is far longer
  // than taking it, and the last one is a small part of the step.
  const std::uint32_t chunk = std::uint32_t(std::clamp<std::size_t>(tasks_.size() / (64 * workers), 1, 8));
  threadSeconds_.assign(threads_.size() * blockCount, 0.0);
  // The parts' seconds weigh the next step's cut (splitIntoBlocks): with
  // one part (up to two threads) there is none to weigh, and the clock is
  // not read (twice per chunk of up to 8 tasks: 1.4 % of the discharge's
  // samples at one thread).
  const bool timed = blockCount > 1;
#pragma omp parallel if (workers > 1)
  {
    const std::size_t thread = std::size_t(threadIndex());
    const bool fromBack = thread % 2 == 1;
    for (std::size_t i = 0; i < blockCount; ++i) {
      const std::size_t b = (thread / 2 + i) % blockCount;
      double& seconds = threadSeconds_[thread * blockCount + b];
      for (;;) {
        const auto [first, last] = cursors_[b].take(chunk, fromBack);
        if (first == last) break;
        const double start = timed ? wallSeconds() : 0.0;
        for (std::size_t k = first; k < last; ++k) runTask(k);
        if (timed) seconds += wallSeconds() - start;
      }
    }
  }
  blockSeconds_.assign(blockCount, 0.0);
  for (std::size_t t = 0; t < threads_.size(); ++t) {
    for (std::size_t b = 0; b < blockCount; ++b) blockSeconds_[b] += threadSeconds_[t * blockCount + b];
  }
  findRuns();
}

template <int D>
void ContactSolver<D>::findRuns() {
  runs_.assign(1, 0);
  for (std::size_t k = 1; k < tasks_.size(); ++k) {
    const TaskOutput& last = tasks_[k - 1];
    const TaskOutput& task = tasks_[k];
    if (task.thread != last.thread || task.firstPair != last.firstPair + last.pairCount ||
        task.firstNode != last.firstNode + last.nodeCount) {
      runs_.push_back(k);
    }
  }
  runs_.push_back(tasks_.size());
}

template <int D>
void ContactSolver<D>::splitIntoBlocks(std::size_t taskCount, std::size_t parts) {
  // Parts of consecutive tasks of about equal time. A task's time is
  // estimated from the last step: the cost of the task at the same relative
  // place in its list (the list changes little between steps), times the
  // seconds per unit of cost its part took then, all threads' seconds on it
  // (which corrects the cost model and a pair of threads slower than the
  // others); 1 each before any.
  parts = std::max<std::size_t>(1, std::min(parts, taskCount));
  const std::size_t known = taskCost_.size();
  const std::size_t lastBlocks = blockSeconds_.size();
  std::vector<double>& rate = blockRate_;
  rate.assign(lastBlocks, 1.0);
  if (known > 0 && lastBlocks > 1 && blocks_.size() == lastBlocks + 1 && blocks_.back() == known) {
    for (std::size_t b = 0; b < lastBlocks; ++b) {
      double cost = 0.0;
      for (std::size_t k = blocks_[b]; k < blocks_[b + 1]; ++k) cost += double(taskCost_[k]);
      if (cost > 0.0 && blockSeconds_[b] > 0.0) rate[b] = blockSeconds_[b] / cost;
    }
    // Relative to their mean, so the units do not matter.
    double mean = 0.0;
    for (const double r : rate) mean += r / double(lastBlocks);
    for (double& r : rate) r /= mean;
  } else {
    rate.assign(1, 1.0);
    blocks_.assign({0, known});
  }
  estimate_.resize(taskCount);
  double total = 0.0;
  std::size_t block = 0;
  for (std::size_t k = 0; k < taskCount; ++k) {
    if (known == 0) {
      estimate_[k] = 1.0;
    } else {
      const std::size_t q = known == taskCount ? k : k * known / taskCount;
      while (block + 1 < rate.size() && q >= blocks_[block + 1]) ++block;
      estimate_[k] = double(taskCost_[q]) * rate[block];
    }
    total += estimate_[k];
  }
  blocks_.assign(1, 0);
  double sum = 0.0;
  for (std::size_t k = 0; k < taskCount && blocks_.size() < parts; ++k) {
    sum += estimate_[k];
    if (sum >= total * double(blocks_.size()) / double(parts)) blocks_.push_back(k + 1);
  }
  while (blocks_.size() <= parts) blocks_.push_back(taskCount);
}

template <int D>
void ContactSolver<D>::gather(const Particles<D>& particles, std::size_t particlePairTasks, std::size_t planeTasks) {
  // Output offsets of every task, in task order; the counts per kind of pair.
  std::uint64_t pairTotal = 0, nodeTotal = 0;
  for (std::size_t k = 0; k < tasks_.size(); ++k) {
    if (k == particlePairTasks) particlePairCount_ = std::size_t(pairTotal);
    if (k == particlePairTasks + planeTasks) planePairCount_ = std::size_t(pairTotal) - particlePairCount_;
    tasks_[k].outPair = pairTotal;
    tasks_[k].outNode = nodeTotal;
    pairTotal += tasks_[k].pairCount;
    nodeTotal += tasks_[k].nodeCount;
  }
  if (tasks_.size() <= particlePairTasks) particlePairCount_ = std::size_t(pairTotal);
  if (tasks_.size() <= particlePairTasks + planeTasks) planePairCount_ = std::size_t(pairTotal) - particlePairCount_;

  // The output is the runs' records in task order (run(): a run is a
  // stretch of consecutive tasks whose records lie one after the other in
  // one thread's buffers). Where one thread's buffers hold exactly the
  // first run's (one thread alone, or the front of the first part while it
  // took nothing else), they become the output and the other runs are
  // appended after them; otherwise every run is appended.
  const bool friction = frictionOn();
  bool anyPreload = false;
  for (const ThreadBuffers<D>& buf : threads_) anyPreload = anyPreload || buf.anyPreload;
  // Only what the next step reads: rest overlaps where some spring has one,
  // node keys where there is a history (friction or rest overlaps).
  const bool keys = friction || anyPreload;
  const auto runAt = [&](std::size_t b) {
    TaskOutput run;
    const std::size_t first = runs_[b], last = runs_[b + 1];
    if (first == last) return run;
    run.thread = tasks_[first].thread;
    run.firstPair = tasks_[first].firstPair;
    run.firstNode = tasks_[first].firstNode;
    run.outPair = tasks_[first].outPair;
    run.outNode = tasks_[first].outNode;
    run.pairCount = std::uint32_t(tasks_[last - 1].outPair + tasks_[last - 1].pairCount - run.outPair);
    run.nodeCount = std::uint32_t(tasks_[last - 1].outNode + tasks_[last - 1].nodeCount - run.outNode);
    return run;
  };
  std::size_t next = 0;  // the first run not yet in the output
  {
    const TaskOutput head = runAt(0);
    ThreadBuffers<D>& buf = threads_[head.thread];
    if (head.firstPair == 0 && head.firstNode == 0 && buf.pairs.size() == head.pairCount &&
        buf.nodes.size() == head.nodeCount) {
      std::swap(pairs_, buf.pairs);
      std::swap(dashpots_, buf.dashpots);
      std::swap(nodes_, buf.nodes);
      std::swap(preload_, buf.preload);
      std::swap(historyKeys_, buf.keys);
      std::swap(shear_, buf.shear);
      next = 1;
    } else {
      pairs_.clear();
      dashpots_.clear();
      nodes_.clear();
      preload_.clear();
      historyKeys_.clear();
      shear_.clear();
    }
  }
  if (!friction) shear_.clear();
  // The other runs' records, after the first's: the arrays grow to their
  // totals (RecordAllocator: unwritten). Their pair records are copied now
  // (few); their node-level records stay where their threads wrote them
  // until read (pending_, copyPendingRecords).
  const std::size_t headPairs = pairs_.size();
  pairs_.resize(pairTotal);
  dashpots_.resize(pairTotal);
  nodes_.resize(nodeTotal);
  if (anyPreload) preload_.resize(nodeTotal);
  if (keys) historyKeys_.resize(nodeTotal);
  if (friction) shear_.resize(nodeTotal);
  // (The last step's pending runs were its history, read by run().)
  const std::size_t runCount = runs_.size() - 1;
  pending_.clear();
  for (std::size_t b = next; b < runCount; ++b) {
    const TaskOutput run = runAt(b);
    if (run.pairCount > 0 || run.nodeCount > 0) pending_.push_back(run);
  }
  copyInShares(
      pending_.size(), pairTotal - headPairs, threads_.size(), [&](std::size_t r) { return pending_[r].pairCount; },
      [&](std::size_t r, std::size_t lo, std::size_t hi) {
        const TaskOutput& run = pending_[r];
        const ThreadBuffers<D>& buf = threads_[run.thread];
        copyRecords(buf.pairs, run.firstPair, pairs_, run.outPair, lo, hi);
        copyRecords(buf.dashpots, run.firstPair, dashpots_, run.outPair, lo, hi);
        for (std::size_t q = run.outPair + lo; q < run.outPair + hi; ++q) {
          pairs_[q].firstNode = std::uint32_t(pairs_[q].firstNode - run.firstNode + run.outNode);
        }
      });
  // The threads holding pending records move them aside (heldNodes ...).
  for (std::size_t t = 0; t < threads_.size(); ++t) {
    if (std::none_of(pending_.begin(), pending_.end(), [&](const TaskOutput& run) { return run.thread == t; })) {
      continue;
    }
    ThreadBuffers<D>& buf = threads_[t];
    std::swap(buf.nodes, buf.heldNodes);
    std::swap(buf.shear, buf.heldShear);
    std::swap(buf.preload, buf.heldPreload);
    std::swap(buf.keys, buf.heldKeys);
  }
  // The next step's blocks weigh tasks by what these cost.
  taskCost_.resize(tasks_.size());
  for (std::size_t k = 0; k < tasks_.size(); ++k) taskCost_[k] = tasks_[k].cost;

  // Totals, summed in output order.
  elasticEnergy_ = 0.0;
  dissipatedPower_ = 0.0;
  for (const PairContact<D>& rec : pairs_) {
    elasticEnergy_ += rec.elasticEnergy;
    dissipatedPower_ += rec.dissipatedPower;
  }
  nodeChecks_ = 0;
  cellChecks_ = 0;
  certifiedWalks_ = 0;
  leafWalks_ = 0;
  frontierWalks_ = 0;
  for (const ThreadBuffers<D>& buf : threads_) {
    nodeChecks_ += buf.nodeChecks;
    cellChecks_ += buf.cellChecks;
    certifiedWalks_ += buf.certifiedWalks;
    leafWalks_ += buf.leafWalks;
    frontierWalks_ += buf.frontierWalks;
  }

  // The marks of nodes born this step are used.
  newborn_.clear();
  // History for the next step: the pair keys, sorted, pointing into nodes_,
  // shear_ and preload_; none without friction and rest overlaps.
  if (!anyPreload) preload_.clear();
  history_.clear();
  if (!friction && !anyPreload) {
    historyKeys_.clear();
    return;
  }
  for (std::size_t k = 0; k < pairs_.size(); ++k) {
    const PairContact<D>& rec = pairs_[k];
    HistoryPair h;
    h.idA = particles.id[rec.a];
    h.other = partnerKey(particles, k);
    h.first = rec.firstNode;
    h.count = rec.nodeCount;
    history_.push_back(h);
  }
  const auto less = [](const HistoryPair& x, const HistoryPair& y) { return keyLess(x, y.idA, y.other); };
  if (!std::is_sorted(history_.begin(), history_.end(), less)) std::sort(history_.begin(), history_.end(), less);
}

template <int D>
void ContactSolver<D>::copyPendingRecords() const {
  const std::lock_guard<std::mutex> lock(pendingLock_.mutex);
  if (pending_.empty()) return;
  // The arrays gather() sized (an array it left empty is not kept).
  const std::size_t total = nodes_.size();
  const bool preload = preload_.size() == total, keys = historyKeys_.size() == total, shear = shear_.size() == total;
  std::size_t copied = 0;
  for (const TaskOutput& run : pending_) copied += run.nodeCount;
  copyInShares(pending_.size(), copied, threads_.size(), [&](std::size_t r) { return pending_[r].nodeCount; },
               [&](std::size_t r, std::size_t lo, std::size_t hi) {
                 const TaskOutput& run = pending_[r];
                 const ThreadBuffers<D>& buf = threads_[run.thread];
                 copyRecords(buf.heldNodes, run.firstNode, nodes_, run.outNode, lo, hi);
                 if (preload) copyRecords(buf.heldPreload, run.firstNode, preload_, run.outNode, lo, hi);
                 if (keys) copyRecords(buf.heldKeys, run.firstNode, historyKeys_, run.outNode, lo, hi);
                 if (shear) copyRecords(buf.heldShear, run.firstNode, shear_, run.outNode, lo, hi);
               });
  pending_.clear();
}

template <int D>
std::size_t ContactSolver<D>::recordBytes() const {
  const auto bytes = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  std::size_t total = bytes(pairs_) + bytes(dashpots_) + bytes(nodes_) + bytes(shear_) + bytes(preload_) +
                      bytes(historyKeys_) + bytes(history_);
  for (const ThreadBuffers<D>& buf : threads_) {
    total += bytes(buf.pairs) + bytes(buf.dashpots) + bytes(buf.nodes) + bytes(buf.work) + bytes(buf.shear) +
             bytes(buf.preload) + bytes(buf.keys) + bytes(buf.leaves) + bytes(buf.previousLeaves) +
             bytes(buf.frontier) + bytes(buf.previousFrontier) + bytes(buf.heldNodes) + bytes(buf.heldShear) +
             bytes(buf.heldPreload) + bytes(buf.heldKeys);
  }
  return total;
}

template <int D>
typename ContactSolver<D>::ParticleHistory ContactSolver<D>::particleHistory(std::uint64_t id) const {
  return std::move(particleHistories(std::span<const std::uint64_t>(&id, 1)).front());
}

template <int D>
std::vector<typename ContactSolver<D>::ParticleHistory> ContactSolver<D>::particleHistories(
    std::span<const std::uint64_t> ids) const {
  if (std::adjacent_find(ids.begin(), ids.end(), std::greater_equal<>()) != ids.end()) {
    throw std::invalid_argument("contact solver: particleHistories() needs ids in strictly ascending order");
  }
  std::vector<ParticleHistory> out(ids.size());
  copyPendingRecords();
  // Each pair of the history goes to both of its particles among `ids` (the
  // other key of a plane or tool pair is no particle id), in history order,
  // as particleHistory() takes them.
  const auto add = [&](std::uint64_t id, const HistoryPair& h) {
    const auto it = std::lower_bound(ids.begin(), ids.end(), id);
    if (it == ids.end() || *it != id) return;
    appendHistoryPair(out[std::size_t(it - ids.begin())], h, nodes_, shear_, preload_, !shear_.empty(),
                      !preload_.empty());
  };
  for (const HistoryPair& h : history_) {
    add(h.idA, h);
    if (h.other != h.idA) add(h.other, h);
  }
  return out;
}

template <int D>
void ContactSolver<D>::adoptHistory(std::uint64_t id, const ParticleHistory& history) {
  std::erase_if(history_, [&](const HistoryPair& h) { return h.idA == id || h.other == id; });
  appendHistory(history);
}

template <int D>
typename ContactSolver<D>::ParticleHistory ContactSolver<D>::mergedHistory(
    std::span<const ParticleHistory* const> histories) {
  // One history of every pair, a pair two of them hold taken once.
  ParticleHistory all;
  bool withShear = false, withPreload = false;
  for (const ParticleHistory* h : histories) {
    withShear = withShear || !h->shear.empty();
    withPreload = withPreload || !h->preload.empty();
  }
  std::set<std::pair<std::uint64_t, std::uint64_t>> taken;
  for (const ParticleHistory* h : histories) {
    for (const HistoryPair& p : h->pairs) {
      if (!taken.emplace(p.idA, p.other).second) continue;
      appendHistoryPair(all, p, h->nodes, h->shear, h->preload, withShear, withPreload);
    }
  }
  return all;
}

template <int D>
void ContactSolver<D>::adoptHistories(std::span<const std::uint64_t> ids,
                                      std::span<const ParticleHistory* const> histories) {
  if (ids.size() != histories.size()) {
    throw std::invalid_argument("ContactSolver::adoptHistories: ids and histories differ in number");
  }
  const std::unordered_set<std::uint64_t> adopted(ids.begin(), ids.end());
  std::erase_if(history_, [&](const HistoryPair& h) { return adopted.count(h.idA) || adopted.count(h.other); });
  appendHistory(mergedHistory(histories));
}

template <int D>
void ContactSolver<D>::appendHistory(const ParticleHistory& history) {
  if (history.pairs.empty()) return;
  copyPendingRecords();
  // The arrays the history points into, aligned with nodes_ before appending
  // (kept when either side has them: a solver whose last compute() found no
  // contact holds none yet).
  const std::size_t base = nodes_.size();
  const bool withShear = !history.shear.empty() || !shear_.empty();
  const bool withPreload = !history.preload.empty() || !preload_.empty();
  if (withShear) shear_.resize(base, Vec<D>::Zero());
  if (withPreload) preload_.resize(base, 0.0);
  if (historyKeys_.size() != base) buildHistoryKeysFor(base);
  nodes_.insert(nodes_.end(), history.nodes.begin(), history.nodes.end());
  for (const NodeContact<D>& c : history.nodes) historyKeys_.push_back(nodeKey(c));
  if (withShear) {
    if (history.shear.empty()) {
      shear_.resize(nodes_.size(), Vec<D>::Zero());
    } else {
      shear_.insert(shear_.end(), history.shear.begin(), history.shear.end());
    }
  }
  if (withPreload) {
    if (history.preload.empty()) {
      preload_.resize(nodes_.size(), 0.0);
    } else {
      preload_.insert(preload_.end(), history.preload.begin(), history.preload.end());
    }
  }
  for (HistoryPair h : history.pairs) {
    h.first += std::uint32_t(base);
    history_.push_back(h);
  }
  std::sort(history_.begin(), history_.end(),
            [](const HistoryPair& x, const HistoryPair& y) { return keyLess(x, y.idA, y.other); });
}

template <int D>
bool ContactSolver<D>::overwriteHistories(std::span<const std::uint64_t> ids,
                                          std::span<const ParticleHistory* const> histories) {
  if (ids.size() != histories.size()) {
    throw std::invalid_argument("ContactSolver::overwriteHistories: ids and histories differ in number");
  }
  const ParticleHistory all = mergedHistory(histories);
  copyPendingRecords();
  // The same pairs here (history_ is sorted by key), node for node.
  const std::unordered_set<std::uint64_t> given(ids.begin(), ids.end());
  std::size_t mine = 0;
  for (const HistoryPair& h : history_) mine += given.count(h.idA) || given.count(h.other);
  if (mine != all.pairs.size()) return false;
  if (!all.nodes.empty() && (shear_.empty() != all.shear.empty() || (!all.preload.empty() && preload_.empty()))) {
    return false;
  }
  std::vector<const HistoryPair*> here(all.pairs.size());
  for (std::size_t k = 0; k < all.pairs.size(); ++k) {
    const HistoryPair& there = all.pairs[k];
    const auto it = std::lower_bound(history_.begin(), history_.end(), there, [](const HistoryPair& x, const HistoryPair& y) {
      return keyLess(x, y.idA, y.other);
    });
    if (it == history_.end() || it->idA != there.idA || it->other != there.other || it->count != there.count) return false;
    for (std::uint32_t j = 0; j < there.count; ++j) {
      if (nodeKey(nodes_[it->first + j]) != nodeKey(all.nodes[there.first + j])) return false;
    }
    here[k] = &*it;
  }
  for (std::size_t k = 0; k < all.pairs.size(); ++k) {
    const HistoryPair& there = all.pairs[k];
    for (std::uint32_t j = 0; j < there.count; ++j) {
      const std::size_t q = here[k]->first + j, r = there.first + j;
      nodes_[q] = all.nodes[r];
      if (!shear_.empty()) shear_[q] = all.shear[r];
      if (!preload_.empty()) preload_[q] = all.preload.empty() ? 0.0 : all.preload[r];
    }
  }
  return true;
}

template <int D>
void ContactSolver<D>::buildHistoryKeysFor(std::size_t count) {
  copyPendingRecords();
  historyKeys_.resize(count);
  for (std::size_t q = 0; q < count; ++q) historyKeys_[q] = nodeKey(nodes_[q]);
}

template <int D>
void ContactSolver<D>::buildHistoryKeys() {
  buildHistoryKeysFor(history_.empty() ? 0 : nodes_.size());
}

template <int D>
const BoundaryLoads<D>& ContactSolver<D>::accumulate(Particles<D>& particles) {
  if (particles.size() != particleCount_) {
    throw std::invalid_argument("contact solver: accumulate() got " + std::to_string(particles.size()) +
                                " particles, compute() had " + std::to_string(particleCount_));
  }
  // Particle pairs: a gets the force, b the reaction; planes and tools: the
  // particle gets the force, the boundary's load the reaction.
  for (std::size_t k = 0; k < pairs_.size(); ++k) {
    const PairContact<D>& rec = pairs_[k];
    particles.force[rec.a] += rec.force;
    particles.torque[rec.a] += rec.torqueA;
    if (k < particlePairCount_) {
      particles.force[rec.b] -= rec.force;
      particles.torque[rec.b] += rec.torqueB;
    }
  }
  return boundaryLoadsOf({}, loads_);
}

template <int D>
const BoundaryLoads<D>& ContactSolver<D>::boundaryLoadsOf(const std::vector<std::uint8_t>& skip,
                                                           BoundaryLoads<D>& out) const {
  out.planeForce.assign(planeCount_, Vec<D>::Zero());
  out.planeTorque.assign(planeCount_, Rotation<D>::zeroSpin());
  out.toolForce.assign(toolCount_, Vec<D>::Zero());
  out.toolTorque.assign(toolCount_, Rotation<D>::zeroSpin());
  const std::size_t planeEnd = particlePairCount_ + planePairCount_;
  for (std::size_t k = particlePairCount_; k < pairs_.size(); ++k) {
    const PairContact<D>& rec = pairs_[k];
    if (!skip.empty() && skip[rec.a]) continue;
    if (k < planeEnd) {
      out.planeForce[rec.b] -= rec.force;
      out.planeTorque[rec.b] += rec.torqueB;
    } else {
      out.toolForce[rec.b] -= rec.force;
      out.toolTorque[rec.b] += rec.torqueB;
    }
  }
  return out;
}

template <int D>
void ContactSolver<D>::addSpringsByGroup(std::span<const std::int64_t> groupOf, const std::vector<std::uint8_t>& skipA,
                                         std::span<double> sums) const {
  for (std::size_t k = 0; k < pairs_.size(); ++k) {
    const PairContact<D>& rec = pairs_[k];
    if (!skipA.empty() && skipA[rec.a]) continue;
    const std::int64_t ga = groupOf[rec.a];
    const std::int64_t gb = k < particlePairCount_ ? groupOf[rec.b] : -1;
    if (ga >= 0) sums[std::size_t(ga)] += rec.elasticEnergy;
    if (gb >= 0 && gb != ga) sums[std::size_t(gb)] += rec.elasticEnergy;
  }
}

template <int D>
void ContactSolver<D>::saveState(StateWriter& out) const {
  copyPendingRecords();
  out.putTag("contacts 4");  // 2: with the pair dashpots; 3: pair records without padding; 4: rest overlaps
  out.putVector(pairs_);
  out.putVector(dashpots_);
  out.putVector(nodes_);
  out.putVector(shear_);
  out.putVector(preload_);
  out.putVector(newborn_);
  out.putVector(history_);
  for (std::size_t v : {particlePairCount_, planePairCount_, particleCount_, planeCount_, toolCount_}) {
    out.put(std::uint64_t(v));
  }
  out.put(elasticEnergy_);
  out.put(dissipatedPower_);
  out.put(nodeChecks_);
  out.putVector(loads_.planeForce);
  out.putVector(loads_.planeTorque);
  out.putVector(loads_.toolForce);
  out.putVector(loads_.toolTorque);
}

template <int D>
void ContactSolver<D>::loadState(StateReader& in) {
  in.expectTag("contacts 4");
  pending_.clear();
  in.getVector(pairs_);
  in.getVector(dashpots_);
  in.getVector(nodes_);
  in.getVector(shear_);
  in.getVector(preload_);
  in.getVector(newborn_);
  in.getVector(history_);
  for (std::size_t* v : {&particlePairCount_, &planePairCount_, &particleCount_, &planeCount_, &toolCount_}) {
    *v = std::size_t(in.get<std::uint64_t>());
  }
  elasticEnergy_ = in.get<double>();
  dissipatedPower_ = in.get<double>();
  nodeChecks_ = in.get<std::uint64_t>();
  in.getVector(loads_.planeForce);
  in.getVector(loads_.planeTorque);
  in.getVector(loads_.toolForce);
  in.getVector(loads_.toolTorque);
  if (particlePairCount_ + planePairCount_ > pairs_.size() || dashpots_.size() != pairs_.size()) {
    throw std::runtime_error("checkpoint state: contact record counts exceed the records");
  }
  for (const PairContact<D>& rec : pairs_) {
    if (std::size_t(rec.firstNode) + rec.nodeCount > nodes_.size()) {
      throw std::runtime_error("checkpoint state: a contact record points past the node contacts");
    }
  }
  buildHistoryKeys();
}

template class ContactSolver<2>;
template class ContactSolver<3>;

}  // namespace lsdem::dynamics
