#include "lsdem/geometry/MeshToLevelSet.h"

#include "support/Meshes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <limits>
#include <map>
#include <numbers>
#include <utility>

#ifdef LSDEM_HAVE_OPENMP
#include <omp.h>
#endif

using namespace lsdem::geometry;
using lsdem::test::boxMesh;
using lsdem::test::icosphere;
using lsdem::test::orientOutward;

namespace {

// Exact signed distance to a box.
double boxSdf(const Vec<3>& x, const Vec<3>& centre, const Vec<3>& half) {
  const Vec<3> q = (x - centre).cwiseAbs() - half;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

// Appends `other` to `mesh` (vertices renumbered).
void append(TriangleMesh& mesh, const TriangleMesh& other) {
  const int offset = int(mesh.vertices.size());
  mesh.vertices.insert(mesh.vertices.end(), other.vertices.begin(), other.vertices.end());
  for (auto f : other.faces) mesh.faces.push_back({f[0] + offset, f[1] + offset, f[2] + offset});
}

// The message meshToLevelSet throws for `mesh` named `name` ("" when it does not throw MeshError).
std::string errorOf(const TriangleMesh& mesh, const std::string& name) {
  try {
    meshToLevelSet(mesh, 0.1, 2, name);
  } catch (const MeshError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

// A cube of 12 triangles gives the exact box distance at every node.
TEST(MeshToLevelSet, CubeMatchesExactBoxDistance) {
  const Vec<3> centre(0.3, -0.2, 0.1), half(0.5, 0.4, 0.3);
  const TriangleMesh cube = boxMesh(centre, half);
  ASSERT_TRUE(inspectMesh(cube).ok()) << inspectMesh(cube).describe();
  EXPECT_EQ(inspectMesh(cube).describe(), "is ok");
  EXPECT_NEAR(cube.signedVolume(), 8 * half.prod(), 1e-12);
  const Grid<3> g = meshToLevelSet(cube, 0.05, 4, "cube");
  // Covers the bounds plus 4 cells.
  EXPECT_LE(g.bounds().lower[0], centre[0] - half[0] - 4 * 0.05 + 1e-12);
  EXPECT_GE(g.bounds().upper[2], centre[2] + half[2] + 4 * 0.05 - 1e-12);
  double worst = 0;
  int inside = 0;
  for (std::size_t n = 0; n < g.size(); ++n) {
    const double exact = boxSdf(g.nodePosition(g.unlinear(n)), centre, half);
    worst = std::max(worst, std::abs(double(g[n]) - exact));
    inside += g[n] < 0 ? 1 : 0;
  }
  std::cout << "cube: " << g.size() << " nodes, " << inside << " inside, max |phi - exact| " << worst << "\n";
  EXPECT_LT(worst, 1e-6);
  EXPECT_GT(inside, 1000);
}

// A subdivided icosahedron: within its chord error of the sphere's distance.
TEST(MeshToLevelSet, IcosphereIsCloseToSphereDistance) {
  const double R = 0.8;
  const TriangleMesh mesh = icosphere(R, 3);
  ASSERT_EQ(mesh.faces.size(), 1280u);
  // Chord error: how far the flat faces sink below the sphere (largest at face centroids).
  double sag = 0;
  for (const auto& f : mesh.faces) {
    const Vec<3> centroid = (mesh.vertices[std::size_t(f[0])] + mesh.vertices[std::size_t(f[1])] +
                             mesh.vertices[std::size_t(f[2])]) / 3.0;
    sag = std::max(sag, R - centroid.norm());
  }
  const auto start = std::chrono::steady_clock::now();
  const Grid<3> g = meshToLevelSet(mesh, 0.04, 4, "icosphere");
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  double worst = 0;
  for (std::size_t n = 0; n < g.size(); ++n) {
    worst = std::max(worst, std::abs(double(g[n]) - (g.nodePosition(g.unlinear(n)).norm() - R)));
  }
  std::cout << "icosphere (1280 faces) on " << g.dims().transpose() << " nodes in " << seconds * 1e3
            << " ms: max |phi - sphere| " << worst << " (chord error " << sag << ")\n";
  EXPECT_LE(worst, sag + 1e-6);
  EXPECT_GT(worst, 0.5 * sag);  // the facets are really seen
}

// A hollow box (outer shell outward, cavity shell inward) is valid: negative
// only in the wall; with the cavity facing outward it is inverted.
TEST(MeshToLevelSet, HollowBoxAndNesting) {
  TriangleMesh hollow = boxMesh(Vec<3>::Zero(), Vec<3>(0.5, 0.5, 0.5));
  TriangleMesh cavity = boxMesh(Vec<3>::Zero(), Vec<3>(0.3, 0.3, 0.3));
  TriangleMesh wrongCavity = cavity;
  for (auto& f : cavity.faces) std::swap(f[1], f[2]);
  TriangleMesh bad = hollow;
  append(hollow, cavity);
  append(bad, wrongCavity);
  const Grid<3> g = meshToLevelSet(hollow, 0.05, 2, "hollow");
  EXPECT_NEAR(g.value(Vec<3>(0, 0, 0)), 0.3, 1e-6);    // cavity centre: outside
  EXPECT_NEAR(g.value(Vec<3>(0.4, 0, 0)), -0.1, 1e-6);  // in the wall
  EXPECT_NEAR(g.value(Vec<3>(0.7, 0, 0)), 0.2, 1e-6);   // outside
  EXPECT_EQ(errorOf(bad, "bad"), "mesh 'bad': is inverted (normals point inward)");
}

// Every kind of broken mesh raises MeshError naming the mesh and the problem.
TEST(MeshToLevelSet, BrokenMeshesRaiseTheRightMessage) {
  const TriangleMesh cube = boxMesh(Vec<3>::Zero(), Vec<3>(0.5, 0.5, 0.5));

  TriangleMesh open = cube;
  open.faces.pop_back();
  EXPECT_EQ(errorOf(open, "open"), "mesh 'open': is not closed (3 border edges)");
  EXPECT_EQ(inspectMesh(open).borderEdges, 3);

  TriangleMesh twoCubes = cube;
  append(twoCubes, boxMesh(Vec<3>(0.3, 0.2, 0.1), Vec<3>(0.5, 0.5, 0.5)));
  EXPECT_EQ(errorOf(twoCubes, "two"), "mesh 'two': self-intersects");

  // Two closed bodies apart in one file would become one grain: refused. A
  // body with a cavity (a shell nested in it, facing in) is one body.
  TriangleMesh apart = cube;
  append(apart, boxMesh(Vec<3>(3.0, 0.0, 0.0), Vec<3>(0.5, 0.5, 0.5)));
  EXPECT_EQ(inspectMesh(apart).bodies, 2);
  EXPECT_EQ(errorOf(apart, "apart"),
            "mesh 'apart': holds 2 separate bodies (a grain or tool is one body: put each in a file of its own)");
  TriangleMesh hollow = boxMesh(Vec<3>::Zero(), Vec<3>(1.0, 1.0, 1.0));
  TriangleMesh cavity = boxMesh(Vec<3>::Zero(), Vec<3>(0.4, 0.4, 0.4));
  for (auto& f : cavity.faces) std::swap(f[1], f[2]);
  append(hollow, cavity);
  EXPECT_EQ(inspectMesh(hollow).bodies, 1);
  EXPECT_TRUE(inspectMesh(hollow).ok()) << inspectMesh(hollow).describe();
  EXPECT_EQ(inspectMesh(cube).bodies, 1);

  // A zero-area face: split edge (a, b) of a face (a, b, c) at its midpoint m,
  // and close the slit with the flat face (a, b, m); still closed and manifold.
  TriangleMesh flat = cube;
  const auto face = flat.faces.back();
  flat.faces.pop_back();
  const int a = face[0], b = face[1], c = face[2];
  flat.vertices.push_back(0.5 * (flat.vertices[std::size_t(a)] + flat.vertices[std::size_t(b)]));
  const int m = int(flat.vertices.size()) - 1;
  flat.faces.push_back({a, m, c});
  flat.faces.push_back({m, b, c});
  flat.faces.push_back({a, b, m});
  EXPECT_EQ(inspectMesh(flat).borderEdges, 0);
  EXPECT_EQ(errorOf(flat, "flat"), "mesh 'flat': has 1 degenerate (zero-area) face (the first: face 13)");

  TriangleMesh flipped = cube;
  for (auto& f : flipped.faces) std::swap(f[1], f[2]);
  EXPECT_EQ(errorOf(flipped, "flipped"), "mesh 'flipped': is inverted (normals point inward)");
  EXPECT_LT(flipped.signedVolume(), 0.0);

  EXPECT_EQ(errorOf(TriangleMesh{}, "nothing"), "mesh 'nothing': is empty");

  // One face flipped: its three edges are traversed the same way by both faces.
  TriangleMesh oneFlipped = cube;
  std::swap(oneFlipped.faces[0][1], oneFlipped.faces[0][2]);
  EXPECT_EQ(errorOf(oneFlipped, "one"), "mesh 'one': is inconsistently oriented (3 edges traversed the same way by both faces)");

  // Two cubes sharing an edge: that edge has four faces.
  TriangleMesh edgeShared = cube;
  TriangleMesh neighbour = boxMesh(Vec<3>(1, 1, 0), Vec<3>(0.5, 0.5, 0.5));
  append(edgeShared, neighbour);
  // Weld the shared corners (1,1,0)+(-0.5,-0.5,+-0.5) == (0.5,0.5,+-0.5).
  for (auto& f : edgeShared.faces) {
    for (int& v : f) {
      for (int w = 0; w < 8; ++w) {
        if (v >= 8 && (edgeShared.vertices[std::size_t(v)] - edgeShared.vertices[std::size_t(w)]).norm() < 1e-12) v = w;
      }
    }
  }
  EXPECT_EQ(errorOf(edgeShared, "edge"), "mesh 'edge': is not manifold (1 edge shared by more than two faces)");

  // Two cubes touching at one corner: a non-manifold vertex.
  TriangleMesh cornerShared = cube;
  append(cornerShared, boxMesh(Vec<3>(1, 1, 1), Vec<3>(0.5, 0.5, 0.5)));
  for (auto& f : cornerShared.faces) {
    for (int& v : f) {
      if (v == 8) v = 7;  // corner (0.5, 0.5, 0.5) of both
    }
  }
  EXPECT_EQ(errorOf(cornerShared, "corner"), "mesh 'corner': is not manifold (1 vertex where separate sheets touch)");

  TriangleMesh badIndex = cube;
  badIndex.faces[3][1] = 42;
  EXPECT_EQ(errorOf(badIndex, "index"), "mesh 'index': has 1 face with vertex indices out of range");

  // Several problems at once are all listed.
  TriangleMesh openAndFlat = flat;
  openAndFlat.faces.erase(openAndFlat.faces.begin());
  EXPECT_EQ(errorOf(openAndFlat, "both"), "mesh 'both': is not closed (3 border edges); has 1 degenerate (zero-area) face (the first: face 12)");
}

TEST(MeshToLevelSet, RejectsBadSpacingAndPadding) {
  const TriangleMesh cube = boxMesh(Vec<3>::Zero(), Vec<3>(0.5, 0.5, 0.5));
  EXPECT_THROW(meshToLevelSet(cube, 0.0), std::invalid_argument);
  EXPECT_THROW(meshToLevelSet(cube, -0.1), std::invalid_argument);
  EXPECT_THROW(meshToLevelSet(cube, std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
  EXPECT_THROW(meshToLevelSet(cube, 0.1, -1), std::invalid_argument);
}

// The grid does not depend on the thread count.
TEST(MeshToLevelSet, DeterministicAcrossThreads) {
  const TriangleMesh mesh = icosphere(0.5, 2);
#ifdef LSDEM_HAVE_OPENMP
  omp_set_num_threads(1);
  const Grid<3> one = meshToLevelSet(mesh, 0.05);
  omp_set_num_threads(2);
#else
  const Grid<3> one = meshToLevelSet(mesh, 0.05);
#endif
  const Grid<3> two = meshToLevelSet(mesh, 0.05);
  EXPECT_EQ(one.values(), two.values());
}
