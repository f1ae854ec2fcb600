#include "lsdem/geometry/NodeTree.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace lsdem::geometry {

template <int D>
NodeTree<D> NodeTree<D>::build(const std::vector<Vec<D>>& nodes, int leafSize) {
  if (leafSize < 1) throw std::invalid_argument("node tree: leaf size must be >= 1, got " + std::to_string(leafSize));
  NodeTree tree;
  const std::uint32_t n = std::uint32_t(nodes.size());
  if (n == 0) return tree;
  // The nodes with their indices, permuted in place as the tree splits them
  // (contiguous records: the selection reads no memory indirectly).
  struct Entry {
    Vec<D> x;
    std::uint32_t index;
  };
  std::vector<Entry> entries(n);
  for (std::uint32_t i = 0; i < n; ++i) entries[i] = {nodes[i], i};
  // A binary tree with leaves of >= leafSize / 2 nodes has fewer than 4 n / leafSize cells.
  tree.cells.reserve(std::size_t(4) * n / std::size_t(leafSize) + 2);
  tree.cells.push_back(Cell{Vec<D>::Zero(), 0.0, 0, n, 0});

  // Breadth-first over cells: children are appended in pairs, so a cell's
  // two children are adjacent; `level` tracks the depth reached.
  struct Pending {
    std::uint32_t cell;
    int level;
  };
  std::vector<Pending> queue{{0, 0}};
  for (std::size_t q = 0; q < queue.size(); ++q) {
    const auto [c, level] = queue[q];
    tree.depth = std::max(tree.depth, level);
    const std::uint32_t begin = tree.cells[c].begin, end = tree.cells[c].end;
    // Bounding box of the cell's nodes: its centre, then the radius about it.
    Vec<D> lo = entries[begin].x, hi = lo;
    for (std::uint32_t k = begin + 1; k < end; ++k) {
      lo = lo.cwiseMin(entries[k].x);
      hi = hi.cwiseMax(entries[k].x);
    }
    const Vec<D> centre = 0.5 * (lo + hi);
    double r2 = 0.0;
    for (std::uint32_t k = begin; k < end; ++k) r2 = std::max(r2, (entries[k].x - centre).squaredNorm());
    tree.cells[c].centre = centre;
    // Rounded up so the sphere holds every node despite the rounding of its own arithmetic.
    tree.cells[c].radius = std::sqrt(r2) * (1.0 + 1e-12) + 1e-300;
    if (end - begin <= std::uint32_t(leafSize)) continue;
    // Split at the median of the longest axis (ties by index, so the tree is deterministic).
    int axis = 0;
    (hi - lo).maxCoeff(&axis);
    const std::uint32_t mid = begin + (end - begin) / 2;
    std::nth_element(entries.begin() + begin, entries.begin() + mid, entries.begin() + end,
                     [axis](const Entry& a, const Entry& b) {
                       return a.x[axis] < b.x[axis] || (a.x[axis] == b.x[axis] && a.index < b.index);
                     });
    const std::uint32_t child = std::uint32_t(tree.cells.size());
    tree.cells[c].child = child;
    tree.cells.push_back(Cell{Vec<D>::Zero(), 0.0, begin, mid, 0});
    tree.cells.push_back(Cell{Vec<D>::Zero(), 0.0, mid, end, 0});
    queue.push_back({child, level + 1});
    queue.push_back({child + 1, level + 1});
  }
  // Median splits halve the count per level: 2^32 nodes give 30 levels; the
  // narrow phase's walk keeps depth + 2 cells on a fixed stack of 128.
  if (tree.depth > 120) throw std::logic_error("node tree: depth " + std::to_string(tree.depth) + " over 120");
  tree.order.reserve(n);
  for (const Entry& e : entries) tree.order.push_back(e.index);
  return tree;
}

template struct NodeTree<2>;
template struct NodeTree<3>;

}  // namespace lsdem::geometry
