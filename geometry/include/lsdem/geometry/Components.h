#pragma once
/// @file Components.h
/// @brief Connected components of a level set's interior: a split (eq. 14-15)
/// of a concave grain can leave one side in several pieces, and each piece must
/// become its own particle.
///
/// Connectivity is between interior nodes (phi < 0; phi == 0 counts as outside)
/// that share a grid edge: 4 neighbours in 2D, 6 in 3D. Two pieces that touch
/// only diagonally are separate components.

#include "lsdem/geometry/Grid.h"
#include "lsdem/geometry/Types.h"

#include <vector>

namespace lsdem::geometry {

/// @brief Labels the interior nodes (phi < 0) by face-connected component
/// (4 neighbours in 2D, 6 in 3D); -1 outside.
/// @param grid level-set grid.
/// @param labels resized to grid.size(); labels[n] is the component of linear
/// node n (0, 1, ...) or -1 when phi >= 0. Components are numbered in order of
/// their lowest linear node index.
/// @return the number of components (0 for an empty grid or one with no interior).
template <int D>
int labelComponents(const Grid<D>& grid, std::vector<int>& labels);

/// @brief Each face-connected component of the interior as its own level-set grid.
///
/// Component k's grid is node-aligned with the input (same spacing, origin
/// shifted by whole cells) and spans the bounding box of k's nodes plus
/// `paddingCells` cells on every side (at least 2 nodes per axis); nodes beyond
/// the input's box take Grid::value's outside extension phi(c) + |x - c|. Its
/// values, with d_k the exact Euclidean distance (world units) from the node to
/// the nearest node of component k and h the spacing, are
///   - phi                        on k's own nodes,
///   - d_k - h (> 0)              on interior nodes of other components
///                                (they are at least h sqrt(2) from k),
///   - max(phi, d_k - h sqrt(D))  on exterior nodes (phi >= 0).
/// The last bound never changes an exterior node of a cell that touches k (such
/// nodes are within h sqrt(D) of a k node), so k's own zero level set, as the
/// multilinear interpolant sees it, is exactly that of the input, except in
/// cells that also hold nodes of another component (pieces touching only
/// diagonally), which must be separated. d_k - h sqrt(D) is a lower bound of
/// the distance to k's zero set (which lies within h sqrt(D) of k's nodes), as
/// phi is for signed distances and their CSG combinations, so exterior values only move towards k's true signed distance: the
/// other components' surfaces disappear from the field and stay out of k's
/// smoothed-Heaviside band (MassProperties.h). (max(phi, d_k - h) on exterior
/// nodes would also raise nodes diagonal to k's nodes and move k's surface.)
/// @param grid level-set grid (world units).
/// @param paddingCells cells added around each component's node bounding box, >= 0.
/// @return the components in labelComponents() order (empty when there is no interior).
/// @note Throws std::invalid_argument when paddingCells < 0.
template <int D>
std::vector<Grid<D>> connectedComponents(const Grid<D>& grid, int paddingCells = kDefaultPaddingCells);

extern template int labelComponents<2>(const Grid<2>&, std::vector<int>&);
extern template int labelComponents<3>(const Grid<3>&, std::vector<int>&);
extern template std::vector<Grid<2>> connectedComponents<2>(const Grid<2>&, int);
extern template std::vector<Grid<3>> connectedComponents<3>(const Grid<3>&, int);

}  // namespace lsdem::geometry
