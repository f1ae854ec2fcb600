#include "support/Sampling.h"
#include "lsdem/geometry/Contours.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Polygon_mesh_processing/shape_predicates.h>
#include <CGAL/Surface_mesh.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <numbers>
#include <random>
#include <set>
#include <utility>

#ifdef LSDEM_HAVE_OPENMP
#include <omp.h>
#endif

using namespace lsdem::geometry;
using lsdem::test::sampled;
using lsdem::test::boxAround;

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using SurfaceMesh = CGAL::Surface_mesh<Kernel::Point_3>;
namespace PMP = CGAL::Polygon_mesh_processing;
constexpr double kPi = std::numbers::pi;


Box<2> square(double r, const Vec<2>& c = Vec<2>::Zero()) { return {c - Vec<2>::Constant(r), c + Vec<2>::Constant(r)}; }
Box<3> cube(double r, const Vec<3>& c = Vec<3>::Zero()) { return {c - Vec<3>::Constant(r), c + Vec<3>::Constant(r)}; }

// Perimeter and signed (shoelace) area of a closed polyline.
double perimeter(const std::vector<Vec<2>>& loop) {
  double s = 0;
  for (std::size_t q = 0; q < loop.size(); ++q) s += (loop[(q + 1) % loop.size()] - loop[q]).norm();
  return s;
}
double signedArea(const std::vector<Vec<2>>& loop) {
  double s = 0;
  for (std::size_t q = 0; q < loop.size(); ++q) {
    const Vec<2>& a = loop[q];
    const Vec<2>& b = loop[(q + 1) % loop.size()];
    s += a[0] * b[1] - a[1] * b[0];
  }
  return 0.5 * s;
}

// Ramanujan's second approximation of an ellipse's perimeter (relative error ~h^5).
double ellipsePerimeter(double a, double b) {
  const double h = (a - b) * (a - b) / ((a + b) * (a + b));
  return kPi * (a + b) * (1 + 3 * h / (10 + std::sqrt(4 - 3 * h)));
}

SurfaceMesh toCgal(const TriangleMesh& mesh) {
  SurfaceMesh out;
  for (const Vec<3>& v : mesh.vertices) out.add_vertex(Kernel::Point_3(v[0], v[1], v[2]));
  for (const auto& f : mesh.faces) {
    const auto added = out.add_face(SurfaceMesh::Vertex_index(f[0]), SurfaceMesh::Vertex_index(f[1]),
                                    SurfaceMesh::Vertex_index(f[2]));
    EXPECT_NE(added, SurfaceMesh::null_face()) << "non-manifold face";
  }
  return out;
}

// Euler characteristic V - E + F from the face list (edges counted once).
int eulerCharacteristic(const TriangleMesh& mesh) {
  std::set<std::pair<int, int>> edges;
  for (const auto& f : mesh.faces) {
    for (int q = 0; q < 3; ++q) edges.insert(std::minmax(f[std::size_t(q)], f[std::size_t((q + 1) % 3)]));
  }
  return int(mesh.vertices.size()) - int(edges.size()) + int(mesh.faces.size());
}

// Every check a watertight, manifold, outward mesh must pass.
void expectWatertight(const TriangleMesh& mesh, int expectedChi) {
  ASSERT_FALSE(mesh.empty());
  SurfaceMesh sm = toCgal(mesh);
  EXPECT_EQ(sm.number_of_faces(), mesh.faces.size());
  EXPECT_TRUE(CGAL::is_closed(sm));
  EXPECT_TRUE(PMP::is_outward_oriented(sm));
  EXPECT_FALSE(PMP::does_self_intersect(sm));
  int degenerate = 0;
  for (auto f : sm.faces()) degenerate += PMP::is_degenerate_triangle_face(f, sm) ? 1 : 0;
  EXPECT_EQ(degenerate, 0);
  EXPECT_EQ(int(sm.number_of_vertices()) - int(sm.number_of_edges()) + int(sm.number_of_faces()), expectedChi);
  EXPECT_EQ(eulerCharacteristic(mesh), expectedChi);
}

}  // namespace

