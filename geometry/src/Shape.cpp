#include "lsdem/geometry/Shape.h"

#include "lsdem/geometry/SurfaceNodes.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace lsdem::geometry {

namespace {

// The contact options every way of making a shape checks.
void validateContactOptions(const ShapeOptions& options) {
  if (!(options.contactSpacing >= 0.0) || !std::isfinite(options.contactSpacing)) {
    throw std::invalid_argument("contact spacing must be finite and >= 0, got " + std::to_string(options.contactSpacing));
  }
  if (!(options.nodeStiffnessScale > 0.0) || !std::isfinite(options.nodeStiffnessScale)) {
    throw std::invalid_argument("node stiffness scale must be finite and > 0, got " +
                                std::to_string(options.nodeStiffnessScale));
  }
}

// The tricubic look-up's data (Shape::CubicLookup) of a grid whose
// multilinear bounding radius about `centroid` (grid frame) is
// `boundingRadius`: the cells where the cubic may be <= 0 (smallest corner -
// deviation bound <= 0; elsewhere it is above the multilinear interpolant's
// corner minimum less the bound, > 0) set the margin, the reach and their
// own cell margins.
template <int D>
typename Shape<D>::CubicLookup cubicData(const Grid<D>& grid, double boundingRadius, const Vec<D>& centroid) {
  const std::vector<float> deviation = grid.cubicDeviationBounds();
  const Index<D> dims = grid.dims();
  std::array<std::size_t, 1 << D> cornerOffset;
  for (int c = 0; c < (1 << D); ++c) {
    Index<D> corner;
    for (int a = 0; a < D; ++a) corner[a] = (c >> a) & 1;
    cornerOffset[std::size_t(c)] = grid.linear(corner);
  }
  typename Shape<D>::CubicLookup data;
  double margin = 0.0;
  double reach2 = boundingRadius * boundingRadius;
  // Per cell: its deviation bound where the cubic may be <= 0, else -1.
  std::vector<double> cellBound(grid.size(), -1.0);
  Index<D> i = Index<D>::Zero();
  for (std::size_t n = 0; n < grid.size(); ++n, grid.advance(i)) {
    if ((i >= dims - 1).any()) continue;
    double lo = grid[n], hi = grid[n];
    for (const std::size_t o : cornerOffset) {
      lo = std::min(lo, double(grid[n + o]));
      hi = std::max(hi, double(grid[n + o]));
    }
    const double e = deviation[n];
    if (lo - e > 0.0) continue;
    cellBound[n] = e;
    margin = std::max(margin, std::min(e, hi));
    for (int c = 0; c < (1 << D); ++c) {
      Index<D> corner = i;
      for (int a = 0; a < D; ++a) corner[a] += (c >> a) & 1;
      reach2 = std::max(reach2, (grid.nodePosition(corner) - centroid).squaredNorm());
    }
  }
  data.margin = margin;
  data.boundingRadius = std::sqrt(reach2);
  // Cell margins: in a cell where the cubic may be <= 0, a multilinear
  // value above e (or above E >= min(e, hi), which it exceeds only when e
  // <= hi, the value being <= hi in the cell) makes the cubic positive;
  // elsewhere the cubic is positive throughout (0). Rounded up to whole
  // steps of E / 255, the unit raised until 255 steps reach E.
  double unit = margin / 255.0;
  while (255.0 * unit < margin) unit = std::nextafter(unit, std::numeric_limits<double>::infinity());
  data.cellUnit = unit;
  data.cellSteps.assign(grid.size(), 0);
  if (margin > 0.0) {
    for (std::size_t n = 0; n < grid.size(); ++n) {
      if (cellBound[n] < 0.0) continue;
      const double bound = std::min(cellBound[n], margin);
      double steps = std::min(std::ceil(bound / unit), 255.0);
      while (steps < 255.0 && unit * steps < bound) steps += 1.0;
      data.cellSteps[n] = std::uint8_t(steps);
    }
  }
  // The gradient bound. Per axis, the Catmull-Rom derivative of four values
  // v0..v3 at t is sum_k a_k(t) (v_{k+1} - v_k), with a_0 = (3t - 1)(t - 1) / 2,
  // a_1 = (1 + 6t - 6t^2) / 2, a_2 = t (3t - 2) / 2, and sum_k |a_k| <= 3/2
  // (at t = 1/2); along every other axis the weights sum in absolute value to
  // 1 + t (1 - t) <= 5/4. A stencil clamped at the border repeats a node (a
  // difference of 0), so the largest difference of grid neighbours bounds all.
  {
    std::array<double, D> largest{};
    std::size_t stride = 1;
    for (int a = 0; a < D; ++a) {
      Index<D> j = Index<D>::Zero();
      for (std::size_t n = 0; n < grid.size(); ++n, grid.advance(j)) {
        if (j[a] + 1 < dims[a]) largest[a] = std::max(largest[a], std::abs(double(grid[n + stride]) - double(grid[n])));
      }
      stride *= std::size_t(dims[a]);
    }
    double sum2 = 0.0;
    for (int a = 0; a < D; ++a) sum2 += largest[a] * largest[a];
    data.slope = 1.5 * std::pow(1.25, D - 1) * std::sqrt(sum2) / grid.spacing();
  }
  // The largest over the cells within one cell along every axis: a running
  // maximum along each axis in turn (the index clamped to the grid).
  data.nearSteps = data.cellSteps;
  std::vector<std::uint8_t> scratch(grid.size());
  std::size_t stride = 1;
  for (int a = 0; a < D; ++a) {
    Index<D> j = Index<D>::Zero();
    for (std::size_t n = 0; n < grid.size(); ++n, grid.advance(j)) {
      std::uint8_t m = data.nearSteps[n];
      if (j[a] > 0) m = std::max(m, data.nearSteps[n - stride]);
      if (j[a] + 1 < dims[a]) m = std::max(m, data.nearSteps[n + stride]);
      scratch[n] = m;
    }
    data.nearSteps.swap(scratch);
    stride *= std::size_t(dims[a]);
  }
  return data;
}

}  // namespace

