#pragma once
/// @file Decomposition.h
/// @brief Spatial domain decomposition by recursive coordinate bisection
/// (RCB), weighted: each rank owns the particles whose centroid lies in its
/// subdomain, a box of the cut tree (docs/parallel.md).
///
/// The tree is built from points and weights (a particle's cost: its surface
/// nodes). A node of the tree splits its points across the longest extent
/// of their bounding box, at the place where the weight on the lower side
/// reaches its share of the ranks below (parts / 2 of parts), so any rank
/// count works, not only powers of two. The build is a pure function of its
/// input: every rank that builds from the same points gets the same tree.
///
/// Plain RCB, written here, and not a partitioning library: a few dozen
/// lines that give the same cuts on every rank without communication, and
/// for the particle counts of a DEM run (10^4-10^6 centroids) the build is
/// milliseconds; the rebalance is rare (DistributedDef::rebalanceImbalance).

#include "lsdem/geometry/Types.h"

#include <cstdint>
#include <span>
#include <vector>

namespace lsdem::parallel {

template <int D>
using Vec = geometry::Vec<D>;

template <int D>
class Decomposition {
 public:
  /// @brief One part: the whole space.
  Decomposition();
  /// @brief The RCB of `points` with `weights` (> 0 each, same length) into
  /// `parts` >= 1 subdomains, numbered 0 .. parts-1; part p gets the share
  /// capacities[p] / sum of them of the weight (empty: equal shares).
  /// @note Throws std::invalid_argument for parts < 1, mismatched sizes or a
  /// capacity that is not positive and finite.
  static Decomposition build(std::span<const Vec<D>> points, std::span<const double> weights, int parts,
                             std::span<const double> capacities = {});

  int parts() const { return parts_; }
  /// @brief The part that owns a centroid at x (a point on a cut belongs to the upper side).
  int owner(const Vec<D>& x) const;
  /// @brief Part p's subdomain (infinite where it reaches the outside).
  const geometry::Box<D>& box(int p) const { return boxes_.at(std::size_t(p)); }
  /// @brief Distance from x to part p's subdomain (0 inside).
  double distance(const Vec<D>& x, int p) const;
  /// @brief Distance between parts p's and q's subdomains (0 where they touch).
  double distance(int p, int q) const;

 private:
  struct Node {
    int axis = -1;      // -1: a leaf
    double cut = 0.0;   // lower side: x[axis] < cut
    int lower = -1, upper = -1;  // child nodes
    int part = 0;       // a leaf's part
  };
  std::vector<Node> nodes_;
  std::vector<geometry::Box<D>> boxes_;
  int parts_ = 1;
};

extern template class Decomposition<2>;
extern template class Decomposition<3>;

}  // namespace lsdem::parallel