// ---- marching squares ---------------------------------------------------------

// Circle: perimeter and area converge to 2 pi R and pi R^2 at second order.
TEST(MarchingSquares, CircleLengthAndAreaConvergeAtSecondOrder) {
  const double R = 1.0;
  const Vec<2> c(0.013, -0.021);  // off the grid's symmetry
  double previousLength = 0, previousArea = 0;
  for (int level = 0; level < 3; ++level) {
    const double h = R / (10.0 * std::pow(2.0, level));
    const auto loops = marchingSquares(sampled<2>(square(R, c), h, [&](const Vec<2>& x) { return (x - c).norm() - R; }));
    ASSERT_EQ(loops.size(), 1u);
    const double lengthError = std::abs(perimeter(loops[0]) - 2 * kPi * R) / (2 * kPi * R);
    const double areaError = std::abs(signedArea(loops[0]) - kPi * R * R) / (kPi * R * R);
    std::cout << "circle h=R/" << R / h << ": length error " << lengthError << ", area error " << areaError << "\n";
    EXPECT_LT(lengthError, 0.01 / std::pow(4.0, level));
    EXPECT_LT(areaError, 0.01 / std::pow(4.0, level));
    EXPECT_GT(signedArea(loops[0]), 0.0);  // counter-clockwise around a solid
    if (level > 0) {
      const double lengthOrder = std::log2(previousLength / lengthError);
      const double areaOrder = std::log2(previousArea / areaError);
      std::cout << "  orders: length " << lengthOrder << ", area " << areaOrder << "\n";
      EXPECT_GT(lengthOrder, 1.7);
      EXPECT_GT(areaOrder, 1.7);
    }
    previousLength = lengthError;
    previousArea = areaError;
  }
}

// Ellipse (zero set of a non-distance function): length and area within
// second-order error of Ramanujan's perimeter and pi a b.
TEST(MarchingSquares, EllipseLengthAndArea) {
  const double a = 1.0, b = 0.45, h = 0.02;
  const auto loops = marchingSquares(sampled<2>(Box<2>{Vec<2>(-a, -b), Vec<2>(a, b)}, h, [&](const Vec<2>& x) {
    return b * (std::hypot(x[0] / a, x[1] / b) - 1.0);
  }));
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_NEAR(perimeter(loops[0]) / ellipsePerimeter(a, b), 1.0, 1e-3);
  EXPECT_NEAR(signedArea(loops[0]) / (kPi * a * b), 1.0, 2e-3);
}

// Two disjoint circles give two counter-clockwise loops of the right areas.
TEST(MarchingSquares, TwoCirclesGiveTwoLoops) {
  const double R = 0.5, h = 0.025;
  const Vec<2> c1(-0.8, 0.0), c2(0.8, 0.1);
  const auto loops = marchingSquares(sampled<2>(Box<2>{Vec<2>(-1.3, -0.5), Vec<2>(1.3, 0.6)}, h, [&](const Vec<2>& x) {
    return std::min((x - c1).norm(), (x - c2).norm()) - R;
  }));
  ASSERT_EQ(loops.size(), 2u);
  for (const auto& loop : loops) {
    EXPECT_NEAR(signedArea(loop), kPi * R * R, 0.003 * kPi * R * R);
    EXPECT_NEAR(perimeter(loop), 2 * kPi * R, 0.003 * 2 * kPi * R);
  }
}

