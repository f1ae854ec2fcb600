#include "lsdem/geometry/MeshToLevelSet.h"

#include "CgalMesh.h"

#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Side_of_triangle_mesh.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <utility>
#include <vector>

namespace lsdem::geometry {

namespace {

namespace PMP = CGAL::Polygon_mesh_processing;
using SideOfMesh = CGAL::Side_of_triangle_mesh<cgal::SurfaceMesh, cgal::Kernel>;
using Tree = SideOfMesh::AABB_tree;

// "3 degenerate faces" / "1 degenerate face".
std::string count(int n, const std::string& singular, const std::string& plural) {
  return std::to_string(n) + " " + (n == 1 ? singular : plural);
}

// Edge checks: every undirected edge must be used by exactly two faces, once
// in each direction. Counts border, non-manifold and misoriented edges.
void inspectEdges(const TriangleMesh& mesh, MeshReport& report) {
  // Directed edges as (undirected key, direction), sorted so equal edges are adjacent.
  std::vector<std::pair<std::uint64_t, int>> edges;
  edges.reserve(3 * mesh.faces.size());
  for (const auto& f : mesh.faces) {
    for (std::size_t q = 0; q < 3; ++q) {
      const std::uint64_t a = std::uint64_t(f[q]), b = std::uint64_t(f[(q + 1) % 3]);
      if (a == b) continue;  // a face with a repeated vertex (already counted degenerate)
      edges.emplace_back(a < b ? (a << 32 | b) : (b << 32 | a), a < b ? 1 : 0);
    }
  }
  std::sort(edges.begin(), edges.end());
  // One group per undirected edge: its use count and how many uses run forward.
  for (std::size_t first = 0; first < edges.size();) {
    std::size_t last = first;
    int forward = 0;
    while (last < edges.size() && edges[last].first == edges[first].first) forward += edges[last++].second;
    const std::size_t uses = last - first;
    if (uses == 1) {
      ++report.borderEdges;
    } else if (uses > 2) {
      ++report.nonManifoldEdges;
    } else if (forward != 1) {
      ++report.misorientedEdges;
    }
    first = last;
  }
}

// Vertex check (edges already manifold and consistent): the faces around a
// vertex must form a single fan. In face (v, b, c) the vertex's link has the
// edge b -> c; the link must be one cycle (interior vertex) or one chain (border
// vertex), not several.
void inspectVertices(const TriangleMesh& mesh, MeshReport& report) {
  // Link edges grouped by vertex (counting sort).
  const std::size_t nv = mesh.vertices.size();
  std::vector<std::size_t> start(nv + 1, 0);
  for (const auto& f : mesh.faces) {
    if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2]) continue;
    for (const int v : f) ++start[std::size_t(v) + 1];
  }
  for (std::size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
  std::vector<std::pair<int, int>> link(start[nv]);
  std::vector<std::size_t> fill(start.begin(), start.end() - 1);
  for (const auto& f : mesh.faces) {
    if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2]) continue;
    for (std::size_t q = 0; q < 3; ++q) link[fill[std::size_t(f[q])]++] = {f[(q + 1) % 3], f[(q + 2) % 3]};
  }

  // Per vertex: count the pieces of the link (chains from their heads, then
  // the remaining cycles); more than one means separate fans.
  std::vector<char> used;
  for (std::size_t v = 0; v < nv; ++v) {
    const auto begin = link.begin() + std::ptrdiff_t(start[v]), end = link.begin() + std::ptrdiff_t(start[v + 1]);
    if (begin == end) continue;
    std::sort(begin, end);
    const std::size_t n = std::size_t(end - begin);
    used.assign(n, 0);
    auto follow = [&](std::size_t e) {
      while (!used[e]) {
        used[e] = 1;
        const auto next = std::lower_bound(begin, end, std::pair<int, int>{(begin + std::ptrdiff_t(e))->second, -1});
        if (next == end || next->first != (begin + std::ptrdiff_t(e))->second) return;
        e = std::size_t(next - begin);
      }
    };
    int pieces = 0;
    for (std::size_t e = 0; e < n; ++e) {
      // A chain head: its source is no edge's target.
      const int source = (begin + std::ptrdiff_t(e))->first;
      const bool isHead = std::none_of(begin, end, [&](const std::pair<int, int>& l) { return l.second == source; });
      if (isHead) {
        ++pieces;
        follow(e);
      }
    }
    for (std::size_t e = 0; e < n; ++e) {
      if (!used[e]) {
        ++pieces;
        follow(e);
      }
    }
    if (pieces > 1) ++report.nonManifoldVertices;
  }
}

}  // namespace

