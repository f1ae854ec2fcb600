#include "lsdem/geometry/Contours.h"

#include <algorithm>
#include <cmath>
#include <array>
#include <cstdint>
#include <optional>
#include <unordered_map>
#include <utility>

namespace lsdem::geometry {

namespace {

/// Smallest fraction along a grid edge at which a contour vertex is placed (see Contours.h).
constexpr double kMinEdgeFraction = 1e-3;

// Fraction along the edge from a node of value a to a node of value b (one
// inside, one outside, so a != b) where the linear interpolant is zero, clamped.
double crossingFraction(double a, double b) {
  return std::clamp(a / (a - b), kMinEdgeFraction, 1.0 - kMinEdgeFraction);
}

// True when any node on the grid's border is inside (phi < 0).
template <int D>
bool interiorReachesBorder(const Grid<D>& grid) {
  for (std::size_t n = 0; n < grid.size(); ++n) {
    if (!(grid[n] < 0.0f)) continue;
    const Index<D> i = grid.unlinear(n);
    if ((i == 0).any() || (i == grid.dims() - 1).any()) return true;
  }
  return false;
}

// The grid surrounded by a ring of outside nodes (value +spacing) one cell wide.
template <int D>
Grid<D> withOutsideRing(const Grid<D>& grid) {
  const double h = grid.spacing();
  Grid<D> out(grid.dims() + 2, grid.origin() - Vec<D>::Constant(h), h, float(h));
  for (std::size_t n = 0; n < grid.size(); ++n) out.at(grid.unlinear(n) + 1) = grid[n];
  return out;
}

// ---- marching tetrahedra tables ----------------------------------------------
// Cube corners are numbered by bits: bit 0 = +x, bit 1 = +y, bit 2 = +z.

// Signed volume (times 6) of the tetrahedron on four cube corners.
constexpr int orientation(const std::array<int, 4>& t) {
  int e[3][3] = {};
  for (int r = 0; r < 3; ++r) {
    for (int a = 0; a < 3; ++a) e[r][a] = ((t[std::size_t(r + 1)] >> a) & 1) - ((t[0] >> a) & 1);
  }
  return e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) - e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
         e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
}

// The 6 Kuhn tetrahedra of a cube: corner 0, then one axis step, a second axis
// step, and corner 7, for each order of the three axes; each positively
// oriented (two corners swapped when the axis order is an odd permutation).
constexpr std::array<std::array<int, 4>, 6> makeKuhnTetrahedra() {
  constexpr int orders[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  std::array<std::array<int, 4>, 6> tets{};
  for (std::size_t p = 0; p < 6; ++p) {
    std::array<int, 4> t = {0, 1 << orders[p][0], (1 << orders[p][0]) | (1 << orders[p][1]), 7};
    if (orientation(t) < 0) std::swap(t[1], t[2]);
    tets[p] = t;
  }
  return tets;
}
constexpr std::array<std::array<int, 4>, 6> kKuhnTetrahedra = makeKuhnTetrahedra();
static_assert(orientation(kKuhnTetrahedra[0]) == 1 && orientation(kKuhnTetrahedra[1]) == 1 &&
                  orientation(kKuhnTetrahedra[2]) == 1 && orientation(kKuhnTetrahedra[3]) == 1 &&
                  orientation(kKuhnTetrahedra[4]) == 1 && orientation(kKuhnTetrahedra[5]) == 1,
              "Kuhn tetrahedra must be positively oriented");

// Even permutations of (0, 1, 2, 3) starting with each index: with a positively
// oriented tetrahedron (a, b, c, d), the face (b, c, d) has its normal pointing away from a.
constexpr int kEvenFrom[4][4] = {{0, 1, 2, 3}, {1, 0, 3, 2}, {2, 0, 1, 3}, {3, 0, 2, 1}};

// True when the sequence (a, b, c, d) of 0..3 is an even permutation.
constexpr bool isEven(int a, int b, int c, int d) {
  const int s[4] = {a, b, c, d};
  int inversions = 0;
  for (int i = 0; i < 4; ++i) {
    for (int j = i + 1; j < 4; ++j) inversions += s[i] > s[j] ? 1 : 0;
  }
  return inversions % 2 == 0;
}
static_assert(isEven(0, 1, 2, 3) && isEven(1, 0, 3, 2) && isEven(2, 0, 1, 3) && isEven(3, 0, 2, 1),
              "kEvenFrom rows must be even permutations");

// Offset (in cells) of a cube corner or of an edge direction given as bits.
Vec<3> bitsVector(int bits) { return Vec<3>(double(bits & 1), double((bits >> 1) & 1), double((bits >> 2) & 1)); }

/// A triangle as the keys of the three grid edges its vertices lie on.
using EdgeTriangle = std::array<std::int64_t, 3>;

// Marching tetrahedra over one z-layer of cubes (cube k spans nodes k..k+1 in
// z); appends triangles to `out`, each vertex keyed 7 * (lower node) + (edge
// direction bits - 1): the 7 edge directions of the Kuhn triangulation.
void marchLayer(const Grid<3>& grid, int k, std::vector<EdgeTriangle>& out) {
  const int nx = grid.dims()[0], ny = grid.dims()[1];
  const std::size_t sy = std::size_t(nx), sz = std::size_t(nx) * std::size_t(ny);
  const std::vector<float>& phi = grid.values();
  for (int j = 0; j + 1 < ny; ++j) {
    for (int i = 0; i + 1 < nx; ++i) {
      // Corner nodes and values of the cube; skip cubes the surface misses.
      const std::size_t n0 = std::size_t(i) + sy * std::size_t(j) + sz * std::size_t(k);
      std::array<std::size_t, 8> node;
      std::array<double, 8> v;
      int insideMask = 0;
      for (int c = 0; c < 8; ++c) {
        node[std::size_t(c)] = n0 + std::size_t(c & 1) + sy * std::size_t((c >> 1) & 1) + sz * std::size_t((c >> 2) & 1);
        v[std::size_t(c)] = phi[node[std::size_t(c)]];
        if (v[std::size_t(c)] < 0.0) insideMask |= 1 << c;
      }
      if (insideMask == 0 || insideMask == 0xff) continue;

      // Key and position (cells, relative to the cube) of the vertex on the
      // edge between cube corners a and b; in a Kuhn tetrahedron one corner's
      // bits contain the other's, so the smaller is the edge's lower node.
      auto key = [&](int a, int b) {
        const int lo = std::min(a, b), hi = std::max(a, b);
        return std::int64_t(7) * std::int64_t(node[std::size_t(lo)]) + std::int64_t((hi ^ lo) - 1);
      };
      auto point = [&](int a, int b) {
        const int lo = std::min(a, b), hi = std::max(a, b);
        const double t = crossingFraction(v[std::size_t(lo)], v[std::size_t(hi)]);
        return Vec<3>(bitsVector(lo) + t * bitsVector(hi ^ lo));
      };

      // Each tetrahedron: one triangle (one corner differs) or a quad (two and two).
      for (const std::array<int, 4>& tet : kKuhnTetrahedra) {
        int in[4];
        int count = 0;
        for (int q = 0; q < 4; ++q) {
          in[q] = (insideMask >> tet[std::size_t(q)]) & 1;
          count += in[q];
        }
        if (count == 0 || count == 4) continue;
        auto corner = [&](int q) { return tet[std::size_t(q)]; };
        if (count == 1 || count == 3) {
          // The lone corner s and the others in an even order: the triangle's
          // normal points away from s, which is right when s is inside.
          int s = 0;
          while (in[s] != (count == 1 ? 1 : 0)) ++s;
          const int* p = kEvenFrom[s];
          const std::int64_t k1 = key(corner(s), corner(p[1]));
          const std::int64_t k2 = key(corner(s), corner(p[2]));
          const std::int64_t k3 = key(corner(s), corner(p[3]));
          if (count == 1) {
            out.push_back({k1, k2, k3});
          } else {
            out.push_back({k1, k3, k2});
          }
        } else {
          // Inside corners i1, i2 and outside o1, o2 in an even order; the quad
          // (i1o1, i1o2, i2o2, i2o1) then faces from inside to outside.
          int ins[2], outs[2], ni = 0, no = 0;
          for (int q = 0; q < 4; ++q) {
            if (in[q]) {
              ins[ni++] = q;
            } else {
              outs[no++] = q;
            }
          }
          if (!isEven(ins[0], ins[1], outs[0], outs[1])) std::swap(outs[0], outs[1]);
          const int i1 = corner(ins[0]), i2 = corner(ins[1]), o1 = corner(outs[0]), o2 = corner(outs[1]);
          const std::array<std::int64_t, 4> quad = {key(i1, o1), key(i1, o2), key(i2, o2), key(i2, o1)};
          // Split along the shorter diagonal for better-shaped triangles.
          const double d02 = (point(i1, o1) - point(i2, o2)).squaredNorm();
          const double d13 = (point(i1, o2) - point(i2, o1)).squaredNorm();
          if (d02 <= d13) {
            out.push_back({quad[0], quad[1], quad[2]});
            out.push_back({quad[0], quad[2], quad[3]});
          } else {
            out.push_back({quad[0], quad[1], quad[3]});
            out.push_back({quad[1], quad[2], quad[3]});
          }
        }
      }
    }
  }
}

// World position of the vertex on the grid edge with key `key` (see marchLayer).
Vec<3> edgeVertex(const Grid<3>& grid, std::int64_t key) {
  const std::size_t lower = std::size_t(key / 7);
  const int bits = int(key % 7) + 1;
  const Index<3> i = grid.unlinear(lower);
  const Index<3> j = i + Index<3>(bits & 1, (bits >> 1) & 1, (bits >> 2) & 1);
  const double t = crossingFraction(grid[lower], grid.at(j));
  return grid.nodePosition(i) + (t * grid.spacing()) * bitsVector(bits);
}

}  // namespace

std::vector<std::vector<Vec<2>>> marchingSquares(const Grid<2>& input) {
  std::vector<std::vector<Vec<2>>> loops;
  if (input.empty()) return loops;

  // Close contours that would leave the grid with a ring of outside nodes.
  std::optional<Grid<2>> ringed;
  if (interiorReachesBorder(input)) ringed = withOutsideRing(input);
  const Grid<2>& grid = ringed ? *ringed : input;
  const int nx = grid.dims()[0], ny = grid.dims()[1];
  const std::size_t sy = std::size_t(nx);
  const double h = grid.spacing();

  // Vertices keyed by grid edge: 2 * (lower node) + axis; `next` links each
  // vertex to the following one along its contour.
  std::unordered_map<std::int64_t, int> vertexOfEdge;
  std::vector<Vec<2>> points;
  std::vector<int> next;
  auto vertex = [&](std::int64_t key) {
    const auto [it, isNew] = vertexOfEdge.try_emplace(key, int(points.size()));
    if (isNew) {
      const std::size_t a = std::size_t(key / 2);
      const int axis = int(key % 2);
      const std::size_t b = a + (axis == 0 ? 1 : sy);
      const double t = crossingFraction(grid[a], grid[b]);
      Vec<2> p = grid.nodePosition(grid.unlinear(a));
      p[axis] += t * h;
      points.push_back(p);
      next.push_back(-1);
    }
    return it->second;
  };

  // Cells in row-major order; corners c0..c3 counter-clockwise from (i, j),
  // edge e_k runs from corner k to corner k+1.
  for (int j = 0; j + 1 < ny; ++j) {
    for (int i = 0; i + 1 < nx; ++i) {
      const std::size_t n0 = std::size_t(i) + sy * std::size_t(j);
      const std::array<std::size_t, 4> c = {n0, n0 + 1, n0 + 1 + sy, n0 + sy};
      std::array<bool, 4> in;
      int insideCount = 0;
      for (std::size_t q = 0; q < 4; ++q) {
        in[q] = grid[c[q]] < 0.0f;
        insideCount += in[q] ? 1 : 0;
      }
      if (insideCount == 0 || insideCount == 4) continue;
      const std::array<std::int64_t, 4> edgeKey = {std::int64_t(2 * n0), std::int64_t(2 * (n0 + 1) + 1),
                                                   std::int64_t(2 * (n0 + sy)), std::int64_t(2 * n0 + 1)};
      // Walking the cell counter-clockwise, a segment starts where the walk
      // leaves the inside and ends where it re-enters: then the inside is on its
      // left. With four crossings (saddle), an inside centre joins the inside
      // corners, so a segment ends at the next crossing; otherwise at the previous.
      int crossings = 0;
      for (std::size_t q = 0; q < 4; ++q) crossings += in[q] != in[(q + 1) % 4] ? 1 : 0;
      const double centreSum = double(grid[c[0]]) + double(grid[c[1]]) + double(grid[c[2]]) + double(grid[c[3]]);
      for (std::size_t q = 0; q < 4; ++q) {
        if (!(in[q] && !in[(q + 1) % 4])) continue;
        std::size_t end = 0;
        if (crossings == 2) {
          end = 0;
          while (!(!in[end] && in[(end + 1) % 4])) ++end;
        } else {
          end = centreSum < 0.0 ? (q + 1) % 4 : (q + 3) % 4;
        }
        const int from = vertex(edgeKey[q]);
        const int to = vertex(edgeKey[end]);
        next[std::size_t(from)] = to;
      }
    }
  }

  // Follow `next` from each unvisited vertex, in order of creation.
  std::vector<char> visited(points.size(), 0);
  for (std::size_t start = 0; start < points.size(); ++start) {
    if (visited[start]) continue;
    std::vector<Vec<2>> loop;
    for (int v = int(start); !visited[std::size_t(v)]; v = next[std::size_t(v)]) {
      visited[std::size_t(v)] = 1;
      loop.push_back(points[std::size_t(v)]);
    }
    loops.push_back(std::move(loop));
  }
  return loops;
}

TriangleMesh marchingCubes(const Grid<3>& input) {
  TriangleMesh mesh;
  if (input.empty()) return mesh;

  // Close surfaces that would leave the grid with a ring of outside nodes.
  std::optional<Grid<3>> ringed;
  if (interiorReachesBorder(input)) ringed = withOutsideRing(input);
  const Grid<3>& grid = ringed ? *ringed : input;
  const int layers = grid.dims()[2] - 1;

  // Triangles per z-layer of cubes, in parallel (each layer is independent).
  std::vector<std::vector<EdgeTriangle>> perLayer(static_cast<std::size_t>(layers));
#pragma omp parallel for schedule(dynamic, 1)
  for (int k = 0; k < layers; ++k) marchLayer(grid, k, perLayer[std::size_t(k)]);

  // Number the vertices in order of first use, layer by layer, so the output
  // does not depend on the thread count.
  std::size_t triangles = 0;
  for (const auto& layer : perLayer) triangles += layer.size();
  std::unordered_map<std::int64_t, int> vertexOfEdge;
  vertexOfEdge.reserve(triangles);
  mesh.faces.reserve(triangles);
  mesh.vertices.reserve(triangles / 2 + 8);
  for (const auto& layer : perLayer) {
    for (const EdgeTriangle& tri : layer) {
      std::array<int, 3> face;
      for (std::size_t q = 0; q < 3; ++q) {
        const auto [it, isNew] = vertexOfEdge.try_emplace(tri[q], int(mesh.vertices.size()));
        if (isNew) mesh.vertices.push_back(edgeVertex(grid, tri[q]));
        face[q] = it->second;
      }
      mesh.faces.push_back(face);
    }
  }
  return mesh;
}

template <int D>
double enclosedVolume(const Grid<D>& grid) {
  if constexpr (D == 2) {
    double area = 0.0;
    for (const std::vector<Vec<2>>& loop : marchingSquares(grid)) {
      for (std::size_t q = 0; q < loop.size(); ++q) {
        const Vec<2>& a = loop[q];
        const Vec<2>& b = loop[(q + 1) % loop.size()];
        area += 0.5 * (a[0] * b[1] - a[1] * b[0]);
      }
    }
    return std::abs(area);
  } else {
    return std::abs(marchingCubes(grid).signedVolume());
  }
}

template double enclosedVolume<2>(const Grid<2>&);
template double enclosedVolume<3>(const Grid<3>&);

}  // namespace lsdem::geometry