template <int D>
std::shared_ptr<const Shape<D>> Shape<D>::fromGrid(Grid<D> grid, const ShapeOptions& options) {
  if (!(options.nodesPerCell > 0.0) || !std::isfinite(options.nodesPerCell)) {
    throw std::invalid_argument("node density must be positive, got " + std::to_string(options.nodesPerCell));
  }
  NodeSet<D> nodes = surfaceNodes(grid, options.nodesPerCell);
  if (nodes.empty()) {
    throw std::invalid_argument("the level set has no surface to place nodes on");
  }
  return fromGridAndNodes(std::move(grid), std::move(nodes), options);
}

template <int D>
std::shared_ptr<const Shape<D>> Shape<D>::fromGridAndNodes(Grid<D> grid, NodeSet<D> nodesGrid,
                                                          const ShapeOptions& options) {
  // Mass properties in the grid frame from the grid itself (eq. 24-30).
  const MassProperties<D> massGrid = massProperties(grid, options.massMethod);
  return fromGridNodesAndMass(std::move(grid), std::move(nodesGrid), massGrid, options);
}

template <int D>
std::shared_ptr<const Shape<D>> Shape<D>::fromGridNodesAndMass(Grid<D> grid, NodeSet<D> nodesGrid,
                                                              const MassProperties<D>& massGrid,
                                                              const ShapeOptions& options) {
  if (nodesGrid.empty() || nodesGrid.positions.size() != nodesGrid.weights.size()) {
    throw std::invalid_argument("a shape needs surface nodes with one weight each (" +
                                std::to_string(nodesGrid.positions.size()) + " positions, " +
                                std::to_string(nodesGrid.weights.size()) + " weights)");
  }
  if (!(massGrid.volume > 0.0) || !std::isfinite(massGrid.volume)) {
    throw std::invalid_argument("the level set has no interior (volume " + std::to_string(massGrid.volume) + ")");
  }
  if (!massGrid.centroid.allFinite() || !massGrid.secondMoment.allFinite()) {
    throw std::invalid_argument("the shape's mass properties are not finite");
  }
  validateContactOptions(options);
  std::shared_ptr<Shape> shape(new Shape());
  shape->options_ = options;

  // The body frame is the principal frame at the centroid.
  shape->bodyToGrid_.rotation = massGrid.principalAxes();
  shape->bodyToGrid_.translation = massGrid.centroid;

  // Descriptors from the grid-frame nodes; then the nodes move to the body frame.
  shape->descriptors_ = computeDescriptors(grid, massGrid, nodesGrid);
  shape->nodes_.weights = std::move(nodesGrid.weights);
  shape->nodes_.positions.reserve(nodesGrid.positions.size());
  double radius = 0.0;
  for (const Vec<D>& p : nodesGrid.positions) {
    shape->nodes_.positions.push_back(shape->bodyToGrid_.applyInverse(p));
    radius = std::max(radius, shape->nodes_.positions.back().norm());
  }

  // Body-frame mass properties: centroid at the origin, diagonal second moment.
  shape->mass_ = massGrid;
  shape->mass_.centroid.setZero();
  shape->mass_.secondMoment = massGrid.principalSecondMoments().asDiagonal();

  // Bounding radius: it must hold all of {phi < 0} of the interpolated grid,
  // which reaches past the nodes (a fragment's edge where its cut meets the
  // old surface can hold none) and up to a cell past the interior grid
  // nodes. Every cell with an interior corner lies inside the corners of the
  // 3^D block about that corner, so the block's farthest corner (per axis the
  // farther side) bounds it. A radius from the nodes and interior grid nodes
  // alone let a neighbour's node reach 0.1 cell into a fragment before the
  // narrow phase looked (a 3D crushing cascade gained 51 % of its energy
  // scale that way).
  const Index<D> last = grid.dims() - 1;
  double radius2 = radius * radius;
  Index<D> i = Index<D>::Zero();
  for (std::size_t n = 0; n < grid.size(); ++n, grid.advance(i)) {
    if (!(grid[n] < 0.0f)) continue;
    const Vec<D> lo = grid.nodePosition((i - 1).max(Index<D>::Zero())) - massGrid.centroid;
    const Vec<D> hi = grid.nodePosition((i + 1).min(last)) - massGrid.centroid;
    radius2 = std::max(radius2, lo.cwiseAbs2().cwiseMax(hi.cwiseAbs2()).sum());
  }
  radius = std::sqrt(radius2);
  shape->boundingRadius_ = radius;
  shape->grid_ = std::move(grid);
  shape->deriveSearchData();
  // Nodes in the tree's order, so a tree leaf is a run of consecutive node
  // indices and the narrow phase finds contacts in node order without sorting.
  {
    NodeTree<D>& tree = shape->nodeTree_;
    NodeSet<D> ordered;
    ordered.positions.reserve(tree.order.size());
    ordered.weights.reserve(tree.order.size());
    for (std::uint32_t i : tree.order) {
      ordered.positions.push_back(shape->nodes_.positions[i]);
      ordered.weights.push_back(shape->nodes_.weights[i]);
    }
    shape->nodes_ = std::move(ordered);
    for (std::uint32_t k = 0; k < tree.order.size(); ++k) tree.order[k] = k;
  }
  return shape;
}

