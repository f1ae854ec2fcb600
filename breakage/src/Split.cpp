#include "lsdem/breakage/Split.h"

#include "lsdem/geometry/Components.h"
#include "lsdem/geometry/MassProperties.h"
#include "lsdem/geometry/NodeSet.h"
#include "lsdem/geometry/SurfaceNodes.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <optional>
#include <utility>

namespace lsdem::breakage {

using geometry::Grid;
using geometry::Mat;
using geometry::Vec;
using geometry::HalfSpace;
using geometry::NodeSet;
using geometry::Rigid;
using geometry::Shape;

namespace {

/// One side's pieces (components of phi4 or phi3) and the nodes gathered for each.
template <int D>
struct Side {
  int sign = 0;                    ///< -1: phi_f < 0 (eq. 15), +1: phi_f > 0 (eq. 14)
  std::vector<Grid<D>> pieces;     ///< cropped grids, parent grid frame
  std::vector<NodeSet<D>> nodes;   ///< per piece, parent grid frame
};

/// Index of the piece whose grid is smallest at grid-frame point x (the first on a tie).
template <int D>
std::size_t owningPiece(const std::vector<Grid<D>>& pieces, const Vec<D>& x) {
  if (pieces.size() == 1) return 0;
  std::size_t best = 0;
  double bestValue = pieces[0].value(x);
  for (std::size_t k = 1; k < pieces.size(); ++k) {
    const double v = pieces[k].value(x);
    if (v < bestValue) {
      bestValue = v;
      best = k;
    }
  }
  return best;
}

/// Orthonormal tangent directions of a unit normal (D - 1 of them), deterministic.
template <int D>
std::vector<Vec<D>> tangentBasis(const Vec<D>& n) {
  if constexpr (D == 2) {
    return {Vec<2>(-n[1], n[0])};
  } else {
    // Start from the coordinate axis least aligned with n.
    Eigen::Index axis = 0;
    n.cwiseAbs().minCoeff(&axis);
    const Vec<3> e = Vec<3>::Unit(axis);
    const Vec<3> t1 = (e - n.dot(e) * n).normalized();
    return {t1, n.cross(t1)};
  }
}

/// New surface nodes on a fracture plane inside the parent (section 3.3):
/// lattice of spacing s in the plane's tangent directions around `centre`
/// (grid frame), out to `radius`; see splitShape's doc for the rim and weights.
template <int D>
NodeSet<D> planeNodes(const Grid<D>& parentGrid, const HalfSpace<D>& planeGrid, const Vec<D>& centre,
                      double radius, double s) {
  const Vec<D> origin = centre - planeGrid.distance(centre) * planeGrid.normal;
  const std::vector<Vec<D>> tangents = tangentBasis<D>(planeGrid.normal);
  const int half = int(std::ceil(radius / s)) + 1;
  const int width = 2 * half + 1;
  int lattice = 1;
  for (int a = 0; a < D - 1; ++a) lattice *= width;

  // Visit every lattice point; count those inside the parent, keep those
  // deeper than s/4 (clear of the rim, where the parent's nodes are).
  NodeSet<D> out;
  std::size_t insideCount = 0;
  for (int q = 0; q < lattice; ++q) {
    Vec<D> p = origin;
    int rest = q;
    for (int a = 0; a < D - 1; ++a) {
      p += double(rest % width - half) * s * tangents[std::size_t(a)];
      rest /= width;
    }
    const double phi = parentGrid.value(p);
    if (!(phi < 0.0)) continue;
    ++insideCount;
    if (phi < -0.25 * s) out.positions.push_back(p);
  }

  // Spread the section's lattice estimate A = s^(D-1) * insideCount evenly over the kept nodes.
  if (!out.positions.empty()) {
    const double section = std::pow(s, D - 1) * double(insideCount);
    out.weights.assign(out.positions.size(), section / double(out.positions.size()));
  }
  return out;
}


/// eq. 15 and eq. 14 in one pass over the parent's grid: minus = max(phi,
/// phi_f) (the phi_f < 0 side), plus = max(phi, -phi_f) (the phi_f > 0 side),
/// with phi_f = psi(node position) evaluated once per node (csgIntersection and
/// csgDifference would evaluate it twice). Nodes are independent, so any thread
/// count gives the same grids.
template <int D, class Psi>
void cutGrids(const Grid<D>& grid, const Psi& psi, Grid<D>& minus, Grid<D>& plus) {
  minus = grid;
  plus = grid;
  const std::int64_t count = std::int64_t(grid.size());
  std::int64_t firstNaN = count;
  // By slices of the last axis, the node index stepped within each slice.
  const int slices = grid.dims()[D - 1];
  const std::size_t sliceSize = grid.size() / std::size_t(slices);
#ifdef LSDEM_HAVE_OPENMP
#pragma omp parallel for schedule(static) reduction(min : firstNaN) if (count > (1 << 18))
#endif
  for (int slice = 0; slice < slices; ++slice) {
    geometry::Index<D> i = geometry::Index<D>::Zero();
    i[D - 1] = slice;
    const std::size_t begin = std::size_t(slice) * sliceSize;
    for (std::size_t node = begin; node < begin + sliceSize; ++node, grid.advance(i)) {
      const double f = psi(grid.nodePosition(i));
      if (std::isnan(f)) {
        firstNaN = std::min(firstNaN, std::int64_t(node));
        continue;
      }
      minus[node] = float(std::max(double(grid[node]), f));
      plus[node] = float(std::max(double(grid[node]), -f));
    }
  }
  if (firstNaN < count) {
    throw std::invalid_argument("splitShape: the fracture surface is NaN at grid node " + std::to_string(firstNaN));
  }
}

/// The face-connected pieces of one side (connectedComponents). A side in one
/// piece, the common case, skips the components' distance transform: its grid
/// is the side's grid cropped to the piece's node bounding box plus `padding`
/// cells (nodes beyond the parent's box take Grid::value's outside extension),
/// which has the same zero level set; only exterior values farther than a
/// cell diagonal from the piece differ (connectedComponents raises them
/// towards the distance, which LS-DEM does not need).
template <int D>
std::vector<Grid<D>> sidePieces(const Grid<D>& side, int padding) {
  std::vector<int> labels;
  const int count = geometry::labelComponents(side, labels);
  if (count == 0) return {};
  if (count > 1) return geometry::connectedComponents(side, padding);

  // Node bounding box of the single piece.
  geometry::Index<D> lower = side.dims(), upper = geometry::Index<D>::Constant(-1);
  geometry::Index<D> i = geometry::Index<D>::Zero();
  for (std::size_t n = 0; n < side.size(); ++n, side.advance(i)) {
    if (labels[n] < 0) continue;
    lower = lower.min(i);
    upper = upper.max(i);
  }
  // The crop, at least 2 nodes per axis, filled from the side's grid.
  const geometry::Index<D> cropLo = lower - padding;
  const geometry::Index<D> cropHi = (upper + padding).max(cropLo + 1);
  Grid<D> piece(cropHi - cropLo + 1, side.nodePosition(cropLo), side.spacing());
  geometry::Index<D> j = geometry::Index<D>::Zero();
  for (std::size_t m = 0; m < piece.size(); ++m, piece.advance(j)) {
    const geometry::Index<D> gi = cropLo + j;
    piece[m] = side.inBounds(gi) ? side.at(gi) : float(side.value(piece.nodePosition(j)));
  }
  std::vector<Grid<D>> out;
  out.push_back(std::move(piece));
  return out;
}

// Merges nodes closer than `tolerance` (world units) into the first of them,
// which takes their weights, so the node set keeps its total weight. Parent
// nodes pushed back onto a small piece's zero level set can land on one point
// (a sliver's rim corner takes every parent node across from it): with the
// per-node law each copy is a full contact spring, so k copies make that point
// k times as stiff and put k times the elastic energy into a contact the
// moment the fragment is born. Deterministic: nodes are taken in order and
// only looked up in the cells around them.
template <int D>
void mergeCoincidentNodes(NodeSet<D>& nodes, double tolerance) {
  // Kept nodes by cell of side 2 x tolerance: a kept node within the
  // tolerance of x lies in x's cell or, per axis, in the neighbour on the side
  // of the cell x is nearer to (2^D cells). Cells are packed into one integer
  // (21 bits per axis; a grain spans far fewer cells) and found in an
  // open-addressing table; the kept nodes of a cell form a list through next.
  const double cell = 2.0 * tolerance;
  const auto pack = [](const std::array<std::int64_t, 3>& c) {
    constexpr std::int64_t bias = std::int64_t(1) << 20;
    return (std::uint64_t(c[0] + bias) << 42) | (std::uint64_t(c[1] + bias) << 21) | std::uint64_t(c[2] + bias);
  };
  constexpr std::uint64_t kEmpty = ~std::uint64_t(0);
  constexpr std::uint32_t kNone = ~std::uint32_t(0);
  std::size_t capacity = 16;
  int bits = 4;
  while (capacity < 4 * nodes.size()) {
    capacity *= 2;
    ++bits;
  }
  std::vector<std::uint64_t> keys(capacity, kEmpty);
  std::vector<std::uint32_t> heads(capacity, kNone);
  const auto slotOf = [&](std::uint64_t key) {
    std::size_t slot = std::size_t((key * 0x9E3779B97F4A7C15ull) >> (64 - bits));  // the product's top bits
    while (keys[slot] != kEmpty && keys[slot] != key) slot = (slot + 1) & (capacity - 1);
    return slot;
  };
  NodeSet<D> kept;
  kept.positions.reserve(nodes.size());
  kept.weights.reserve(nodes.size());
  std::vector<std::uint32_t> next;
  next.reserve(nodes.size());
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const Vec<D>& x = nodes.positions[i];
    std::array<std::int64_t, 3> home{0, 0, 0}, side{0, 0, 0};
    for (int a = 0; a < D; ++a) {
      const double u = x[a] / cell;
      home[std::size_t(a)] = std::int64_t(std::floor(u));
      side[std::size_t(a)] = u - std::floor(u) < 0.5 ? -1 : 1;
    }
    std::size_t found = kept.size();
    for (int q = 0; q < (1 << D) && found == kept.size(); ++q) {
      std::array<std::int64_t, 3> key = home;
      for (int a = 0; a < D; ++a) {
        if (q & (1 << a)) key[std::size_t(a)] += side[std::size_t(a)];
      }
      const std::size_t slot = slotOf(pack(key));
      for (std::uint32_t j = keys[slot] == kEmpty ? kNone : heads[slot]; j != kNone; j = next[j]) {
        if ((kept.positions[j] - x).norm() < tolerance) {
          found = j;
          break;
        }
      }
    }
    if (found < kept.size()) {
      kept.weights[found] += nodes.weights[i];
    } else {
      const std::size_t slot = slotOf(pack(home));
      keys[slot] = pack(home);
      next.push_back(heads[slot]);
      heads[slot] = std::uint32_t(kept.size());
      kept.positions.push_back(x);
      kept.weights.push_back(nodes.weights[i]);
    }
  }
  nodes = std::move(kept);
}

}  // namespace