bool MeshReport::ok() const {
  return !empty && borderEdges == 0 && nonManifoldEdges == 0 && misorientedEdges == 0 && nonManifoldVertices == 0 &&
         badIndexFaces == 0 && nonFiniteVertices == 0 && degenerateFaces == 0 && !selfIntersecting && !inverted &&
         bodies <= 1;
}

std::string MeshReport::describe() const {
  // One phrase per problem, in the order the checks run.
  std::vector<std::string> parts;
  if (empty) parts.push_back("is empty");
  if (badIndexFaces > 0) parts.push_back("has " + count(badIndexFaces, "face", "faces") + " with vertex indices out of range");
  if (nonFiniteVertices > 0) parts.push_back("has " + count(nonFiniteVertices, "non-finite vertex", "non-finite vertices"));
  if (borderEdges > 0) parts.push_back("is not closed (" + count(borderEdges, "border edge", "border edges") + ")");
  if (nonManifoldEdges > 0) {
    parts.push_back("is not manifold (" + count(nonManifoldEdges, "edge", "edges") + " shared by more than two faces)");
  }
  if (misorientedEdges > 0) {
    parts.push_back("is inconsistently oriented (" + count(misorientedEdges, "edge", "edges") +
                    " traversed the same way by both faces)");
  }
  if (nonManifoldVertices > 0) {
    parts.push_back("is not manifold (" + count(nonManifoldVertices, "vertex", "vertices") + " where separate sheets touch)");
  }
  if (degenerateFaces > 0) {
    parts.push_back("has " + count(degenerateFaces, "degenerate (zero-area) face", "degenerate (zero-area) faces") +
                    " (the first: face " + std::to_string(firstDegenerateFace) + ")");
  }
  if (selfIntersecting) parts.push_back("self-intersects");
  if (inverted) parts.push_back("is inverted (normals point inward)");
  if (bodies > 1) {
    parts.push_back("holds " + std::to_string(bodies) + " separate bodies (a grain or tool is one body: put each in a file of its own)");
  }
  if (parts.empty()) return "is ok";
  std::string out = parts.front();
  for (std::size_t p = 1; p < parts.size(); ++p) out += "; " + parts[p];
  return out;
}

MeshReport inspectMesh(const TriangleMesh& mesh) {
  MeshReport report;
  // Emptiness, then indices: nothing else can be checked without them.
  if (mesh.faces.empty() || mesh.vertices.empty()) {
    report.empty = true;
    return report;
  }
  for (const auto& f : mesh.faces) {
    const bool bad = std::any_of(f.begin(), f.end(), [&](int v) { return v < 0 || std::size_t(v) >= mesh.vertices.size(); });
    report.badIndexFaces += bad ? 1 : 0;
  }
  if (report.badIndexFaces > 0) return report;
  for (const Vec<3>& v : mesh.vertices) report.nonFiniteVertices += v.allFinite() ? 0 : 1;
  if (report.nonFiniteVertices > 0) return report;

  // Degenerate faces: a repeated vertex or three collinear points (exact predicate).
  for (std::size_t k = 0; k < mesh.faces.size(); ++k) {
    const auto& f = mesh.faces[k];
    const bool repeated = f[0] == f[1] || f[1] == f[2] || f[0] == f[2];
    if (repeated || CGAL::collinear(cgal::toPoint(mesh.vertices[std::size_t(f[0])]),
                                    cgal::toPoint(mesh.vertices[std::size_t(f[1])]),
                                    cgal::toPoint(mesh.vertices[std::size_t(f[2])]))) {
      if (report.degenerateFaces++ == 0) report.firstDegenerateFace = (long long)k;
    }
  }

  // Topology: edges, then vertices.
  inspectEdges(mesh, report);
  if (report.nonManifoldEdges > 0 || report.misorientedEdges > 0) return report;
  inspectVertices(mesh, report);
  if (report.nonManifoldVertices > 0) return report;

  // Geometry on a manifold surface mesh: self-intersections (undefined with
  // degenerate faces), then orientation of a closed mesh: every shell must face
  // away from the solid it bounds (CGAL does_bound_a_volume, which needs a
  // self-intersection-free mesh; otherwise the sign of the volume decides).
  cgal::SurfaceMesh surface = cgal::toSurfaceMesh(mesh);
  if (report.degenerateFaces == 0) report.selfIntersecting = PMP::does_self_intersect(surface);
  if (report.borderEdges == 0) {
    const bool boundsVolume = (report.degenerateFaces == 0 && !report.selfIntersecting)
                                  ? PMP::does_bound_a_volume(surface)
                                  : mesh.signedVolume() > 0.0;
    report.inverted = !boundsVolume || !(mesh.signedVolume() > 0.0);
    // How many solids: two closed bodies in one file would become one grain.
    if (report.degenerateFaces == 0 && !report.selfIntersecting && !report.inverted) {
      auto volume = surface.add_property_map<cgal::FaceIndex, std::size_t>("f:volume", 0).first;
      report.bodies = int(PMP::volume_connected_components(surface, volume));
    }
  }
  return report;
}

