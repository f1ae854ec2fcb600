#include "lsdem/breakage/Split.h"

#include "lsdem/geometry/Components.h"
#include "lsdem/geometry/Contours.h"
#include "lsdem/geometry/Csg.h"
#include "lsdem/geometry/MassProperties.h"
#include "lsdem/geometry/NodeSet.h"
#include "lsdem/geometry/SurfaceNodes.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
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
  /// Per piece, per node: 1 for a node of the parent's surface, 0 for one of
  /// the cut (nodesOnPiece keeps a parent node's offset from the interpolant).
  std::vector<std::vector<char>> fromParent;
};

/// Distance from x to a grid's node box (0 inside). A padded piece's grid is
/// positive on its border, so outside the box its value (Grid::value's
/// extension phi(c) + |x - c|) is at least this: a lower bound that lets a
/// look-up be skipped.
template <int D>
double distanceToBox(const Grid<D>& grid, const Vec<D>& x) {
  const geometry::Box<D> box = grid.bounds();
  return (box.lower - x).cwiseMax(x - box.upper).cwiseMax(0.0).norm();
}

/// Index of the piece whose grid is smallest at grid-frame point x (the first
/// on a tie). Pieces whose box is farther than the best value so far cannot
/// be smaller there and are not looked up.
template <int D>
std::size_t owningPiece(const std::vector<Grid<D>>& pieces, const Vec<D>& x) {
  if (pieces.size() == 1) return 0;
  std::size_t best = 0;
  double bestValue = pieces[0].value(x);
  for (std::size_t k = 1; k < pieces.size(); ++k) {
    if (distanceToBox(pieces[k], x) >= bestValue) continue;
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


/// The face-connected pieces of one side (connectedComponents). A side in one
/// piece, the common case, skips the components' distance transform: its grid
/// is the side's grid cropped to the piece's node bounding box plus `padding`
/// cells (nodes beyond the parent's box take Grid::value's outside extension),
/// which has the same zero level set; only exterior values farther than a
/// cell diagonal from the piece differ (connectedComponents raises them
/// towards the distance, which LS-DEM does not need).
///
/// Specks are not pieces: a component of fewer than 2^D interior nodes (not
/// one cell's worth) with a node diagonal to a node of a larger component.
/// Where a cut meets a grain's surface at a shallow angle, single interior
/// nodes along the rim touch the piece only across a cell's diagonal; each
/// became a fragment of about one cell's volume (a 64^3 sphere cut 0.7 radii
/// off centre gave 9 of them beside the cap, each re-gridded: 773 ms for the
/// split against 47 ms). Their share of the mass goes to the pieces around
/// them (partitionMass gives every sample of a side to one of its pieces).
template <int D>
std::vector<Grid<D>> sidePieces(const Grid<D>& side, int padding) {
  std::vector<int> labels;
  const int count = geometry::labelComponents(side, labels);
  if (count == 0) return {};
  if (count > 1) {
    std::vector<Grid<D>> pieces = geometry::connectedComponents(side, padding);
    constexpr int kSpeckNodes = 1 << D;
    std::vector<int> nodes(std::size_t(count), 0);
    for (int label : labels) {
      if (label >= 0) ++nodes[std::size_t(label)];
    }
    std::vector<char> speck(std::size_t(count), 0);
    int neighbours = 1;
    for (int a = 0; a < D; ++a) neighbours *= 3;
    for (std::size_t n = 0; n < side.size(); ++n) {
      const int label = labels[n];
      if (label < 0 || nodes[std::size_t(label)] >= kSpeckNodes || speck[std::size_t(label)]) continue;
      const geometry::Index<D> i = side.unlinear(n);
      for (int q = 0; q < neighbours; ++q) {
        geometry::Index<D> j = i;
        for (int a = 0, rest = q; a < D; ++a, rest /= 3) j[a] += rest % 3 - 1;
        if (!side.inBounds(j)) continue;
        const int other = labels[side.linear(j)];
        if (other >= 0 && other != label && nodes[std::size_t(other)] >= kSpeckNodes) speck[std::size_t(label)] = 1;
      }
    }
    std::vector<Grid<D>> kept;
    for (std::size_t k = 0; k < pieces.size(); ++k) {
      if (!speck[k]) kept.push_back(std::move(pieces[k]));
    }
    return kept;
  }

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
// only looked up in the cells around them. `starts`, when given, is one
// point per node and is kept beside the nodes: a merged node keeps its first one's.
template <int D>
void mergeCoincidentNodes(NodeSet<D>& nodes, double tolerance, std::vector<Vec<D>>* starts = nullptr) {
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
      if (starts) (*starts)[kept.size()] = (*starts)[i];  // kept.size() <= i
      kept.positions.push_back(x);
      kept.weights.push_back(nodes.weights[i]);
    }
  }
  if (starts) starts->resize(kept.size());
  nodes = std::move(kept);
}

/// The pieces of both sides in one list (the side -1 pieces first): a piece's slot.
template <int D>
std::size_t slotOf(const std::array<Side<D>, 2>& sides, std::size_t side, std::size_t piece) {
  return side == 0 ? piece : sides[0].pieces.size() + piece;
}

/// Sub-samples per axis of a grid cell that the cut crosses (4^D per cell).
/// Even, so no sample sits on the node itself: a cut through a row of grid
/// nodes (common: planes through a box's centre) would put a whole layer of
/// samples at phi_f = 0 and hand it to one side.
template <int D>
constexpr int kCutSubsamples = 4;

/// How far (parent cells) a parent node's projection onto its piece's
/// surface may travel beyond its distance from that surface before the node
/// counts as moved to a new point (nodesOnPiece).
constexpr double kSlideCells = 0.1;

/// The parent's mass integrand (eq. 24-30, the sums massProperties() forms)
/// partitioned among the pieces, in the parent's grid frame about `reference`
/// (see splitShape's doc, "Mass"). A node whose cell the cut cannot cross adds
/// its sample, as massProperties() does, to the piece that owns it; a node
/// whose cell it may cross adds kCutSubsamples^D samples of the multilinear
/// interpolant, each to the side of the cut it is on. Per slice of the last
/// axis in parallel, added in slice order: the same sums for any thread count.
template <int D, class Psi>
std::vector<geometry::MassSums<D>> partitionMass(const Grid<D>& grid, double epsilon, const Psi& psi,
                                                 const Vec<D>* planeNormal, const std::array<Side<D>, 2>& sides,
                                                 const Vec<D>& reference) {
  const std::size_t slots = sides[0].pieces.size() + sides[1].pieces.size();
  const double h = grid.spacing();
  // The cut can cross a node's cell (its dual box, half a cell each way) when
  // the surface passes within half a diagonal of the node; 1.5x that for a
  // surface field that is not an exact distance.
  const double halfDiagonal = 0.5 * std::sqrt(double(D)) * h;
  const double nearCut = (planeNormal ? 1.0 + 1e-9 : 1.5) * halfDiagonal;
  const double band = 2.0 * epsilon;
  const int slices = grid.dims()[D - 1];
  const std::size_t sliceSize = grid.size() / std::size_t(slices);
  std::vector<std::vector<geometry::MassSums<D>>> partial(
      std::size_t(slices), std::vector<geometry::MassSums<D>>(slots, geometry::MassSums<D>(epsilon)));
  // Cells near both the cut and the surface are sampled kSub^D times with a
  // band kSub times narrower (MassSums' sums of different widths add term by
  // term). Where a piece meets the cut at a grazing angle (a thin cap), the
  // wide band beside the cut would hand it the outer half of the band of a
  // surface that is mostly the other piece's (a 2 % cap of a sphere at 20
  // cells across was 4 % too heavy); the narrow band keeps that error within
  // a sub-cell. A cell is wholly in or out of that zone, which reaches as far
  // from the cut as the wide band reaches from the surface.
  const double fineReach = band + halfDiagonal;
  // A sub-sample within half a sub-cell of the cut is shared between the
  // sides in proportion to the part of its sub-cell on each (a linear ramp
  // over the sub-cell's width along the cut's normal: exact for a cut along
  // a grid axis, unbiased otherwise). Handing it whole to one side put the
  // cut up to half a sub-cell off, which is 7 % of the mass of a segment one
  // cell thick.
  double rampWidth = h / kCutSubsamples<D>;
  if (planeNormal) rampWidth *= planeNormal->cwiseAbs().sum();
  std::vector<std::vector<geometry::MassSums<D>>> partialFine(
      std::size_t(slices), std::vector<geometry::MassSums<D>>(slots, geometry::MassSums<D>(epsilon / kCutSubsamples<D>)));
  const auto owner = [&](const Vec<D>& x, double f) {
    const std::size_t side = f < 0.0 ? 0 : 1;
    return slotOf(sides, side, owningPiece(sides[side].pieces, x));
  };
  constexpr int kSub = kCutSubsamples<D>;
  constexpr int kSamples = D == 2 ? kSub * kSub : kSub * kSub * kSub;
  const double subWeight = 1.0 / double(kSamples);
  // Sub-sample offsets from the node, and a plane's change across them (psi is linear).
  std::array<Vec<D>, kSamples> offsets;
  std::array<double, kSamples> planeChange{};
  for (int q = 0; q < kSamples; ++q) {
    int rest = q;
    for (int a = 0; a < D; ++a) {
      offsets[std::size_t(q)][a] = h * ((double(rest % kSub) + 0.5) / kSub - 0.5);
      rest /= kSub;
    }
    if (planeNormal) planeChange[std::size_t(q)] = planeNormal->dot(offsets[std::size_t(q)]);
  }
#ifdef LSDEM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
  for (int slice = 0; slice < slices; ++slice) {
    std::vector<geometry::MassSums<D>>& out = partial[std::size_t(slice)];
    std::vector<geometry::MassSums<D>>& outFine = partialFine[std::size_t(slice)];
    geometry::Index<D> i = geometry::Index<D>::Zero();
    i[D - 1] = slice;
    const std::size_t begin = std::size_t(slice) * sliceSize;
    for (std::size_t n = begin; n < begin + sliceSize; ++n, grid.advance(i)) {
      const double phi = grid[n];
      if (phi >= band + 2.0 * halfDiagonal) continue;
      const Vec<D> x = grid.nodePosition(i);
      const double f = psi(x);
      // Near the cut and the surface: sub-samples with the narrow band.
      const bool fine = std::abs(f) < fineReach && std::abs(phi) < band + 2.0 * halfDiagonal;
      if (!fine && !(std::abs(f) < nearCut)) {
        // The whole cell is on one side: the node's own sample.
        if (phi < band) out[owner(x, f)].add(phi, x - reference);
        continue;
      }
      // The cut may cross the cell: sub-samples at the centres of kSub^D
      // sub-cells; a cell deep inside needs no look-up (weight 1 throughout).
      const bool deep = phi < -band - 2.0 * halfDiagonal;
      std::vector<geometry::MassSums<D>>& to = fine ? outFine : out;
      for (std::size_t q = 0; q < std::size_t(kSamples); ++q) {
        const Vec<D> y = x + offsets[q];
        const double phiY = deep ? phi : grid.value(y);
        if (phiY >= band) continue;
        // The share of its sub-cell on each side of the cut.
        const double t = std::clamp(0.5 + (planeNormal ? f + planeChange[q] : psi(y)) / rampWidth, 0.0, 1.0);
        if (t < 1.0) to[owner(y, -1.0)].add(phiY, y - reference, (1.0 - t) * subWeight);
        if (t > 0.0) to[owner(y, 1.0)].add(phiY, y - reference, t * subWeight);
      }
    }
  }
  std::vector<geometry::MassSums<D>> sums(slots, geometry::MassSums<D>(epsilon));
  for (std::size_t slice = 0; slice < partial.size(); ++slice) {
    for (std::size_t k = 0; k < slots; ++k) {
      sums[k].add(partial[slice][k]);
      sums[k].add(partialFine[slice][k]);
    }
  }
  return sums;
}

/// Twice the smallest semi-axis of the ellipse (2D) / ellipsoid (3D) with the
/// same area/volume and second moments (S_ii = V a_i^2 / 4 in 2D, / 5 in 3D):
/// a fragment's smallest extent, world units.
template <int D>
double smallestExtent(const geometry::MassProperties<D>& mass) {
  constexpr double k = D == 2 ? 4.0 : 5.0;
  const double smallest = std::max(0.0, mass.principalSecondMoments()[D - 1]);
  return 2.0 * std::sqrt(k * smallest / mass.volume);
}

/// Where a piece's material is: the box of its nodes within a cell of its
/// surface (phi < h) in the parent's grid frame, grown by a cell (the
/// interpolant's interior reaches up to a cell past them), and its deepest node.
template <int D>
struct PieceExtent {
  geometry::Box<D> box;
  Vec<D> deepest = Vec<D>::Zero();
};

template <int D>
PieceExtent<D> pieceExtent(const Grid<D>& piece) {
  const double h = piece.spacing();
  Vec<D> lo = Vec<D>::Constant(std::numeric_limits<double>::infinity());
  Vec<D> hi = -lo;
  PieceExtent<D> out;
  float deepestValue = std::numeric_limits<float>::infinity();
  geometry::Index<D> i = geometry::Index<D>::Zero();
  for (std::size_t n = 0; n < piece.size(); ++n, piece.advance(i)) {
    if (!(piece[n] < h)) continue;
    const Vec<D> x = piece.nodePosition(i);
    lo = lo.cwiseMin(x);
    hi = hi.cwiseMax(x);
    if (piece[n] < deepestValue) {
      deepestValue = piece[n];
      out.deepest = x;
    }
  }
  out.box = geometry::Box<D>{(lo.array() - h).matrix(), (hi.array() + h).matrix()};
  return out;
}

/// Nodes of a grid covering `box` at spacing s with `padding` cells (as Grid::covering makes it).
template <int D>
double coveringNodes(const geometry::Box<D>& box, double s, int padding) {
  double count = 1.0;
  for (int a = 0; a < D; ++a) count *= std::ceil(box.size()[a] / s) + 1.0 + 2.0 * padding;
  return count;
}

/// The level set a piece of `side` has in the parent (eq. 14-15 on the
/// parent's multilinear field): max(phi, -sign psi) at grid-frame point x,
/// and, beside other pieces of the side, only where this piece owns the point
/// (its cropped grid is the smallest there, as for nodes), so material the
/// parent's nodes did not resolve between two pieces goes to neither twice.
template <int D>
double pieceLevelSet(const Grid<D>& parentGrid, const geometry::SignedDistance<D>& psi, const Side<D>& side,
                     std::size_t piece, const Vec<D>& x) {
  double v = std::max(parentGrid.value(x), -double(side.sign) * psi(x));
  if (side.pieces.size() > 1) {
    // A piece j matters only if 0.5 (own - phi_j) > v, i.e. phi_j < own - 2 v;
    // its value is at least its box's distance (distanceToBox).
    const double own = side.pieces[piece].value(x);
    const double matters = own - 2.0 * v;
    double other = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < side.pieces.size(); ++k) {
      if (k == piece || distanceToBox(side.pieces[k], x) >= std::min(other, matters)) continue;
      other = std::min(other, side.pieces[k].value(x));
    }
    v = std::max(v, 0.5 * (own - other));
  }
  return v;
}

