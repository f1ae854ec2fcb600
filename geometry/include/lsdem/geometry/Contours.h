#pragma once
/// @file Contours.h
/// @brief The zero level set (eq. 2) of a grid as explicit geometry: closed
/// polylines in 2D (marching squares) and a closed triangle mesh in 3D
/// (marching tetrahedra on a Kuhn decomposition of each cube).
///
/// Common rules:
/// - A node is inside when phi < 0; phi >= 0 counts as outside.
/// - A contour vertex lies on a grid edge whose end nodes differ in sign, at the
///   zero of the linear interpolant along that edge. Its fraction along the edge
///   is clamped to [1e-3, 1 - 1e-3] so that a node whose value is exactly 0 never
///   produces coincident vertices or zero-length / zero-area pieces; the shift
///   this causes is at most 1e-3 cells.
/// - Vertices are keyed by grid edge, so neighbouring cells share them.
/// - The region beyond the grid counts as outside: when inside nodes reach the
///   grid's border, the grid is surrounded by a virtual ring of outside nodes
///   (value +spacing) one cell beyond it, so contours and meshes are always
///   closed.

#include "lsdem/geometry/Grid.h"
#include "lsdem/geometry/TriangleMesh.h"

#include <vector>

namespace lsdem::geometry {

/// @brief Marching squares: the zero level set (eq. 2) of a 2D grid as closed polylines.
/// @param grid level set, world units, phi < 0 inside.
/// @return One polyline per closed contour, world units; the last point is not
/// a repeat of the first. Each runs with the inside on its left, so it is
/// counter-clockwise around a solid and clockwise around a hole. Ambiguous
/// saddle cells (diagonal corners alike) are resolved by the cell-centre
/// average of the four corner values (centre inside when the average is < 0).
/// Loops come in the order of their first vertex in a row-major cell scan
/// (deterministic); empty when no node is inside.
std::vector<std::vector<Vec<2>>> marchingSquares(const Grid<2>& grid);

/// @brief The zero level set (eq. 2) of a 3D grid as a watertight, manifold,
/// outward-oriented triangle mesh with shared vertices.
/// @param grid level set, world units, phi < 0 inside.
/// @return Mesh in world units; empty when no node is inside.
/// @note Method: every grid cube is cut into 6 tetrahedra around its main
/// diagonal (Kuhn / Freudenthal decomposition). Neighbouring cubes cut their
/// common face along the same diagonal, so the tetrahedra form a consistent
/// triangulation of the grid; in a tetrahedron the linear interpolant's zero set
/// is one triangle or one quad (split along its shorter diagonal) with no
/// ambiguous case. The result is therefore closed and 2-manifold with the
/// topology of the sign pattern, with no holes at ambiguous cube faces (the
/// classic 15-case tables can leave some), at the price of about twice as many
/// triangles as classic marching cubes. Output order is deterministic and
/// independent of the thread count.
TriangleMesh marchingCubes(const Grid<3>& grid);

/// @brief Area (2D) / volume (3D) enclosed by the zero level set as lsdem
/// draws it (the surfaces output): the shoelace sum of marchingSquares' loops,
/// or the signed volume of marchingCubes' mesh; world units^D. 0 when no node
/// is inside.
template <int D>
double enclosedVolume(const Grid<D>& grid);

extern template double enclosedVolume<2>(const Grid<2>&);
extern template double enclosedVolume<3>(const Grid<3>&);

}  // namespace lsdem::geometry
