#pragma once
/// @file Meshes.h
/// @brief Test helpers shared by the suites: small closed triangle meshes
/// (a box, a subdivided icosahedron) with outward faces.

#include "lsdem/geometry/TriangleMesh.h"

#include <array>
#include <cmath>
#include <map>
#include <utility>
#include <vector>

namespace lsdem::test {

using geometry::TriangleMesh;
using geometry::Vec;

/// Flips every face whose normal points toward `centre` (for convex test solids).
inline void orientOutward(TriangleMesh& mesh, const Vec<3>& centre) {
  for (auto& f : mesh.faces) {
    const Vec<3>& a = mesh.vertices[std::size_t(f[0])];
    const Vec<3>& b = mesh.vertices[std::size_t(f[1])];
    const Vec<3>& c = mesh.vertices[std::size_t(f[2])];
    if ((b - a).cross(c - a).dot((a + b + c) / 3.0 - centre) < 0) std::swap(f[1], f[2]);
  }
}

/// An axis-aligned box as 12 outward triangles.
inline TriangleMesh boxMesh(const Vec<3>& centre, const Vec<3>& half) {
  TriangleMesh mesh;
  for (int c = 0; c < 8; ++c) {
    mesh.vertices.push_back(centre + Vec<3>((c & 1) ? half[0] : -half[0], (c & 2) ? half[1] : -half[1],
                                            (c & 4) ? half[2] : -half[2]));
  }
  // Each face: the 4 corners with bit `axis` equal to `side`, split in two.
  for (int axis = 0; axis < 3; ++axis) {
    for (int side = 0; side < 2; ++side) {
      int quad[4], n = 0;
      for (int c = 0; c < 8; ++c) {
        if (((c >> axis) & 1) == side) quad[n++] = c;
      }
      // quad holds corners in bit order: (0, 1, 3, 2) goes around the face.
      mesh.faces.push_back({quad[0], quad[1], quad[3]});
      mesh.faces.push_back({quad[0], quad[3], quad[2]});
    }
  }
  orientOutward(mesh, centre);
  return mesh;
}

/// An icosahedron subdivided `levels` times, vertices on the sphere of radius R.
inline TriangleMesh icosphere(double R, int levels) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  TriangleMesh mesh;
  for (const Vec<3>& v : {Vec<3>(-1, t, 0), Vec<3>(1, t, 0), Vec<3>(-1, -t, 0), Vec<3>(1, -t, 0), Vec<3>(0, -1, t),
                          Vec<3>(0, 1, t), Vec<3>(0, -1, -t), Vec<3>(0, 1, -t), Vec<3>(t, 0, -1), Vec<3>(t, 0, 1),
                          Vec<3>(-t, 0, -1), Vec<3>(-t, 0, 1)}) {
    mesh.vertices.push_back(R * v.normalized());
  }
  mesh.faces = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                {11, 10, 2}, {10, 7, 6}, {7, 1, 8},   {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                {3, 8, 9},  {4, 9, 5},  {2, 4, 11},  {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<int, int>, int> midpoint;
    auto middle = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      const auto it = midpoint.find(key);
      if (it != midpoint.end()) return it->second;
      mesh.vertices.push_back(R * (mesh.vertices[std::size_t(a)] + mesh.vertices[std::size_t(b)]).normalized());
      return midpoint[key] = int(mesh.vertices.size()) - 1;
    };
    std::vector<std::array<int, 3>> faces;
    for (const auto& f : mesh.faces) {
      const int ab = middle(f[0], f[1]), bc = middle(f[1], f[2]), ca = middle(f[2], f[0]);
      faces.push_back({f[0], ab, ca});
      faces.push_back({f[1], bc, ab});
      faces.push_back({f[2], ca, bc});
      faces.push_back({ab, bc, ca});
    }
    mesh.faces = std::move(faces);
  }
  orientOutward(mesh, Vec<3>::Zero());
  return mesh;
}

}  // namespace lsdem::test
