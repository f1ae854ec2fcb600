#include "lsdem/geometry/TriangleMesh.h"

#include <cmath>
#include <string>

namespace lsdem::geometry {

namespace {

// Throws when face f refers to a vertex the mesh does not have.
void checkFace(const TriangleMesh& mesh, std::size_t f) {
  for (const int v : mesh.faces[f]) {
    if (v < 0 || std::size_t(v) >= mesh.vertices.size()) {
      throw std::invalid_argument("triangle mesh face " + std::to_string(f) + " refers to vertex " +
                                  std::to_string(v) + " but the mesh has " +
                                  std::to_string(mesh.vertices.size()) + " vertices");
    }
  }
}

}  // namespace

double TriangleMesh::area() const {
  // Half the norm of each face's edge cross product, summed in face order.
  double total = 0.0;
  for (std::size_t f = 0; f < faces.size(); ++f) {
    checkFace(*this, f);
    const Vec<3>& a = vertices[std::size_t(faces[f][0])];
    const Vec<3>& b = vertices[std::size_t(faces[f][1])];
    const Vec<3>& c = vertices[std::size_t(faces[f][2])];
    total += 0.5 * (b - a).cross(c - a).norm();
  }
  return total;
}

double TriangleMesh::signedVolume() const {
  // Tetrahedra from the centre of the bounds to each face (divergence theorem).
  const Box<3> box = bounds();
  const Vec<3> ref = 0.5 * (box.lower + box.upper);
  double total = 0.0;
  for (std::size_t f = 0; f < faces.size(); ++f) {
    checkFace(*this, f);
    const Vec<3> a = vertices[std::size_t(faces[f][0])] - ref;
    const Vec<3> b = vertices[std::size_t(faces[f][1])] - ref;
    const Vec<3> c = vertices[std::size_t(faces[f][2])] - ref;
    total += a.dot(b.cross(c));
  }
  return total / 6.0;
}

Box<3> TriangleMesh::bounds() const {
  // Component-wise min and max over the vertices.
  Box<3> box;
  if (vertices.empty()) return box;
  box.lower = vertices.front();
  box.upper = vertices.front();
  for (const Vec<3>& v : vertices) {
    box.lower = box.lower.cwiseMin(v);
    box.upper = box.upper.cwiseMax(v);
  }
  return box;
}

}  // namespace lsdem::geometry