template <int D>
SplitResult<D> splitShape(const Shape<D>& parent, const FractureSurface<D>& surface, const SplitOptions& options) {
  // Check the arguments.
  if (!surface.plane && !surface.field) {
    throw std::invalid_argument("splitShape: the fracture surface has neither a plane nor a field");
  }
  if (!std::isfinite(options.nodesPerCell) || options.nodesPerCell < 0.0) {
    throw std::invalid_argument("splitShape: options.nodesPerCell must be finite and >= 0, got " +
                                std::to_string(options.nodesPerCell));
  }
  if (options.paddingCells < 3) {
    throw std::invalid_argument("splitShape: options.paddingCells must be >= 3, got " +
                                std::to_string(options.paddingCells));
  }
  std::optional<HalfSpace<D>> planeBody = surface.plane;
  if (planeBody) {
    const double norm = planeBody->normal.norm();
    if (!std::isfinite(norm) || !(norm > 0.0) || !std::isfinite(planeBody->offset)) {
      throw std::invalid_argument("splitShape: the fracture plane needs a finite non-zero normal and a finite offset "
                                  "(|normal| = " + std::to_string(norm) + ", offset = " +
                                  std::to_string(planeBody->offset) + ")");
    }
    planeBody->normal /= norm;
    planeBody->offset /= norm;
  }

  const Grid<D>& grid = parent.grid();
  const Rigid<D>& bodyToGrid = parent.bodyToGrid();
  const double h = grid.spacing();
  const double nodesPerCell = options.nodesPerCell > 0.0 ? options.nodesPerCell : parent.options().nodesPerCell;
  geometry::ShapeOptions childOptions = parent.options();
  childOptions.nodesPerCell = nodesPerCell;

  SplitResult<D> result;
  result.parentVolume = parent.volume();

  // The fracture surface in the parent's grid frame: x_body = bodyToGrid^-1(x_grid).
  // A plane n.x_b = c becomes (R n).x_g = c + (R n).t.
  std::optional<HalfSpace<D>> planeGrid;
  if (planeBody) {
    HalfSpace<D> p;
    p.normal = bodyToGrid.rotation * planeBody->normal;
    p.offset = planeBody->offset + p.normal.dot(bodyToGrid.translation);
    planeGrid = p;
  }

  // eq. 15 (phi_f < 0 side) and eq. 14 (phi_f > 0 side), each cut into its
  // face-connected pieces.
  Grid<D> minusGrid, plusGrid;
  if (planeGrid) {
    const HalfSpace<D> p = *planeGrid;
    cutGrids(grid, [&p](const Vec<D>& x) { return p.distance(x); }, minusGrid, plusGrid);
  } else {
    cutGrids(grid, [&](const Vec<D>& x) { return surface.field(bodyToGrid.applyInverse(x)); }, minusGrid, plusGrid);
  }
  std::array<Side<D>, 2> sides;
  sides[0].sign = -1;
  sides[0].pieces = sidePieces(minusGrid, options.paddingCells);
  sides[1].sign = +1;
  sides[1].pieces = sidePieces(plusGrid, options.paddingCells);

  // A surface that leaves one side without interior does not split the grain.
  if (sides[0].pieces.empty() || sides[1].pieces.empty()) return result;
  for (Side<D>& side : sides) side.nodes.resize(side.pieces.size());

  // Nodes of a flat cut: the parent's by the sign of phi_f, then the new plane
  // nodes on both sides, each to the piece whose grid is smallest at it.
  if (planeGrid) {
    const NodeSet<D>& parentNodes = parent.nodes();
    for (std::size_t i = 0; i < parentNodes.size(); ++i) {
      const Vec<D> x = bodyToGrid.apply(parentNodes.positions[i]);
      Side<D>& side = sides[planeGrid->distance(x) < 0.0 ? 0 : 1];
      NodeSet<D>& target = side.nodes[owningPiece(side.pieces, x)];
      target.positions.push_back(x);
      target.weights.push_back(parentNodes.weights[i]);
    }
    const NodeSet<D> onPlane =
        planeNodes(grid, *planeGrid, bodyToGrid.translation, parent.boundingRadius(), h / nodesPerCell);
    for (Side<D>& side : sides) {
      for (std::size_t i = 0; i < onPlane.size(); ++i) {
        NodeSet<D>& target = side.nodes[owningPiece(side.pieces, onPlane.positions[i])];
        target.positions.push_back(onPlane.positions[i]);
        target.weights.push_back(onPlane.weights[i]);
      }
    }
  }

  // Each piece becomes a shape: its nodes are put back on its own zero level
  // set (the rim's kink moves it); a piece with no nodes takes them from its
  // own grid (curved cuts always do), and is dropped when it has none even then.
  const Rigid<D> gridToParentBody = bodyToGrid.inverse();
  for (Side<D>& side : sides) {
    for (std::size_t k = 0; k < side.pieces.size(); ++k) {
      NodeSet<D> nodes = std::move(side.nodes[k]);
      // Back onto the piece's own phi = 0: the multilinear interpolant rounds the
      // max() kink of eq. 14-15 at the new rim by up to ~h/4.
      for (Vec<D>& x : nodes.positions) x = geometry::projectOntoZero(side.pieces[k], x, 1e-4, 10);
      // A node the projection could not bring to the piece's surface (a
      // parent node several cells from the piece it was given to, left up to a
      // cell outside it and outside the parent; or one beside a sliver whose
      // grid values stay just above zero, left 0.008 cells out: both found by
      // fuzz_split) is not a surface node of this piece: dropped. A converged
      // projection is within 1e-4 cells.
      std::size_t keptCount = 0;
      for (std::size_t n = 0; n < nodes.size(); ++n) {
        if (!(std::abs(side.pieces[k].value(nodes.positions[n])) <= 1e-3 * h)) continue;
        nodes.positions[keptCount] = nodes.positions[n];
        nodes.weights[keptCount] = nodes.weights[n];
        ++keptCount;
      }
      nodes.positions.resize(keptCount);
      nodes.weights.resize(keptCount);
      // Nodes that landed on one point are one node.
      mergeCoincidentNodes(nodes, 0.25 * h / nodesPerCell);
      if (nodes.empty()) {
        if constexpr (D == 2) {
          nodes = geometry::surfaceNodes(side.pieces[k], nodesPerCell);
        } else {
          nodes = geometry::surfaceNodes(side.pieces[k], nodesPerCell, nullptr);
        }
      }
      if (nodes.empty()) {
        result.droppedRawVolume += geometry::massProperties(side.pieces[k], childOptions.massMethod).volume;
        ++result.droppedCount;
        continue;
      }
      Fragment<D> fragment;
      fragment.shape = Shape<D>::fromGridAndNodes(std::move(side.pieces[k]), std::move(nodes), childOptions);
      fragment.childToParent = gridToParentBody * fragment.shape->bodyToGrid();
      fragment.rawVolume = fragment.shape->volume();
      fragment.side = side.sign;
      result.rawVolumeSum += fragment.rawVolume;
      result.fragments.push_back(std::move(fragment));
    }
  }
  if (result.fragments.size() < 2) {
    result.fragments.clear();
    result.rawVolumeSum = 0.0;
    return result;
  }
  result.isSplit = true;
  result.rawRelativeError = (result.rawVolumeSum + result.droppedRawVolume - result.parentVolume) / result.parentVolume;

  // Carry the parent's volume exactly: proportional correction of every fragment.
  const double scale = result.parentVolume / result.rawVolumeSum;
  for (Fragment<D>& fragment : result.fragments) fragment.volume = fragment.rawVolume * scale;

  // The fragments' common centre of mass (parent body frame), a small fraction
  // of a cell from the parent's centroid. The fragments stay where the
  // parent's material was: moving them all by -centroidShift (as an earlier
  // version did, to keep the centre of mass) pushed their surfaces up to a
  // tenth of a cell into the walls and grains the parent touched, and each
  // split then started contact springs from nothing. Momentum is kept through
  // the velocities instead (fragmentState()).
  Vec<D> firstMoment = Vec<D>::Zero();
  for (const Fragment<D>& fragment : result.fragments) firstMoment += fragment.volume * fragment.childToParent.translation;
  result.centroidShift = firstMoment / result.parentVolume;
  for (Fragment<D>& fragment : result.fragments) fragment.centreOfMass = result.centroidShift;

  // Inertia mismatch: the fragments' corrected inertias moved to the parent's
  // centroid (parallel axes) against the parent's, per unit density. In 2D the
  // trace of tr(S) 1 - S is tr(S), the polar moment (eq. 30), and the trace of
  // the parallel-axis term is |c|^2.
  Mat<D> combined = Mat<D>::Zero();
  for (const Fragment<D>& fragment : result.fragments) {
    const Mat<D>& rc = fragment.childToParent.rotation;
    const Vec<D> c = fragment.childToParent.translation - result.centroidShift;
    combined += fragment.massScale() * rc * fragment.shape->mass().inertiaTensor() * rc.transpose() +
                fragment.volume * (c.squaredNorm() * Mat<D>::Identity() - c * c.transpose());
  }
  const Mat<D> parentInertia = parent.mass().inertiaTensor();
  if constexpr (D == 2) {
    result.inertiaRelativeError = std::abs(combined.trace() - parentInertia.trace()) / parentInertia.trace();
  } else {
    result.inertiaRelativeError = (combined - parentInertia).norm() / parentInertia.norm();
  }
  return result;
}

