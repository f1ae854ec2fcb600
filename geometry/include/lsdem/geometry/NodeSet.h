#pragma once
/// @file NodeSet.h
/// @brief Surface nodes of a shape (eq. 2): points on the zero level set, each
/// carrying the share of perimeter (2D) or surface area (3D) it stands for.

#include "lsdem/geometry/Types.h"

#include <numeric>
#include <vector>

namespace lsdem::geometry {

template <int D>
struct NodeSet {
  /// Node positions, in the frame of the grid they were made from (world units), N x D.
  std::vector<Vec<D>> positions;
  /// Length (2D) or area (3D) each node stands for, world units^(D-1); N values
  /// summing to the perimeter / surface area.
  std::vector<double> weights;

  std::size_t size() const { return positions.size(); }
  bool empty() const { return positions.empty(); }
  /// @brief Sum of the weights: the perimeter (2D) or surface area (3D).
  double totalWeight() const { return std::accumulate(weights.begin(), weights.end(), 0.0); }
  /// Mean weight: length (2D) or area (3D) a node stands for.
  double meanWeight() const { return totalWeight() / double(weights.size()); }
};

}  // namespace lsdem::geometry