Grid<3> meshToLevelSet(const TriangleMesh& mesh, double spacing, int paddingCells, const std::string& name) {
  if (!std::isfinite(spacing) || !(spacing > 0.0)) {
    throw std::invalid_argument("mesh '" + name + "': level-set spacing must be positive and finite, got " +
                                std::to_string(spacing));
  }
  if (paddingCells < 0) {
    throw std::invalid_argument("mesh '" + name + "': padding must be >= 0 cells, got " + std::to_string(paddingCells));
  }
  const MeshReport report = inspectMesh(mesh);
  if (!report.ok()) throw MeshError("mesh '" + name + "': " + report.describe());

  // Distance tree (with its k-d tree for distance hints) and the side-of-mesh
  // functor, built once here: the parallel queries below only read them.
  const cgal::SurfaceMesh surface = cgal::toSurfaceMesh(mesh);
  Tree tree(faces(surface).first, faces(surface).second, surface);
  tree.build();
  tree.accelerate_distance_queries();
  const SideOfMesh side(tree);

  // Rows along x, in parallel over z-slices. Along a row the previous closest
  // point is the search hint, and the sign is inherited from the previous node
  // when the surface cannot lie between them (d_prev + d > spacing); otherwise
  // (and at each row's first node) it comes from ray casting.
  Grid<3> grid = Grid<3>::covering(mesh.bounds(), spacing, paddingCells);
  const int nx = grid.dims()[0], ny = grid.dims()[1], nz = grid.dims()[2];
#pragma omp parallel for schedule(dynamic, 1)
  for (int k = 0; k < nz; ++k) {
    for (int j = 0; j < ny; ++j) {
      cgal::Point hint = tree.closest_point(cgal::toPoint(grid.nodePosition(Index<3>(0, j, k))));
      double previousDistance = 0.0;
      int previousSign = 0;
      for (int i = 0; i < nx; ++i) {
        const Index<3> node(i, j, k);
        const cgal::Point p = cgal::toPoint(grid.nodePosition(node));
        hint = tree.closest_point(p, hint);
        const double distance = std::sqrt(CGAL::squared_distance(p, hint));
        int sign = previousSign;
        if (i == 0 || !(previousDistance + distance > spacing * (1.0 + 1e-9))) {
          const CGAL::Bounded_side where = side(p);
          sign = where == CGAL::ON_BOUNDED_SIDE ? -1 : (where == CGAL::ON_BOUNDARY ? 0 : 1);
        }
        grid.at(node) = float(sign * distance);
        previousDistance = distance;
        previousSign = sign == 0 ? 1 : sign;
      }
    }
  }
  return grid;
}

namespace {

// A mesh and its distance tree, built once and only read by the queries
// (the tree keeps pointers into the mesh: the two never move apart).
struct MeshDistanceTree {
  explicit MeshDistanceTree(const TriangleMesh& mesh)
      : surface(cgal::toSurfaceMesh(mesh)), tree(faces(surface).first, faces(surface).second, surface) {
    tree.build();
    tree.accelerate_distance_queries();
  }
  cgal::SurfaceMesh surface;
  Tree tree;
};

}  // namespace

SurfaceProjector<3> meshSurfaceProjector(const TriangleMesh& mesh, double spacing) {
  if (!std::isfinite(spacing) || !(spacing > 0.0)) {
    throw std::invalid_argument("mesh surface projector: spacing must be positive and finite, got " +
                                std::to_string(spacing));
  }
  const auto index = std::make_shared<const MeshDistanceTree>(mesh);
  // The closest point of the triangles, where it is within a cell.
  return [index, spacing](const Vec<3>& x) {
    const Vec<3> y = cgal::toVec(index->tree.closest_point(cgal::toPoint(x)));
    return (y - x).norm() <= spacing ? y : x;
  };
}

}  // namespace lsdem::geometry