// An annulus: the outer loop runs counter-clockwise, the hole clockwise, and
// the signed areas add up to the annulus area.
TEST(MarchingSquares, AnnulusHasClockwiseHole) {
  const double R0 = 0.4, R1 = 1.0, h = 0.02;
  const auto loops = marchingSquares(sampled<2>(square(R1), h, [&](const Vec<2>& x) {
    return std::max(x.norm() - R1, R0 - x.norm());
  }));
  ASSERT_EQ(loops.size(), 2u);
  const double a0 = signedArea(loops[0]), a1 = signedArea(loops[1]);
  const double outer = std::max(a0, a1), inner = std::min(a0, a1);
  EXPECT_NEAR(outer, kPi * R1 * R1, 2e-3 * kPi * R1 * R1);
  EXPECT_NEAR(inner, -kPi * R0 * R0, 2e-3 * kPi * R0 * R0);
  EXPECT_NEAR(a0 + a1, kPi * (R1 * R1 - R0 * R0), 2e-3 * kPi * R1 * R1);
}

// The saddle cell (diagonal corners alike) is resolved by the centre average.
TEST(MarchingSquares, SaddleResolvedByCentreAverage) {
  for (const float off : {0.5f, 2.0f}) {
    Grid<2> g(Index<2>(4, 4), Vec<2>::Zero(), 1.0, 1.0f);
    g.at(Index<2>(1, 1)) = -1.0f;
    g.at(Index<2>(2, 2)) = -1.0f;
    g.at(Index<2>(2, 1)) = off;
    g.at(Index<2>(1, 2)) = off;
    const auto loops = marchingSquares(g);
    // Centre average (-2 + 2 off) / 4: inside for off = 0.5 (one joined loop), outside for 2 (two loops).
    EXPECT_EQ(loops.size(), off < 1.0f ? 1u : 2u) << "off " << off;
    for (const auto& loop : loops) EXPECT_GT(signedArea(loop), 0.0);
  }
}

// Nodes exactly on phi = 0 count as outside: with a square whose sides pass
// through nodes, every vertex sits 1e-3 cells inside the sides (the clamp), no
// segment has zero length.
TEST(MarchingSquares, ZeroNodesAreOutsideAndClamped) {
  const double h = 0.25;
  Grid<2> g(Index<2>(13, 13), Vec<2>::Constant(-1.5), h);
  for (std::size_t n = 0; n < g.size(); ++n) g[n] = float(g.nodePosition(g.unlinear(n)).cwiseAbs().maxCoeff() - 1.0);
  const auto loops = marchingSquares(g);
  ASSERT_EQ(loops.size(), 1u);
  for (const Vec<2>& x : loops[0]) {
    EXPECT_NEAR(x.cwiseAbs().maxCoeff(), 1.0 - 1e-3 * h, 1e-9);
  }
  for (std::size_t q = 0; q < loops[0].size(); ++q) {
    EXPECT_GT((loops[0][(q + 1) % loops[0].size()] - loops[0][q]).norm(), 0.5e-3 * h);
  }
}

// Vertices are shared between cells: no loop repeats a point and consecutive
// points are at most a cell diagonal apart.
TEST(MarchingSquares, LoopsAreSimpleAndConnected) {
  const double h = 0.05;
  const auto loops = marchingSquares(sampled<2>(square(1.0), h, [](const Vec<2>& x) {
    return x.norm() - 0.7 - 0.2 * std::sin(5 * std::atan2(x[1], x[0]));
  }));
  ASSERT_EQ(loops.size(), 1u);
  const auto& loop = loops[0];
  std::set<std::pair<double, double>> seen;
  for (std::size_t q = 0; q < loop.size(); ++q) {
    EXPECT_TRUE(seen.insert({loop[q][0], loop[q][1]}).second);
    EXPECT_LE((loop[(q + 1) % loop.size()] - loop[q]).norm(), h * std::sqrt(2.0) + 1e-12);
  }
}

// A shape reaching the grid's border is closed beyond the border; no inside
// nodes gives no loops.
TEST(MarchingSquares, BorderAndEmpty) {
  Grid<2> g(Index<2>(5, 4), Vec<2>::Zero(), 0.5, -1.0f);
  auto loops = marchingSquares(g);
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_GT(signedArea(loops[0]), 2.0 * 1.5);  // encloses every node
  g.values().assign(g.size(), 0.0f);              // phi == 0 everywhere: all outside
  EXPECT_TRUE(marchingSquares(g).empty());
}