/// A piece re-gridded at spacing `fine` (SplitOptions::regridCells): its level
/// set (pieceLevelSet) sampled afresh at the new nodes, a plane exactly, cut
/// down to the one component that holds the piece's deepest point. The grid
/// covers the piece's extent plus `padding` cells. The samples are a signed
/// distance inside the piece (the max of the parent's distance and the
/// plane's), as the crops of non-re-gridded pieces are; outside, near the new
/// rim, they underestimate the distance (they stay 1-Lipschitz). They are not
/// reinitialised (eq. 17): fast sweeping took 68 % of a 3D crushing cascade's
/// time and moves neither the zero set nor the interior values contacts use.
template <int D>
Grid<D> regridPiece(const Grid<D>& parentGrid, const geometry::SignedDistance<D>& psi, const Side<D>& side,
                    std::size_t piece, const PieceExtent<D>& extent, double fine, int padding) {
  Grid<D> grid = Grid<D>::covering(extent.box, fine, padding);
  geometry::Index<D> j = geometry::Index<D>::Zero();
  for (std::size_t n = 0; n < grid.size(); ++n, grid.advance(j)) {
    grid[n] = float(pieceLevelSet(parentGrid, psi, side, piece, grid.nodePosition(j)));
  }
  // Other pieces of the same side may still reach into the box: keep this one.
  std::vector<int> labels;
  if (geometry::labelComponents(grid, labels) > 1) {
    std::vector<Grid<D>> parts = geometry::connectedComponents(grid, padding);
    std::size_t best = 0;
    for (std::size_t k = 1; k < parts.size(); ++k) {
      if (parts[k].value(extent.deepest) < parts[best].value(extent.deepest)) best = k;
    }
    grid = std::move(parts[best]);
  }
  return grid;
}

