#pragma once
/// @file Csg.h
/// @brief Constructive solid geometry on level sets (eq. 14-16): how a grain is
/// split by a fracture surface, and how fragments recombine.
///
/// Every operation returns a grid with the first operand's layout (dims, origin,
/// spacing) whose node values are the node-wise max/min of a's value and the
/// second operand's value at that node's world position. The second operand is
/// either another grid, read with Grid::value() (multilinear inside its box, the
/// distance-like extension phi(c) + |x - c| outside it), or an analytic signed
/// distance such as a fracture plane (eq. 18-20) or a primitive.
///
/// The results are exact set operations on the node samples; away from the new
/// surface they are no longer signed distances outside the shape (the paper's
/// remark after eq. 16), which reinitialisation (eq. 17) repairs if needed.

#include "lsdem/geometry/Grid.h"
#include "lsdem/geometry/Types.h"

#include <functional>

namespace lsdem::geometry {

/// An analytic signed distance phi_b(world point), world units, phi < 0 inside.
/// The CSG functions call it once per node of the grid operand, from several
/// threads at once when OpenMP is on: it must be safe to call concurrently (a
/// pure function of its argument).
template <int D>
using SignedDistance = std::function<double(const Vec<D>&)>;

/// @brief eq. 14: a minus b, max(phi_a, -phi_b), on a's grid.
/// @param a level-set grid of the shape that is cut (world units).
/// @param b level-set grid of the cutter; sampled at a's nodes with Grid::value()
/// (b's grid may have any origin and spacing).
/// @note Throws std::invalid_argument when either grid is empty.
template <int D>
Grid<D> csgDifference(const Grid<D>& a, const Grid<D>& b);

/// @brief eq. 15: the intersection of a and b, max(phi_a, phi_b), on a's grid.
/// @param a level-set grid (world units); the result has its layout.
/// @param b level-set grid, sampled at a's nodes with Grid::value().
/// @note Throws std::invalid_argument when either grid is empty.
template <int D>
Grid<D> csgIntersection(const Grid<D>& a, const Grid<D>& b);

/// @brief eq. 16: the union of a and b, min(phi_a, phi_b), on a's grid.
/// Recombining the two halves of eq. 14 and 15 gives back the original inside
/// set: min(max(phi, -psi), max(phi, psi)) = max(phi, -|psi|), which equals phi
/// wherever phi >= -|psi|.
/// @param a level-set grid (world units); the result has its layout.
/// @param b level-set grid, sampled at a's nodes with Grid::value().
/// @note Throws std::invalid_argument when either grid is empty. Parts of b
/// outside a's box are lost (the result lives on a's grid).
template <int D>
Grid<D> csgUnion(const Grid<D>& a, const Grid<D>& b);

/// @brief eq. 14 with an analytic cutter: max(phi_a, -phi_b(x)) at a's nodes.
/// @param a level-set grid (world units).
/// @param b signed distance of the cutter at a world point, world units.
/// @note Throws std::invalid_argument when a is empty or b is an empty function.
template <int D>
Grid<D> csgDifference(const Grid<D>& a, const SignedDistance<D>& b);

/// @brief eq. 15 with an analytic operand: max(phi_a, phi_b(x)) at a's nodes.
/// @param a level-set grid (world units).
/// @param b signed distance at a world point, world units.
/// @note Throws std::invalid_argument when a is empty or b is an empty function.
template <int D>
Grid<D> csgIntersection(const Grid<D>& a, const SignedDistance<D>& b);

/// @brief eq. 16 with an analytic operand: min(phi_a, phi_b(x)) at a's nodes.
/// @param a level-set grid (world units).
/// @param b signed distance at a world point, world units.
/// @note Throws std::invalid_argument when a is empty or b is an empty function.
template <int D>
Grid<D> csgUnion(const Grid<D>& a, const SignedDistance<D>& b);

/// @brief eq. 15 and eq. 14 in one pass, as a split by a fracture surface
/// needs them: `negative` = max(phi_a, phi_b(x)) (the part of a where
/// phi_b < 0, csgIntersection) and `positive` = max(phi_a, -phi_b(x)) (the
/// part where phi_b > 0, csgDifference), with phi_b evaluated once per node.
/// @param a level-set grid (world units); both results have its layout.
/// @param b signed distance of the fracture surface at a world point, world units.
/// @param negative receives eq. 15. @param positive receives eq. 14.
/// @note Throws std::invalid_argument when a is empty, b is an empty function
/// or b is NaN at a node (the message names the first such node).
template <int D>
void csgSplit(const Grid<D>& a, const SignedDistance<D>& b, Grid<D>& negative, Grid<D>& positive);

extern template Grid<2> csgDifference<2>(const Grid<2>&, const Grid<2>&);
extern template Grid<3> csgDifference<3>(const Grid<3>&, const Grid<3>&);
extern template Grid<2> csgIntersection<2>(const Grid<2>&, const Grid<2>&);
extern template Grid<3> csgIntersection<3>(const Grid<3>&, const Grid<3>&);
extern template Grid<2> csgUnion<2>(const Grid<2>&, const Grid<2>&);
extern template Grid<3> csgUnion<3>(const Grid<3>&, const Grid<3>&);
extern template Grid<2> csgDifference<2>(const Grid<2>&, const SignedDistance<2>&);
extern template Grid<3> csgDifference<3>(const Grid<3>&, const SignedDistance<3>&);
extern template Grid<2> csgIntersection<2>(const Grid<2>&, const SignedDistance<2>&);
extern template Grid<3> csgIntersection<3>(const Grid<3>&, const SignedDistance<3>&);
extern template Grid<2> csgUnion<2>(const Grid<2>&, const SignedDistance<2>&);
extern template Grid<3> csgUnion<3>(const Grid<3>&, const SignedDistance<3>&);
extern template void csgSplit<2>(const Grid<2>&, const SignedDistance<2>&, Grid<2>&, Grid<2>&);
extern template void csgSplit<3>(const Grid<3>&, const SignedDistance<3>&, Grid<3>&, Grid<3>&);

}  // namespace lsdem::geometry