// ---- marching cubes (Kuhn tetrahedra) ------------------------------------------

// Sphere 20 cells across: watertight, outward, no self-intersection, chi = 2,
// area and volume within 1%.
TEST(MarchingCubes, SphereIsWatertightAndAccurate) {
  const double R = 1.0, h = 0.1;
  const Vec<3> c(0.011, -0.023, 0.031);
  const TriangleMesh mesh = marchingCubes(sampled<3>(cube(R, c), h, [&](const Vec<3>& x) { return (x - c).norm() - R; }));
  expectWatertight(mesh, 2);
  const double areaError = mesh.area() / (4 * kPi * R * R) - 1;
  const double volumeError = mesh.signedVolume() / (4.0 / 3.0 * kPi * R * R * R) - 1;
  std::cout << "sphere 20 cells across: " << mesh.vertices.size() << " vertices, " << mesh.faces.size()
            << " faces, area error " << areaError << ", volume error " << volumeError << "\n";
  EXPECT_LT(std::abs(areaError), 0.01);
  EXPECT_LT(std::abs(volumeError), 0.01);
  // Every vertex lies close to the sphere (second-order interpolation error).
  for (const Vec<3>& v : mesh.vertices) EXPECT_LT(std::abs((v - c).norm() - R), 0.05 * h);
}

// Torus: genus 1, chi = 0; volume 2 pi^2 R r^2.
TEST(MarchingCubes, TorusHasGenusOne) {
  const double R = 0.7, r = 0.3, h = 0.05;
  const TriangleMesh mesh = marchingCubes(sampled<3>(Box<3>{Vec<3>(-1, -1, -0.3), Vec<3>(1, 1, 0.3)}, h, [&](const Vec<3>& x) {
    return std::hypot(std::hypot(x[0], x[1]) - R, x[2]) - r;
  }));
  expectWatertight(mesh, 0);
  EXPECT_NEAR(mesh.signedVolume() / (2 * kPi * kPi * R * r * r), 1.0, 0.01);
  EXPECT_NEAR(mesh.area() / (4 * kPi * kPi * R * r), 1.0, 0.01);
}

// Two separate spheres: chi = 4 (two components of genus 0).
TEST(MarchingCubes, TwoSpheres) {
  const Vec<3> c1(-0.6, 0, 0), c2(0.6, 0.05, 0);
  const TriangleMesh mesh = marchingCubes(sampled<3>(Box<3>{Vec<3>(-1.1, -0.5, -0.5), Vec<3>(1.1, 0.55, 0.5)}, 0.1,
                                                    [&](const Vec<3>& x) {
                                                      return std::min((x - c1).norm(), (x - c2).norm()) - 0.45;
                                                    }));
  expectWatertight(mesh, 4);
}

// A box whose faces pass exactly through nodes (phi == 0 there, counted
// outside): still watertight, no degenerate faces, and every vertex sits 1e-3
// cells (the clamp) inside the faces. Values come from integer node indices so
// that the zeros are exact.
TEST(MarchingCubes, ZeroNodesGiveNoDegenerateFaces) {
  const double h = 0.1;
  const Index<3> centre(8, 7, 6), halfCells(5, 4, 3);
  Grid<3> g(Index<3>(17, 15, 13), -h * centre.cast<double>().matrix(), h);
  for (std::size_t n = 0; n < g.size(); ++n) {
    g[n] = float(h * double(((g.unlinear(n) - centre).abs() - halfCells).maxCoeff()));
  }
  const TriangleMesh mesh = marchingCubes(g);
  expectWatertight(mesh, 2);
  const Vec<3> half = h * halfCells.cast<double>().matrix();
  for (const Vec<3>& v : mesh.vertices) EXPECT_NEAR((v.cwiseAbs() - half).maxCoeff(), -1e-3 * h, 1e-9);
  // Volume between the box shrunk by a cell and the full box.
  EXPECT_GT(mesh.signedVolume(), 8 * (half - Vec<3>::Constant(h)).prod());
  EXPECT_LT(mesh.signedVolume(), 8 * half.prod());
}