/// A fragment's free surface moved out by `delta` (SplitOptions::
/// matchEnclosedVolume): phi' = phi - delta w(x), with the weight
///     w = clamp((|phi_f(x)| - b) / g, 0, 1) clamp((c(x) - 2 delta_max) / h, 0, 1),
///     b = max(sqrt(D) g, the largest shift allowed),
/// with g the spacing of the piece's own grid, h the parent's, c the
/// clearance (the distance to the nearest other body, splitShape's
/// `clearance`). w is 0 within b of the fracture surface: every grid value of
/// a cell the cut face crosses (a cell diagonal), and with them the face,
/// stays exactly as cut, and no point across the cut comes inside (there
/// phi >= |phi_f| > b >= delta), so siblings do not overlap. Likewise it is
/// 0 within max(sqrt(D) g, 2 x the largest shift) of another piece of the same
/// side (a concave grain's pieces on one side can lie a fraction of a cell
/// apart, and both move). It is 0 within twice the largest shift of
/// any other body, so the surface moves into nothing (contact overlaps are
/// small fractions of a cell: a shift into a neighbour of even 0.05 cells
/// made springs a hundred times stiffer than the load's; a point c away
/// moves at most delta (c - 2 delta_max) / h < c), and 1 from b + g off the
/// cut and a parent cell more than that off every other body.
template <int D>
struct SurfaceShift {
  const geometry::SignedDistance<D>* psi = nullptr;        ///< the fracture surface, parent grid frame
  const geometry::SignedDistance<D>* clearance = nullptr;  ///< parent body frame; empty: nothing around
  const Rigid<D>* bodyToGrid = nullptr;
  double cell = 0.0;     ///< the parent's grid spacing
  double ownCell = 0.0;  ///< the piece's grid spacing
  double cutBand = 0.0;  ///< b: no shift this close to the cut
  double pieceBand = 0.0;  ///< no shift this close to another piece of the side
  double clearanceBand = 0.0;  ///< nor this close to another body
  const Side<D>* side = nullptr;  ///< the piece's side
  std::size_t piece = 0;          ///< the piece's index in it
  double delta = 0.0;    ///< world units, > 0 outward
  double weight(const Vec<D>& x) const {
    double apart = std::abs((*psi)(x)) - cutBand;
    for (std::size_t k = 0; k < side->pieces.size(); ++k) {
      if (k == piece || distanceToBox(side->pieces[k], x) - pieceBand >= apart) continue;
      apart = std::min(apart, side->pieces[k].value(x) - pieceBand);
    }
    const double fromCut = std::clamp(apart / ownCell, 0.0, 1.0);
    if (fromCut == 0.0 || !*clearance) return fromCut;
    return fromCut * std::clamp(((*clearance)(bodyToGrid->applyInverse(x)) - clearanceBand) / cell, 0.0, 1.0);
  }
  double at(const Vec<D>& x) const { return delta == 0.0 ? 0.0 : delta * weight(x); }
};

