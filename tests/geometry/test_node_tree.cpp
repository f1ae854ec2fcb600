#include "lsdem/geometry/NodeTree.h"
#include "lsdem/geometry/ShapeDef.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>
#include <vector>

using namespace lsdem::geometry;

namespace {

// Every cell's sphere holds the nodes of its range; children split their
// parent's range in two; leaves hold 1..leafSize nodes and cover every node
// once; `order` is a permutation.
template <int D>
void checkTree(const std::vector<Vec<D>>& nodes, int leafSize) {
  const NodeTree<D> tree = NodeTree<D>::build(nodes, leafSize);
  ASSERT_FALSE(tree.cells.empty());
  std::vector<std::uint32_t> sorted = tree.order;
  std::sort(sorted.begin(), sorted.end());
  std::vector<std::uint32_t> identity(nodes.size());
  std::iota(identity.begin(), identity.end(), 0u);
  EXPECT_EQ(sorted, identity);
  EXPECT_EQ(tree.cells[0].begin, 0u);
  EXPECT_EQ(tree.cells[0].end, nodes.size());
  std::size_t inLeaves = 0;
  for (const auto& cell : tree.cells) {
    for (std::uint32_t k = cell.begin; k < cell.end; ++k) {
      EXPECT_LE((nodes[tree.order[k]] - cell.centre).norm(), cell.radius);
    }
    if (cell.child == 0) {
      EXPECT_GE(cell.end - cell.begin, 1u);
      EXPECT_LE(cell.end - cell.begin, std::uint32_t(leafSize));
      inLeaves += cell.end - cell.begin;
    } else {
      const auto& a = tree.cells[cell.child];
      const auto& b = tree.cells[cell.child + 1];
      EXPECT_EQ(a.begin, cell.begin);
      EXPECT_EQ(a.end, b.begin);
      EXPECT_EQ(b.end, cell.end);
    }
  }
  EXPECT_EQ(inLeaves, nodes.size());
  // Deterministic.
  const NodeTree<D> again = NodeTree<D>::build(nodes, leafSize);
  EXPECT_EQ(again.order, tree.order);
}

}  // namespace

TEST(NodeTree, CellsHoldTheirNodesAndLeavesCoverAll) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<Vec<3>> sphere(1000);
  for (Vec<3>& x : sphere) x = Vec<3>(n(rng), n(rng), n(rng)).normalized();
  checkTree<3>(sphere, 8);
  checkTree<3>(sphere, 1);
  std::vector<Vec<2>> ring(77);
  for (Vec<2>& x : ring) x = Vec<2>(n(rng), n(rng)).normalized();
  checkTree<2>(ring, 8);
  // Repeated positions (ties on every axis) and a single node.
  checkTree<3>(std::vector<Vec<3>>(20, Vec<3>(1.0, 2.0, 3.0)), 8);
  checkTree<2>({Vec<2>(0.5, 0.5)}, 8);
  EXPECT_TRUE(NodeTree<3>::build({}).cells.empty());
  EXPECT_THROW(NodeTree<3>::build(sphere, 0), std::invalid_argument);
}

// A shape keeps its nodes in tree order (a leaf is a run of node indices),
// and its slope bound is about 1 for a sampled distance.
TEST(NodeTree, ShapesKeepNodesInTreeOrder) {
  ShapeDef<3> def;
  def.kind = ShapeKind::Ellipsoid;
  def.semiAxes = Vec<3>(0.5, 0.4, 0.3);
  def.cellsAcross = 12;
  const auto shape = buildShape(def);
  const NodeTree<3>& tree = shape->nodeTree();
  ASSERT_EQ(tree.order.size(), shape->nodes().size());
  for (std::uint32_t k = 0; k < tree.order.size(); ++k) EXPECT_EQ(tree.order[k], k);
  EXPECT_GT(shape->levelSetSlope(), 0.99);
  EXPECT_LT(shape->levelSetSlope(), 1.8);
}