// Random values: every sign pattern, ambiguous faces everywhere, inside nodes
// on the border. The mesh must still be closed, manifold, consistently oriented
// and free of self-intersections; and its volume equals the sum over the Kuhn
// tetrahedra of the linear interpolant's inside volume.
TEST(MarchingCubes, RandomFieldIsWatertight) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Grid<3> g(Index<3>(9, 8, 7), Vec<3>(0.1, 0.2, 0.3), 0.5);
  for (std::size_t n = 0; n < g.size(); ++n) g[n] = float(u(rng));
  const TriangleMesh mesh = marchingCubes(g);
  ASSERT_FALSE(mesh.empty());
  SurfaceMesh sm = toCgal(mesh);
  EXPECT_TRUE(CGAL::is_closed(sm));
  EXPECT_FALSE(PMP::does_self_intersect(sm));
  EXPECT_GT(mesh.signedVolume(), 0.0);
  // Each component's edges are used once in each direction: consistent orientation.
  std::set<std::pair<int, int>> directed;
  for (const auto& f : mesh.faces) {
    for (int q = 0; q < 3; ++q) EXPECT_TRUE(directed.insert({f[std::size_t(q)], f[std::size_t((q + 1) % 3)]}).second);
  }
  for (const auto& e : directed) EXPECT_TRUE(directed.count({e.second, e.first}));
}

// No inside node: empty mesh; phi == 0 everywhere is outside too.
TEST(MarchingCubes, NoInteriorGivesEmptyMesh) {
  Grid<3> g(Index<3>(6, 6, 6), Vec<3>::Zero(), 0.1, 0.5f);
  EXPECT_TRUE(marchingCubes(g).empty());
  g.values().assign(g.size(), 0.0f);
  EXPECT_TRUE(marchingCubes(g).empty());
}

// Solid up to the border is closed by the virtual outside ring.
TEST(MarchingCubes, InteriorAtBorderIsClosed) {
  Grid<3> g(Index<3>(5, 6, 7), Vec<3>::Zero(), 0.2, -0.05f);
  const TriangleMesh mesh = marchingCubes(g);
  expectWatertight(mesh, 2);
  EXPECT_GT(mesh.signedVolume(), 0.8 * 1.0 * 1.2);  // encloses every node
}

// Same mesh for 1 and 2 threads; time for a 64^3 sphere.
TEST(MarchingCubes, DeterministicAndTimed) {
  const double R = 1.0, h = 2 * R / 56;  // 56 cells across + 4 padding each side = 65 nodes
  const Grid<3> g = sampled<3>(cube(R), h, [&](const Vec<3>& x) { return x.norm() - R; });
  std::cout << "grid " << g.dims().transpose() << "\n";
#ifdef LSDEM_HAVE_OPENMP
  omp_set_num_threads(1);
  const TriangleMesh one = marchingCubes(g);
  omp_set_num_threads(2);
#else
  const TriangleMesh one = marchingCubes(g);
#endif
  const auto start = std::chrono::steady_clock::now();
  const TriangleMesh two = marchingCubes(g);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cout << "64^3 sphere: " << two.faces.size() << " faces in " << seconds * 1e3 << " ms\n";
  ASSERT_EQ(one.faces, two.faces);
  ASSERT_EQ(one.vertices.size(), two.vertices.size());
  for (std::size_t v = 0; v < one.vertices.size(); ++v) ASSERT_EQ(one.vertices[v], two.vertices[v]);
  EXPECT_NEAR(two.signedVolume() / (4.0 / 3.0 * kPi), 1.0, 2e-3);
}