/// Moves the surface of a piece's grid (SurfaceShift) until the volume its
/// zero set encloses, as the surfaces output draws it (enclosedVolume), is
/// `target` (its share of the parent's volume) to 1e-4, the shift at most
/// `maxShift` either way. The enclosed volume V(delta) grows with delta at the
/// rate of the weighted surface area; the first step takes that area from the
/// grid (sum of w times a cosine delta kernel 3 cells wide), the next ones
/// are secant steps on V (at most 4 evaluations, 2 as a rule). Returns the shift applied.
template <int D>
SurfaceShift<D> matchEnclosedVolume(Grid<D>& grid, const SurfaceShift<D>& unshifted, double target, double maxShift) {
  SurfaceShift<D> shift = unshifted;
  const double tolerance = 1e-4 * target;
  double v0 = geometry::enclosedVolume<D>(grid);
  if (!(maxShift > 0.0) || !(target > 0.0) || !(v0 > 0.0) || std::abs(v0 - target) <= tolerance) return shift;

  const std::vector<float> base = grid.values();
  std::vector<float> weights(grid.size());
  const double h = grid.spacing(), band = 1.5 * h, pi = std::acos(-1.0);
  double area = 0.0;
  geometry::Index<D> j = geometry::Index<D>::Zero();
  // Only values within a few cells of the zero set can move it.
  const double reach = std::sqrt(double(D)) * h + maxShift;
  for (std::size_t n = 0; n < grid.size(); ++n, grid.advance(j)) {
    if (!(std::abs(base[n]) < reach)) continue;
    weights[n] = float(shift.weight(grid.nodePosition(j)));
    if (std::abs(base[n]) < band) area += weights[n] * (1.0 + std::cos(pi * base[n] / band)) / (2.0 * band);
  }
  area *= std::pow(h, D);
  if (!(area > 0.0)) return shift;
  const auto volumeAt = [&](double delta) {
    for (std::size_t n = 0; n < grid.size(); ++n) grid[n] = float(base[n] - delta * weights[n]);
    return geometry::enclosedVolume<D>(grid);
  };
  double d0 = 0.0, f0 = v0 - target;
  double d1 = std::clamp(-f0 / area, -maxShift, maxShift);
  double f1 = volumeAt(d1) - target;
  for (int evaluation = 1; evaluation < 4 && std::abs(f1) > tolerance && f1 != f0; ++evaluation) {
    const double d2 = std::clamp(d1 - f1 * (d1 - d0) / (f1 - f0), -maxShift, maxShift);
    if (d2 == d1) break;  // held at the bound
    d0 = d1;
    f0 = f1;
    d1 = d2;
    f1 = volumeAt(d1) - target;
  }
  shift.delta = d1;
  return shift;
}