template <int D>
FragmentState<D> fragmentState(const Fragment<D>& fragment, const Vec<D>& parentPosition, const Mat<D>& parentRotation,
                               const Vec<D>& parentVelocity, const dynamics::Spin<D>& parentSpin) {
  // Pose: the child's centroid and principal frame carried by the parent's pose.
  FragmentState<D> state;
  const Vec<D> lever = parentRotation * fragment.childToParent.translation;
  state.position = parentPosition + lever;
  state.rotation = parentRotation * fragment.childToParent.rotation;
  // Velocity: the parent's rigid-body motion (its centroid's velocity carried
  // by the fragments' common centre of mass), at the child's centroid.
  state.velocity = parentVelocity + dynamics::Rotation<D>::velocityAt(
                                        parentSpin, Vec<D>(lever - parentRotation * fragment.centreOfMass));
  state.angularVelocity = parentSpin;
  return state;
}

template SplitResult<2> splitShape<2>(const Shape<2>&, const FractureSurface<2>&, const SplitOptions&);
template SplitResult<3> splitShape<3>(const Shape<3>&, const FractureSurface<3>&, const SplitOptions&);
template FragmentState<2> fragmentState<2>(const Fragment<2>&, const Vec<2>&, const Mat<2>&, const Vec<2>&,
                                           const dynamics::Spin<2>&);
template FragmentState<3> fragmentState<3>(const Fragment<3>&, const Vec<3>&, const Mat<3>&, const Vec<3>&,
                                           const dynamics::Spin<3>&);

}  // namespace lsdem::breakage
