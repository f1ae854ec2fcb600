#pragma once
/// @file CgalMesh.h
/// @brief PRIVATE to geometry/src: the CGAL types the geometry layer uses and
/// conversions between them and TriangleMesh. Include it only from the .cpp
/// files that need CGAL (each such file costs ~30 s to compile); never from a
/// public header.

#include "lsdem/geometry/TriangleMesh.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>

#include <string>
#include <vector>

namespace lsdem::geometry::cgal {

/// Kernel: exact predicates, double-precision constructions.
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
/// Halfedge surface mesh of triangles.
using SurfaceMesh = CGAL::Surface_mesh<Point>;
using VertexIndex = SurfaceMesh::Vertex_index;
using FaceIndex = SurfaceMesh::Face_index;

inline Point toPoint(const Vec<3>& x) { return Point(x[0], x[1], x[2]); }
inline Vec<3> toVec(const Point& p) { return Vec<3>(p.x(), p.y(), p.z()); }

/// @brief The mesh as a CGAL surface mesh with the same vertex and face order.
/// @note Precondition: face indices in range and the faces form a manifold
/// (every edge in at most two faces, traversed in opposite directions, and one
/// fan of faces around every vertex); throws MeshError when CGAL cannot join a
/// face.
inline SurfaceMesh toSurfaceMesh(const TriangleMesh& mesh) {
  SurfaceMesh out;
  out.reserve(SurfaceMesh::size_type(mesh.vertices.size()), SurfaceMesh::size_type(3 * mesh.faces.size() / 2),
              SurfaceMesh::size_type(mesh.faces.size()));
  for (const Vec<3>& v : mesh.vertices) out.add_vertex(toPoint(v));
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    const auto& t = mesh.faces[f];
    const FaceIndex added = out.add_face(VertexIndex(SurfaceMesh::size_type(t[0])), VertexIndex(SurfaceMesh::size_type(t[1])),
                                         VertexIndex(SurfaceMesh::size_type(t[2])));
    if (added == SurfaceMesh::null_face()) {
      throw MeshError("face " + std::to_string(f) + " cannot be joined to a manifold surface mesh");
    }
  }
  return out;
}

/// @brief A CGAL surface mesh (triangles) as a TriangleMesh, vertices renumbered
/// densely in the mesh's vertex order (removed elements skipped).
inline TriangleMesh toTriangleMesh(const SurfaceMesh& mesh) {
  TriangleMesh out;
  std::vector<int> number(mesh.num_vertices(), -1);  // used + removed slots
  out.vertices.reserve(mesh.number_of_vertices());
  for (const VertexIndex v : mesh.vertices()) {
    number[std::size_t(v)] = int(out.vertices.size());
    out.vertices.push_back(toVec(mesh.point(v)));
  }
  out.faces.reserve(mesh.number_of_faces());
  for (const FaceIndex f : mesh.faces()) {
    std::array<int, 3> t{};
    std::size_t q = 0;
    for (const VertexIndex v : CGAL::vertices_around_face(mesh.halfedge(f), mesh)) {
      if (q < 3) t[q] = number[std::size_t(v)];
      ++q;
    }
    if (q != 3) throw MeshError("surface mesh face " + std::to_string(std::size_t(f)) + " is not a triangle");
    out.faces.push_back(t);
  }
  return out;
}

}  // namespace lsdem::geometry::cgal