/// Nodes made on a re-gridded piece lie on its new grid's zero set, which
/// samples the piece's level set in the parent (pieceLevelSet) and so differs
/// from it by the new grid's interpolation error, up to a few thousandths of
/// a parent cell: a node a little outside the parent would start inside
/// whatever the parent touched (or its sibling). Each such node is moved in
/// along the new grid's normal until it is within 1e-4 parent cells of the
/// parent's surface moved by `shift` (at most a few hundredths of a cell).
/// `starts` (nodesOnPiece; null for nodes made afresh): a parent's node on
/// its true surface lies outside the parent's multilinear zero set by up to
/// ~h^2 / (8 R) where the parent was there too: that much is allowed.
template <int D>
void pullInsideParent(NodeSet<D>& nodes, const Grid<D>& fineGrid, const Grid<D>& parentGrid,
                      const geometry::SignedDistance<D>& psi, const Side<D>& side, std::size_t piece,
                      const SurfaceShift<D>& shift, const std::vector<Vec<D>>* starts) {
  const double tolerance = 1e-4 * parentGrid.spacing();
  for (std::size_t n = 0; n < nodes.size(); ++n) {
    Vec<D>& x = nodes.positions[n];
    const double allowed = starts ? std::max(0.0, parentGrid.value((*starts)[n])) : 0.0;
    for (int iteration = 0; iteration < 8; ++iteration) {
      const double outside = pieceLevelSet(parentGrid, psi, side, piece, x) - shift.at(x) - allowed;
      if (!(outside > tolerance)) break;
      Vec<D> grad;
      fineGrid.valueAndGradient(x, grad);
      const double g2 = grad.squaredNorm();
      if (!(g2 > 1e-12)) break;
      x -= (outside + tolerance) / g2 * grad;
    }
  }
}

/// The parent's nodes (and a flat cut's) given to a piece, on the piece's
/// own surface as the contact sees it: each projected with `interpolant`
/// (the scene's contact look-up, SplitOptions::nodeInterpolant) of
/// `pieceGrid` onto the level it had in the parent. A cut's node goes to
/// level 0. A parent's node goes to the value `levelInterpolant` of
/// `parentGrid` had at it, less the piece's surface shift there
/// (matchEnclosedVolume lowers the piece's grid by `shift`), both times the
/// shift's weight, which is 0 within a cell diagonal of the cut (there a
/// node keeping its offset would come round the rim, past the cut, into its
/// sibling) and near other bodies: the offset of a
/// node on the parent's true surface from its interpolated zero set
/// (~h^2 / (8 R) with the multilinear one, ~0 for the grid's own nodes) is
/// kept, so that away from the cut, where the piece's surface is the
/// parent's, the node stays where it was, and near it (the multilinear
/// interpolant rounds the max() kink of eq. 14-15 at the new rim by up to
/// ~h/4, a re-gridded piece's finer grid less) it moves onto the piece's
/// surface with its offset. The shift moves the grid's zero set, whose
/// enclosed volume it matches to the piece's mass, not the parent's nodes:
/// they were on the parent's surface. A node the projection could not
/// bring to the surface (a parent node several cells from the piece it was
/// given to, left up to a cell outside it and outside the parent; or one
/// beside a sliver whose grid values stay just above zero, left 0.008 cells
/// out: both found by fuzz_split) is not a surface node of this piece:
/// dropped; a converged projection is within 1e-4 cells. Nodes that landed
/// on one point are one node. `h` is the parent's spacing.
///
/// `starts` gets, per node kept, the point it was projected from (the
/// parent's node, or the cut's), for movedNodes().
template <int D>
NodeSet<D> nodesOnPiece(NodeSet<D> nodes, const std::vector<char>& fromParent, const Grid<D>& pieceGrid,
                        geometry::GridInterpolant interpolant, const SurfaceShift<D>& shift, const Grid<D>& parentGrid,
                        geometry::GridInterpolant levelInterpolant, double h, double nodesPerCell,
                        std::vector<Vec<D>>& starts) {
  starts.clear();
  std::size_t keptCount = 0;
  for (std::size_t n = 0; n < nodes.size(); ++n) {
    // The offset and the shift both fade to 0 by the cut (SurfaceShift::
    // weight): there a node with its offset would come round the rim onto
    // the sibling's side, inside it.
    const Vec<D>& start = nodes.positions[n];
    const double level =
        fromParent[n]
            ? (geometry::interpolantValue(parentGrid, start, levelInterpolant) - shift.delta) * shift.weight(start)
            : 0.0;
    const Vec<D> x = geometry::projectOntoLevel(pieceGrid, nodes.positions[n], level, interpolant, 1e-4, 10);
    if (!(std::abs(geometry::interpolantValue(pieceGrid, x, interpolant) - level) <= 1e-3 * h)) continue;
    starts.push_back(nodes.positions[n]);
    nodes.positions[keptCount] = x;
    nodes.weights[keptCount] = nodes.weights[n];
    ++keptCount;
  }
  nodes.positions.resize(keptCount);
  nodes.weights.resize(keptCount);
  mergeCoincidentNodes(nodes, 0.25 * h / nodesPerCell, &starts);
  return nodes;
}

/// Where a piece's nodes that are new to it lie (its grid frame), by first
/// coordinate: those carried from their start (nodesOnPiece) farther than
/// their start's distance from the piece's surface plus kSlideCells of the
/// parent's cells. Moving a node onto the piece's surface takes about that
/// distance; where the interpolant's gradient is weak (near a rim) the
/// projection's capped Newton steps can slide a node most of a cell along
/// the surface, and there a neighbour may overlap the surface where no node
/// of the parent felt it (a 3D fragment was born holding 100x its parent's
/// spring energy, 18 % of the run's energy scale, from one node slid 0.8
/// cells into a grain's overlap). Such a node is new to the fragment, as a
/// cut face's are (Fragment::cutFaceNodes).
template <int D>
std::vector<Vec<D>> movedNodes(const NodeSet<D>& nodes, const std::vector<Vec<D>>& starts, const Grid<D>& pieceGrid,
                               double h) {
  std::vector<Vec<D>> out;
  for (std::size_t n = 0; n < starts.size(); ++n) {
    const double travel = (nodes.positions[n] - starts[n]).norm();
    if (travel > std::abs(pieceGrid.value(starts[n])) + kSlideCells * h) out.push_back(nodes.positions[n]);
  }
  std::sort(out.begin(), out.end(), [](const Vec<D>& a, const Vec<D>& b) { return a[0] < b[0]; });
  return out;
}

