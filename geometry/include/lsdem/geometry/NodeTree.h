#pragma once
/// @file NodeTree.h
/// @brief A bounding-sphere tree over a shape's surface nodes, so the narrow
/// phase can reject whole groups of nodes with one test instead of testing
/// every node (NarrowPhase.h, "Bulk rejection").
///
/// Built once per shape (Shape makes it; fragments get theirs at birth): the
/// nodes are split recursively at the median of the longest axis of their
/// bounding box until a group holds at most `leafSize` nodes. Each tree cell
/// keeps the centre of its nodes' bounding box and the radius of the sphere
/// about that centre holding them all, and a contiguous range of `order` (the
/// node indices in tree order; a new Shape stores its nodes in that order, so
/// a leaf's nodes are one stretch of memory). Children of cell c are cells `child` and `child + 1`; a leaf has
/// child 0 (the root, index 0, is nobody's child).
///
/// Deterministic: the same positions give the same tree.

#include "lsdem/geometry/Types.h"

#include <cstdint>
#include <vector>

namespace lsdem::geometry {

template <int D>
struct NodeTree {
  struct Cell {
    Vec<D> centre = Vec<D>::Zero();  ///< body frame, world units
    double radius = 0.0;             ///< every node of the cell is within this of centre
    std::uint32_t begin = 0, end = 0;  ///< range of order
    std::uint32_t child = 0;           ///< first child (second: child + 1); 0 for a leaf
  };
  std::vector<Cell> cells;              ///< cells[0] is the root (absent for no nodes)
  std::vector<std::uint32_t> order;     ///< node indices in tree order
  int depth = 0;                        ///< levels below the root (a traversal stack needs depth + 2 entries)

  /// Nodes per leaf at most (the default of build()).
  static constexpr int kLeafSize = 8;

  /// @brief The tree over `nodes` (body frame), leaves of at most `leafSize` (>= 1) nodes.
  static NodeTree build(const std::vector<Vec<D>>& nodes, int leafSize = kLeafSize);
  /// @brief Bytes held.
  std::size_t bytes() const {
    return cells.size() * sizeof(Cell) + order.size() * sizeof(std::uint32_t);
  }
};

extern template struct NodeTree<2>;
extern template struct NodeTree<3>;

}  // namespace lsdem::geometry