template <int D>
std::shared_ptr<const Shape<D>> Shape<D>::fromParts(Parts parts) {
  // Validate what a consumer of the shape relies on; the values themselves are trusted.
  if (parts.grid.size() == 0) throw std::invalid_argument("shape parts: the grid is empty");
  if (parts.nodes.empty() || parts.nodes.positions.size() != parts.nodes.weights.size()) {
    throw std::invalid_argument("shape parts: need surface nodes with one weight each (" +
                                std::to_string(parts.nodes.positions.size()) + " positions, " +
                                std::to_string(parts.nodes.weights.size()) + " weights)");
  }
  if (!(parts.mass.volume > 0.0) || !std::isfinite(parts.mass.volume)) {
    throw std::invalid_argument("shape parts: volume must be positive, got " + std::to_string(parts.mass.volume));
  }
  if (!(parts.boundingRadius > 0.0) || !std::isfinite(parts.boundingRadius)) {
    throw std::invalid_argument("shape parts: bounding radius must be positive, got " +
                                std::to_string(parts.boundingRadius));
  }
  for (std::size_t n = 0; n < parts.grid.size(); ++n) {
    if (!std::isfinite(parts.grid[n])) throw std::invalid_argument("shape parts: grid value " + std::to_string(n) + " is not finite");
  }
  for (std::size_t i = 0; i < parts.nodes.size(); ++i) {
    if (!parts.nodes.positions[i].allFinite() || !std::isfinite(parts.nodes.weights[i]) || parts.nodes.weights[i] < 0.0) {
      throw std::invalid_argument("shape parts: node " + std::to_string(i) + " has a non-finite position or a bad weight");
    }
  }
  validateContactOptions(parts.options);
  if (!parts.mass.secondMoment.allFinite() || !parts.bodyToGrid.rotation.allFinite() ||
      !parts.bodyToGrid.translation.allFinite()) {
    throw std::invalid_argument("shape parts: mass properties or body-to-grid map not finite");
  }
  std::shared_ptr<Shape> shape(new Shape());
  shape->grid_ = std::move(parts.grid);
  shape->bodyToGrid_ = parts.bodyToGrid;
  shape->nodes_ = std::move(parts.nodes);
  shape->mass_ = parts.mass;
  shape->descriptors_ = parts.descriptors;
  shape->boundingRadius_ = parts.boundingRadius;
  shape->options_ = parts.options;
  shape->deriveSearchData();
  return shape;
}

template <int D>
void Shape<D>::deriveSearchData() {
  nodeTree_ = NodeTree<D>::build(nodes_.positions);
  levelSetSlope_ = grid_.maxGradientNorm();
}

template <int D>
void Shape<D>::deriveCubicData() const {
  std::call_once(cubicOnce_.flag, [this] {
    cubic_ = cubicData(grid_, boundingRadius_, bodyToGrid_.translation);
  });
}

template <int D>
typename Shape<D>::Parts Shape<D>::parts() const {
  return Parts{grid_, bodyToGrid_, nodes_, mass_, descriptors_, boundingRadius_, options_};
}

template <int D>
std::size_t Shape<D>::bytes() const {
  return sizeof(Shape) + grid_.bytes() + nodes_.positions.size() * sizeof(Vec<D>) + nodes_.weights.size() * sizeof(double) +
         nodeTree_.bytes();
}

template class Shape<2>;
template class Shape<3>;

}  // namespace lsdem::geometry
