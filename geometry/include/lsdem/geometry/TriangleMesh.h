#pragma once
/// @file TriangleMesh.h
/// @brief A plain indexed triangle mesh (vertices + faces): what marching cubes
/// produces, what CAD files are read into and what surfaces are written out as.
///
/// Rationale: public headers expose no CGAL type, so meshes cross layer
/// boundaries in this simple form; the few .cpp files that need CGAL's surface
/// mesh convert to it and back (geometry/src/CgalMesh.h).

#include "lsdem/geometry/Types.h"

#include <array>
#include <stdexcept>
#include <vector>

namespace lsdem::geometry {

/// @brief A triangle mesh (CAD part, fragment surface, wall) that is broken or
/// cannot be read: the message names the mesh or file and says what is wrong.
class MeshError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// @brief An indexed triangle mesh in world units.
struct TriangleMesh {
  /// Vertex positions, world units, N x 3.
  std::vector<Vec<3>> vertices;
  /// Vertex indices of each triangle, counter-clockwise seen from outside
  /// (right-hand normals point outward), F x 3.
  std::vector<std::array<int, 3>> faces;

  /// @brief True when the mesh has no faces.
  bool empty() const { return faces.empty(); }

  /// @brief Total area of the faces, world units^2.
  /// @note Throws std::invalid_argument when a face refers to a missing vertex.
  double area() const;

  /// @brief Enclosed volume by the divergence theorem, world units^3: the sum
  /// over faces of the signed volume of the tetrahedron (reference point, face).
  /// Positive for a closed mesh with outward normals, negative when inverted.
  /// The reference point is the centre of the bounds, which keeps the sum
  /// accurate far from the origin.
  /// @note Only meaningful for a closed mesh (for an open one it depends on the
  /// reference point). Throws std::invalid_argument when a face refers to a
  /// missing vertex.
  double signedVolume() const;

  /// @brief Axis-aligned bounds of the vertices, world units (a zero box when
  /// there are no vertices).
  Box<3> bounds() const;
};

}  // namespace lsdem::geometry