/// Surface nodes of a grid at `nodesPerCell`, raised until there are at least
/// `minNodes` (a fragment is never a handful of nodes); empty when the grid
/// has no surface. With the Catmull-Rom `interpolant` (the contact's) they
/// are moved on from the multilinear zero set to its.
template <int D>
NodeSet<D> nodesWithFloor(const Grid<D>& grid, double nodesPerCell, int minNodes, geometry::GridInterpolant interpolant) {
  geometry::SurfaceProjector<D> onSurface;
  if (interpolant == geometry::GridInterpolant::CatmullRom) {
    onSurface = [&grid](const Vec<D>& x) {
      return geometry::projectOntoLevel(grid, x, 0.0, geometry::GridInterpolant::CatmullRom);
    };
  }
  NodeSet<D> nodes;
  for (int attempt = 0; attempt < 4; ++attempt) {
    if constexpr (D == 2) {
      nodes = geometry::surfaceNodes(grid, nodesPerCell, onSurface);
    } else {
      nodes = geometry::surfaceNodes(grid, nodesPerCell, nullptr, onSurface);
    }
    if (nodes.empty() || nodes.size() >= std::size_t(minNodes)) break;
    // Node counts grow like density^(D-1): raise it by the shortfall.
    nodesPerCell *= 1.05 * std::pow(double(minNodes) / double(nodes.size()), 1.0 / double(D - 1));
  }
  return nodes;
}

}  // namespace

void validateSplitOptions(const SplitOptions& options) {
  const auto fail = [](const std::string& what) { throw std::invalid_argument("split options: " + what); };
  if (!std::isfinite(options.nodesPerCell) || options.nodesPerCell < 0.0) {
    fail("nodesPerCell must be finite and >= 0, got " + std::to_string(options.nodesPerCell));
  }
  if (options.paddingCells < 3) fail("paddingCells must be >= 3, got " + std::to_string(options.paddingCells));
  if (!std::isfinite(options.regridCells) || options.regridCells < 0.0) {
    fail("regridCells must be finite and >= 0, got " + std::to_string(options.regridCells));
  }
  if (options.regridMaxFactor < 1) fail("regridMaxFactor must be >= 1, got " + std::to_string(options.regridMaxFactor));
  if (options.regridMaxNodes < 64) fail("regridMaxNodes must be >= 64, got " + std::to_string(options.regridMaxNodes));
  if (!std::isfinite(options.regridMinVolume) || options.regridMinVolume < 0.0) {
    fail("regridMinVolume must be finite and >= 0, got " + std::to_string(options.regridMinVolume));
  }
  if (!(options.maxSurfaceShift >= 0.0 && options.maxSurfaceShift <= 1.0)) {
    fail("maxSurfaceShift must be in [0, 1] cells, got " + std::to_string(options.maxSurfaceShift));
  }
  if (options.minFragmentNodes < 1) {
    fail("minFragmentNodes must be >= 1, got " + std::to_string(options.minFragmentNodes));
  }
}

template <int D>
SplitResult<D> splitShape(const Shape<D>& parent, const FractureSurface<D>& surface, const SplitOptions& options,
                          const geometry::SignedDistance<D>& clearance) {
  // Check the arguments.
  if (!surface.plane && !surface.field) {
    throw std::invalid_argument("splitShape: the fracture surface has neither a plane nor a field");
  }
  validateSplitOptions(options);
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
  childOptions.contactSpacing = parent.contactSpacing();

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
  geometry::SignedDistance<D> psi;
  if (planeGrid) {
    psi = [p = *planeGrid](const Vec<D>& x) { return p.distance(x); };
  } else {
    psi = [&](const Vec<D>& x) { return surface.field(bodyToGrid.applyInverse(x)); };
  }
  Grid<D> minusGrid, plusGrid;
  try {
    geometry::csgSplit(grid, psi, minusGrid, plusGrid);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("splitShape: the fracture surface is NaN at a grid node (") + e.what() + ")");
  }
  std::array<Side<D>, 2> sides;
  sides[0].sign = -1;
  sides[0].pieces = sidePieces(minusGrid, options.paddingCells);
  sides[1].sign = +1;
  sides[1].pieces = sidePieces(plusGrid, options.paddingCells);

  // A surface that leaves one side without interior does not split the grain.
  if (sides[0].pieces.empty() || sides[1].pieces.empty()) return result;
  for (Side<D>& side : sides) {
    side.nodes.resize(side.pieces.size());
    side.fromParent.resize(side.pieces.size());
  }

  // Nodes of a flat cut: the parent's by the sign of phi_f, then the new plane
  // nodes on both sides, each to the piece whose grid is smallest at it.
  if (planeGrid) {
    const NodeSet<D>& parentNodes = parent.nodes();
    for (std::size_t i = 0; i < parentNodes.size(); ++i) {
      const Vec<D> x = bodyToGrid.apply(parentNodes.positions[i]);
      Side<D>& side = sides[planeGrid->distance(x) < 0.0 ? 0 : 1];
      const std::size_t piece = owningPiece(side.pieces, x);
      side.nodes[piece].positions.push_back(x);
      side.nodes[piece].weights.push_back(parentNodes.weights[i]);
      side.fromParent[piece].push_back(1);
    }
    const NodeSet<D> onPlane =
        planeNodes(grid, *planeGrid, bodyToGrid.translation, parent.boundingRadius(), h / nodesPerCell);
    for (Side<D>& side : sides) {
      for (std::size_t i = 0; i < onPlane.size(); ++i) {
        const std::size_t piece = owningPiece(side.pieces, onPlane.positions[i]);
        side.nodes[piece].positions.push_back(onPlane.positions[i]);
        side.nodes[piece].weights.push_back(onPlane.weights[i]);
        side.fromParent[piece].push_back(0);
      }
    }
  }

  // Mass: the parent's own integrand (eq. 24-30) partitioned among the pieces,
  // about the centre of the parent's grid box, in the parent's grid frame.
  const double epsilon = 1.5 * h;
  Vec<D> centreCells;
  for (int a = 0; a < D; ++a) centreCells[a] = 0.5 * double(grid.dims()[a] - 1);
  const Vec<D> reference = grid.toWorld(centreCells);
  const std::vector<geometry::MassSums<D>> shares =
      planeGrid ? partitionMass(grid, epsilon, [p = *planeGrid](const Vec<D>& x) { return p.distance(x); },
                                &planeGrid->normal, sides, reference)
                : partitionMass(grid, epsilon, psi, static_cast<const Vec<D>*>(nullptr), sides, reference);
  const double cellVolume = std::pow(h, D);
  std::vector<geometry::MassProperties<D>> pieceMass;
  double sharesTotal = 0.0;
  for (const geometry::MassSums<D>& share : shares) {
    pieceMass.push_back(share.properties(childOptions.massMethod, cellVolume, reference));
    sharesTotal += pieceMass.back().volume;
  }
  // The factor that makes the shares carry the parent's volume (the one
  // applied below, over the kept pieces: the same unless a piece is dropped).
  const double shareScale = sharesTotal > 0.0 ? result.parentVolume / sharesTotal : 1.0;

  // Each piece: its grid (re-gridded when small), its nodes, its share of the mass.
  struct Piece {
    Grid<D> grid;
    NodeSet<D> nodes;
    geometry::MassProperties<D> mass;
    int side = 0;
    bool regridded = false;
    bool freshNodes = false;  ///< its nodes made afresh, not the parent's
    std::vector<Vec<D>> starts;  ///< per node, where it was projected from (empty when made afresh)
    double nodesPerCell = 0.0;  ///< of the piece's own grid: what its own splits put on their cut faces
    double nodeStiffnessScale = 1.0;  ///< ShapeOptions::nodeStiffnessScale
  };
  std::vector<Piece> kept;
  double keptVolume = 0.0;
  for (std::size_t s = 0; s < 2; ++s) {
    Side<D>& side = sides[s];
    for (std::size_t k = 0; k < side.pieces.size(); ++k) {
      Piece piece;
      piece.side = side.sign;
      piece.nodesPerCell = nodesPerCell;
      piece.nodeStiffnessScale = parent.nodeStiffnessScale();
      piece.mass = pieceMass[slotOf(sides, s, k)];
      // Its surface moved to enclose its share of the parent's volume, when asked.
      const auto matchSurface = [&](Grid<D>& pieceGrid) {
        const double g = pieceGrid.spacing(), maxShift = options.maxSurfaceShift * h;
        const double diagonal = std::sqrt(double(D)) * g;
        const SurfaceShift<D> unshifted{&psi,  &clearance, &bodyToGrid, h, g, std::max(diagonal, maxShift),
                                        std::max(diagonal, 2.0 * maxShift), 2.0 * maxShift, &side, k, 0.0};
        if (!options.matchEnclosedVolume) return unshifted;
        const SurfaceShift<D> shift = matchEnclosedVolume(pieceGrid, unshifted, piece.mass.volume * shareScale, maxShift);
        result.largestSurfaceShift = std::max(result.largestSurfaceShift, std::abs(shift.delta) / h);
        return shift;
      };
      // A piece thinner than regridCells of its cells gets a finer grid of its
      // own (within the memory bound) and nodes made afresh on it.
      if (options.regridCells > 0.0 && piece.mass.volume > options.regridMinVolume) {
        const double extent = smallestExtent(piece.mass);
        double fine = std::max(extent / options.regridCells, h / double(options.regridMaxFactor));
        const PieceExtent<D> where = pieceExtent(side.pieces[k]);
        const double count = coveringNodes(where.box, fine, options.paddingCells);
        if (count > double(options.regridMaxNodes)) fine *= std::pow(count / double(options.regridMaxNodes), 1.0 / D);
        if (fine < 0.9 * h) {
          Grid<D> refined = regridPiece(grid, psi, side, k, where, fine, options.paddingCells);
          const SurfaceShift<D> shift = matchSurface(refined);
          const double density = options.regridKeepsNodeSpacing ? nodesPerCell * refined.spacing() / h : nodesPerCell;
          // At the parent's node spacing, the parent's own nodes (and the
          // cut's) where there are enough of them: a node made afresh between
          // two of the parent's, where a neighbour overlaps the surface more
          // than at either, started with a spring the parent never had (a
          // 2D fragment re-gridded against a platen held 5x its parent's
          // spring energy the moment it was born).
          NodeSet<D> nodes;
          bool ownNodes = false;
          if (options.regridKeepsNodeSpacing && planeGrid) {
            // The refined grid samples the parent's multilinear field: a
            // node keeps its offset from that.
            nodes = nodesOnPiece(std::move(side.nodes[k]), side.fromParent[k], refined, options.nodeInterpolant, shift,
                                 grid, geometry::GridInterpolant::Multilinear, h, nodesPerCell, piece.starts);
            ownNodes = nodes.size() >= std::size_t(options.minFragmentNodes);
          }
          if (!ownNodes) nodes = nodesWithFloor(refined, density, options.minFragmentNodes, options.nodeInterpolant);
          pullInsideParent(nodes, refined, grid, psi, side, k, shift, ownNodes ? &piece.starts : nullptr);
          if (!nodes.empty()) {
            piece.grid = std::move(refined);
            piece.nodes = std::move(nodes);
            piece.regridded = true;
            piece.freshNodes = !ownNodes;
            // The node spacing in metres passes on to this piece's own
            // fragments (with "per_new_cell" the density per cell does).
            piece.nodesPerCell = density;
            // Nodes made afresh stand for less (or more) surface each than
            // the parent's: the per-node stiffness follows, so the stiffness
            // per unit surface stays the parent's.
            if (!ownNodes) piece.nodeStiffnessScale *= piece.nodes.meanWeight() / parent.meanNodeWeight();
          }
        }
      }
      if (!piece.regridded) {
        // A copy: a later piece of this side may be re-gridded beside it.
        piece.grid = side.pieces[k];
        const SurfaceShift<D> shift = matchSurface(piece.grid);
        NodeSet<D> nodes = nodesOnPiece(std::move(side.nodes[k]), side.fromParent[k], piece.grid,
                                        geometry::GridInterpolant::Multilinear, shift, grid,
                                        geometry::GridInterpolant::Multilinear, h, nodesPerCell, piece.starts);
        if (nodes.empty()) {
          nodes = nodesWithFloor(piece.grid, nodesPerCell, 1, geometry::GridInterpolant::Multilinear);
          piece.freshNodes = true;
        }
        piece.nodes = std::move(nodes);
      }
      if (piece.nodes.empty() || !(piece.mass.volume > 0.0)) {
        result.droppedRawVolume += std::max(0.0, piece.mass.volume);
        ++result.droppedCount;
        continue;
      }
      keptVolume += piece.mass.volume;
      kept.push_back(std::move(piece));
    }
  }
  if (kept.size() < 2) return result;
  result.isSplit = true;
  result.rawVolumeSum = keptVolume;
  // The shares' quadrature against the parent's own grid's estimate (sub-cell
  // samples along the cut against node samples; ~1e-4). A fragment's volume is
  // its share of its own parent's, which its grid's estimate need not equal
  // (a surface moved to enclose it, SplitOptions::matchEnclosedVolume, gives
  // a smoothed-Heaviside volume about 1 % above it): the parent's volume is
  // not the reference for the quadrature.
  const double parentGridVolume = geometry::massProperties(grid, childOptions.massMethod).volume;
  result.rawRelativeError = (keptVolume + result.droppedRawVolume - parentGridVolume) / parentGridVolume;

  // Carry the parent's volume exactly: the shares differ from it by the
  // quadrature (rawRelativeError) and, for a fragment, by its grid's estimate
  // against its share; one common factor removes both.
  const double scale = result.parentVolume / keptVolume;
  const Rigid<D> gridToParentBody = bodyToGrid.inverse();
  for (Piece& piece : kept) {
    piece.mass.volume *= scale;
    piece.mass.secondMoment *= scale;
    Fragment<D> fragment;
    // The child grid's own estimate, for comparison only (0 where it has none).
    try {
      fragment.rawVolume = geometry::massProperties(piece.grid, childOptions.massMethod).volume;
    } catch (const std::invalid_argument&) {
      fragment.rawVolume = 0.0;
    }
    fragment.volume = piece.mass.volume;
    fragment.side = piece.side;
    fragment.regridded = piece.regridded;
    geometry::ShapeOptions pieceOptions = childOptions;
    pieceOptions.nodesPerCell = piece.nodesPerCell;
    pieceOptions.nodeStiffnessScale = piece.nodeStiffnessScale;
    // The nodes moved to new points, found by position: the shape reorders its nodes.
    const std::vector<Vec<D>> movedAt =
        piece.freshNodes ? std::vector<Vec<D>>{} : movedNodes(piece.nodes, piece.starts, piece.grid, h);
    fragment.shape =
        Shape<D>::fromGridNodesAndMass(std::move(piece.grid), std::move(piece.nodes), piece.mass, pieceOptions);
    fragment.childToParent = gridToParentBody * fragment.shape->bodyToGrid();
    // Its nodes that were not the parent's: on the new face, moved to a new
    // point, or all when made afresh. Indices of the shape's nodes, which it
    // keeps in its node tree's order, not the order they were made in (the
    // piece's grid frame is the parent's).
    const double pieceSpacing = fragment.shape->grid().spacing();
    const double sameNode = 1e-9 * h;  // the body-frame round trip's round-off is far below
    const auto wasMoved = [&](const Vec<D>& x) {
      auto it = std::lower_bound(movedAt.begin(), movedAt.end(), x[0] - sameNode,
                                 [](const Vec<D>& a, double v) { return a[0] < v; });
      for (; it != movedAt.end() && (*it)[0] <= x[0] + sameNode; ++it) {
        if ((*it - x).norm() <= sameNode) return true;
      }
      return false;
    };
    const auto& shapeNodes = fragment.shape->nodes().positions;
    for (std::size_t n = 0; n < shapeNodes.size(); ++n) {
      const Vec<D> x = fragment.shape->bodyToGrid().apply(shapeNodes[n]);
      if (piece.freshNodes || (std::abs(psi(x)) < 0.25 * pieceSpacing && grid.value(x) < -0.05 * h) || wasMoved(x)) {
        fragment.cutFaceNodes.push_back(std::uint32_t(n));
      }
    }
    result.fragments.push_back(std::move(fragment));
  }

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

template SplitResult<2> splitShape<2>(const Shape<2>&, const FractureSurface<2>&, const SplitOptions&,
                                          const geometry::SignedDistance<2>&);
template SplitResult<3> splitShape<3>(const Shape<3>&, const FractureSurface<3>&, const SplitOptions&,
                                          const geometry::SignedDistance<3>&);
template FragmentState<2> fragmentState<2>(const Fragment<2>&, const Vec<2>&, const Mat<2>&, const Vec<2>&,
                                           const dynamics::Spin<2>&);
template FragmentState<3> fragmentState<3>(const Fragment<3>&, const Vec<3>&, const Mat<3>&, const Vec<3>&,
                                           const dynamics::Spin<3>&);

}  // namespace lsdem::breakage
