#include "lsdem/geometry/MeshIO.h"
#include "lsdem/geometry/MeshToLevelSet.h"
#include "lsdem/geometry/Primitives.h"
#include "lsdem/geometry/Shape.h"
#include "lsdem/geometry/ShapeDef.h"
#include "support/Files.h"
#include "support/Meshes.h"
#include "support/Shapes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <utility>

using namespace lsdem::geometry;

namespace {

constexpr double kPi = 3.14159265358979323846;

// An ellipsoid with semi-axes (0.6, 0.4, 0.3) rotated by R and centred at c, sampled at 20 cells across its smallest axis.
Grid<3> rotatedEllipsoid(const Mat<3>& R, const Vec<3>& c) {
  const Vec<3> semi(0.6, 0.4, 0.3);
  const Box<3> box{c - Vec<3>::Constant(0.6), c + Vec<3>::Constant(0.6)};
  return sampleGrid<3>(box, 0.03, kDefaultPaddingCells,
                       [&](const Vec<3>& x) { return sdfEllipsoid<3>(Vec<3>(R.transpose() * (x - c)), semi); });
}

}  // namespace

TEST(Shape, BodyFrameIsThePrincipalFrameOfARotatedEllipsoid) {
  const Mat<3> R = Eigen::AngleAxisd(0.7, Vec<3>(1, 2, 3).normalized()).toRotationMatrix();
  const Vec<3> c(0.11, -0.07, 0.05);
  const auto shape = Shape<3>::fromGrid(rotatedEllipsoid(R, c), ShapeOptions{1.0, MassMethod::Extrapolated});

  // Centroid and axes: the body x, y, z axes are the ellipsoid's long, middle, short axes.
  EXPECT_LT((shape->bodyToGrid().translation - c).norm(), 0.002);
  for (int a = 0; a < 3; ++a) {
    EXPECT_GT(std::abs(shape->bodyToGrid().rotation.col(a).dot(R.col(a))), 0.999) << "axis " << a;
  }
  EXPECT_NEAR(shape->bodyToGrid().rotation.determinant(), 1.0, 1e-12);

  // Principal moments per unit density: V (b^2 + c^2) / 5 and permutations, within 0.5 %.
  const double V = 4.0 / 3.0 * kPi * 0.6 * 0.4 * 0.3;
  const Vec<3> expected(V * (0.16 + 0.09) / 5, V * (0.36 + 0.09) / 5, V * (0.36 + 0.16) / 5);
  const Vec<3> inertia = shape->mass().principalInertia();
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(inertia[a], expected[a], 0.005 * expected[a]);
  EXPECT_NEAR(shape->volume(), V, 0.005 * V);
  EXPECT_LT(shape->mass().centroid.norm(), 1e-12);

  // Nodes sit on the surface, seen through the body frame.
  for (const Vec<3>& p : shape->nodes().positions) EXPECT_LT(std::abs(shape->value(p)), 0.05 * 0.03);
  // The bounding sphere holds the whole ellipsoid and is tight.
  EXPECT_GE(shape->boundingRadius(), 0.6 - 0.01);
  EXPECT_LT(shape->boundingRadius(), 0.6 + std::sqrt(3.0) * 0.03);  // the negative region's cells: up to a cell diagonal
}

TEST(Shape, BodyLookupsEqualGridLookups) {
  const Mat<3> R = Eigen::AngleAxisd(-0.4, Vec<3>(0, 1, 1).normalized()).toRotationMatrix();
  const auto shape = Shape<3>::fromGrid(rotatedEllipsoid(R, Vec<3>(0.02, 0.0, -0.03)));
  for (const Vec<3>& xBody : {Vec<3>(0.1, 0.2, 0.05), Vec<3>(0.55, 0.0, 0.0), Vec<3>(-0.2, 0.3, 0.25)}) {
    const Vec<3> xGrid = shape->bodyToGrid().apply(xBody);
    Vec<3> gBody, gGrid;
    EXPECT_DOUBLE_EQ(shape->valueAndGradient(xBody, gBody), shape->grid().valueAndGradient(xGrid, gGrid));
    EXPECT_LT((shape->bodyToGrid().rotation * gBody - gGrid).norm(), 1e-12);
  }
}

TEST(Shape, TwoDimensionalEllipse) {
  ShapeDef<2> def;
  def.kind = ShapeKind::Ellipsoid;
  def.semiAxes = Vec<2>(0.6, 0.3);
  def.cellsAcross = 20;
  def.options.nodesPerCell = 2.0;
  const auto shape = buildShape(def);
  EXPECT_NEAR(resolvedSpacing(def), 0.03, 1e-15);
  const double A = kPi * 0.18;
  EXPECT_NEAR(shape->volume(), A, 0.005 * A);
  EXPECT_NEAR(shape->mass().polarMoment(), A * (0.36 + 0.09) / 4, 0.005 * A * 0.45 / 4);
  // Body x is the long axis.
  EXPECT_GT(std::abs(shape->bodyToGrid().rotation(0, 0)), 0.999);
  EXPECT_NEAR(shape->descriptors().aspectRatio, 0.5, 0.01);
}

TEST(Shape, RefusesAnEmptyLevelSetAndBadDensity) {
  Grid<2> empty(Index<2>(10, 10), Vec<2>::Zero(), 0.1, 1.0f);
  EXPECT_THROW(Shape<2>::fromGrid(empty), std::invalid_argument);
  EXPECT_THROW(Shape<2>::fromGrid(sphereGrid<2>(1.0, 0.1), ShapeOptions{0.0, MassMethod::Paper}), std::invalid_argument);
}

TEST(ShapeDef, ResolutionMustBeGivenOnce) {
  ShapeDef<3> def;
  def.radius = 0.5;
  EXPECT_THROW(resolvedSpacing(def), std::invalid_argument);
  def.spacing = 0.05;
  def.cellsAcross = 20;
  EXPECT_THROW(resolvedSpacing(def), std::invalid_argument);
  def.spacing = 0.0;
  EXPECT_DOUBLE_EQ(resolvedSpacing(def), 0.05);
}

// Lengths are metres: a shape 1e-10 to 1e10 m across its smallest dimension
// builds; beyond, an error says so (a sphere of radius 1e40 crashed the node
// placement's exact geometry, 1e155 the grid).
TEST(ShapeDef, ShapesBeyondTheLengthRangeAreRefused) {
  const auto message = [](double radius) {
    ShapeDef<3> def;
    def.radius = radius;
    def.cellsAcross = 6;
    try {
      buildShape(def);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  for (const double radius : {1e40, 1e155, 1e10, 1e-11}) {
    EXPECT_NE(message(radius).find("m across its smallest dimension: lsdem takes shapes 1e-10 to 1e10 m across"),
              std::string::npos)
        << radius << ": " << message(radius);
  }
  EXPECT_EQ(message(1e4), "");
  EXPECT_EQ(message(1e-9), "");
  ShapeDef<3> box;
  box.kind = ShapeKind::Box;
  box.halfExtents = Vec<3>(1e100, 1e100, 1e100);
  box.cellsAcross = 6;
  EXPECT_THROW(buildShape(box), std::invalid_argument);
}

// The bounding sphere holds every point where the interpolated level set is
// negative, not only the nodes and interior grid nodes (the fragments of a
// split, with sharp edges where nodes are sparse, are checked in test_split).
TEST(Shape, BoundingSphereHoldsTheWholeInterpolatedGrain) {
  ShapeDef<3> box;
  box.kind = ShapeKind::Box;
  box.halfExtents = Vec<3>(0.3, 0.2, 0.1);
  box.cellsAcross = 6;
  EXPECT_LE(lsdem::test::boundingSphereExcess(*buildShape(box)), 0.0);
  ShapeDef<2> triangle;
  triangle.kind = ShapeKind::Polygon;
  triangle.vertices = {Vec<2>(0.0, 0.0), Vec<2>(1.0, 0.1), Vec<2>(0.2, 0.5)};
  triangle.cellsAcross = 6;
  EXPECT_LE(lsdem::test::boundingSphereExcess(*buildShape(triangle)), 0.0);
}

// ---- the tricubic look-up's margin and reach (Shape::cubicMargin, cubicBoundingRadius) ----

namespace {

// How loose CubicLookup::slope may be against the steepest sampled gradient.
constexpr double kSlopeBoundFactor = 4.0;

// Random points of a shape's grid box (grid coordinates), over every cell.
template <int D>
void checkCubicMarginAndReach(const Shape<D>& shape) {
  const Grid<D>& g = shape.grid();
  const double E = shape.cubicMargin();
  EXPECT_GE(E, 0.0);
  EXPECT_LT(E, 0.5 * g.spacing());  // small on a smooth grain: the rejection tests stay useful
  EXPECT_GE(shape.cubicBoundingRadius(), shape.boundingRadius());
  const typename Shape<D>::CubicLookup& lookup = shape.cubicLookup();
  ASSERT_EQ(lookup.cellSteps.size(), g.size());
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int negative = 0, clearedByCell = 0, clearedByNear = 0;
  double steepest = 0.0;  // the largest |grad| of the cubic sampled, world units per world unit
  for (int k = 0; k < 200000; ++k) {
    Vec<D> c;
    for (int a = 0; a < D; ++a) c[a] = u(rng) * double(g.dims()[a] - 1);
    const double cubic = g.cubicValueAtCells(c);
    // The gradient bound that certifies a node the cubic clears (CubicLookup::slope).
    Vec<D> gradCells;
    g.cubicValueAndGradientAtCells(c, gradCells);
    const double steep = gradCells.norm() / g.spacing();
    ASSERT_LE(steep, lookup.slope * (1.0 + 1e-12));
    steepest = std::max(steepest, steep);
    const double linear = g.valueAtCells(c);
    // Where the multilinear value exceeds E the cubic is positive ...
    if (linear > E) {
      ASSERT_GT(cubic, 0.0);
    }
    // ... and where it exceeds its cell's margin E_c <= E.
    const double cellMargin = lookup.cellMargin(g.cellAtCells(c));
    ASSERT_LE(cellMargin, E * (1.0 + 1e-12));
    if (linear > cellMargin) {
      ASSERT_GT(cubic, 0.0) << "cell margin " << cellMargin;
      if (linear <= E) ++clearedByCell;
    }
    // A point within one cell of c (in the box) above c's near margin is
    // outside the cubic too.
    const double nearMargin = lookup.nearMargin(g.cellAtCells(c));
    ASSERT_GE(nearMargin, cellMargin);
    ASSERT_LE(nearMargin, E * (1.0 + 1e-12));
    Vec<D> step;
    for (int a = 0; a < D; ++a) step[a] = u(rng) - 0.5;
    const Vec<D> moved = c + u(rng) * step / step.norm();
    bool inBox = true;
    for (int a = 0; a < D; ++a) inBox = inBox && moved[a] >= 0.0 && moved[a] <= double(g.dims()[a] - 1);
    if (inBox && g.valueAtCells(moved) > nearMargin) {
      ASSERT_GT(g.cubicValueAtCells(moved), 0.0) << "near margin " << nearMargin;
      if (g.valueAtCells(moved) <= E) ++clearedByNear;
    }
    // ... and where the cubic is negative the point is in the cubic bounding sphere.
    if (cubic < 0.0) {
      ++negative;
      const Vec<D> body = shape.bodyToGrid().applyInverse(g.toWorld(c));
      ASSERT_LE(body.norm(), shape.cubicBoundingRadius() * (1.0 + 1e-12));
    }
  }
  EXPECT_GT(negative, 1000);
  // A bound, not a guess: within a small factor of the steepest sampled.
  EXPECT_LT(lookup.slope, kSlopeBoundFactor * steepest);
  std::printf("cubic gradient bound %.3f, steepest sampled %.3f (ratio %.2f)\n", lookup.slope, steepest,
              lookup.slope / steepest);
  // The cell margins clear points near the surface that E does not.
  EXPECT_GT(clearedByCell, 100);
  EXPECT_GT(clearedByNear, 20);
}

}  // namespace

TEST(Shape, CubicMarginAndReachHoldForGrains) {
  ShapeDef<3> grain;
  grain.kind = ShapeKind::RandomGrain;
  grain.grain.roughness = 0.15;
  grain.grain.elongation = 1.3;
  grain.grain.seed = 4;
  grain.cellsAcross = 8;
  grain.options.nodesPerCell = 1.0;
  checkCubicMarginAndReach<3>(*buildShape(grain));
  ShapeDef<3> box;
  box.kind = ShapeKind::Box;
  box.halfExtents = Vec<3>(0.3, 0.2, 0.1);
  box.cellsAcross = 6;
  checkCubicMarginAndReach<3>(*buildShape(box));
  ShapeDef<2> triangle;
  triangle.kind = ShapeKind::Polygon;
  triangle.vertices = {Vec<2>(0.0, 0.0), Vec<2>(1.0, 0.1), Vec<2>(0.2, 0.5)};
  triangle.cellsAcross = 6;
  checkCubicMarginAndReach<2>(*buildShape(triangle));
}

// Nodes on the exact surface (ShapeDef::exactNodes, the default): on a
// sphere |x| = R to round-off, where the grid's nodes sit inside by about
// h^2 / (8 R) per curved direction; on a random grain its radial distance
// function is 0 at every node; a mesh (no exact surface) keeps the grid's.
TEST(ShapeDef, ExactNodesLieOnTheTrueSurface) {
  ShapeDef<3> def;
  def.kind = ShapeKind::Sphere;
  def.radius = 0.5;
  def.cellsAcross = 10;
  def.options.nodesPerCell = 1.0;
  const auto exact = buildShape(def);
  def.exactNodes = false;
  const auto onGrid = buildShape(def);
  const double h = exact->grid().spacing();
  const auto radialGap = [](const Shape<3>& s) {
    double worst = 0.0, mean = 0.0;
    for (const Vec<3>& x : s.nodes().positions) {
      const double gap = s.bodyToGrid().apply(x).norm() - 0.5;
      worst = std::max(worst, std::abs(gap));
      mean += gap / double(s.nodes().size());
    }
    return std::pair{worst, mean};
  };
  const auto [exactWorst, exactMean] = radialGap(*exact);
  const auto [gridWorst, gridMean] = radialGap(*onGrid);
  EXPECT_LT(exactWorst, 1e-9 * h);
  EXPECT_LT(gridMean, -0.05 * h * h / 0.5);  // inside, by a good part of h^2 / (8 R) per direction
  EXPECT_GT(gridWorst, 1e3 * exactWorst);
  // The weights are the area of the polyhedron through the nodes: nearer 4 pi R^2 on the sphere.
  const double area = 4.0 * kPi * 0.25;
  EXPECT_LT(std::abs(exact->nodes().totalWeight() - area), std::abs(onGrid->nodes().totalWeight() - area));

  ShapeDef<3> grain;
  grain.kind = ShapeKind::RandomGrain;
  grain.grain.roughness = 0.15;
  grain.grain.seed = 4;
  grain.cellsAcross = 8;
  grain.options.nodesPerCell = 1.0;
  const auto rough = buildShape(grain);
  const SurfaceFunction<3> surface = exactSurface(grain);
  ASSERT_TRUE(bool(surface));
  double worst = 0.0;
  for (const Vec<3>& x : rough->nodes().positions) worst = std::max(worst, std::abs(surface(rough->bodyToGrid().apply(x))));
  EXPECT_LT(worst, 1e-6 * rough->grid().spacing());

  ShapeDef<3> mesh;
  mesh.kind = ShapeKind::Mesh;
  EXPECT_FALSE(bool(exactSurface(mesh)));
}

// Mesh nodes on the CAD surface (meshSurfaceProjector): the grid's nodes of
// an icosphere (R = 0.5, 20,480 faces) at 10 cells across sit inside it by
// about h^2 / (8 R) per curved direction; moved to the closest point of the
// triangles they lie on the mesh to round-off, and on the sphere to within
// the mesh's own chord sag. Measured: mean distance to the sphere 3.42e-3
// (grid) -> 8.97e-5 (exact), to the mesh 3.33e-3 -> 2e-16 (h^2 / (8 R) =
// 2.5e-3). A box of 12 triangles turned off the grid's axes: the grid's
// nodes cut its edges and corners (worst 0.28 cells from the mesh at 6
// cells), the exact ones lie on its faces (4e-15 cells).
TEST(ShapeDef, MeshNodesLieOnTheTriangles) {
  const double R = 0.5;
  const TriangleMesh ball = lsdem::test::icosphere(R, 5);
  const std::string ballFile = lsdem::test::tempPath("icosphere.stl").string();
  writeStl(ball, ballFile);
  ShapeDef<3> def;
  def.kind = ShapeKind::Mesh;
  def.meshFile = ballFile;
  def.cellsAcross = 10;
  def.options.nodesPerCell = 1.0;
  const auto exact = buildShape(def);
  def.exactNodes = false;
  const auto onGrid = buildShape(def);
  const double h = exact->grid().spacing();
  // Distances of the nodes (mesh frame) to the sphere and to the mesh as
  // read back (float32 vertices; its closest point, without the one-cell cap).
  const SurfaceProjector<3> closest = meshSurfaceProjector(readMesh(ballFile), 1e3);
  const auto gaps = [&](const Shape<3>& s) {
    double sphere = 0.0, mesh = 0.0;
    for (const Vec<3>& node : s.nodes().positions) {
      const Vec<3> x = s.bodyToGrid().apply(node);
      sphere += std::abs(x.norm() - R) / double(s.nodes().size());
      mesh += (closest(x) - x).norm() / double(s.nodes().size());
    }
    return std::pair{sphere, mesh};
  };
  const auto [exactSphere, exactMesh] = gaps(*exact);
  const auto [gridSphere, gridMesh] = gaps(*onGrid);
  std::printf("icosphere at 10 cells, mean node distance to the sphere / mesh: grid %.3e / %.3e, exact %.3e / %.3e "
              "(h^2 / (8 R) = %.3e)\n", gridSphere, gridMesh, exactSphere, exactMesh, h * h / (8.0 * R));
  // Chord sag of the mesh: no vertex of a face is farther than this from its plane's sphere point.
  double sag = 0.0;
  for (const auto& f : ball.faces) {
    const Vec<3> centroid = (ball.vertices[std::size_t(f[0])] + ball.vertices[std::size_t(f[1])] +
                             ball.vertices[std::size_t(f[2])]) / 3.0;
    sag = std::max(sag, R - centroid.norm());
  }
  EXPECT_LT(exactMesh, 1e-9 * h);
  EXPECT_LT(exactSphere, sag);
  EXPECT_GT(gridSphere, 0.5 * h * h / (8.0 * R));
  EXPECT_GT(gridSphere, 10.0 * exactSphere);
  EXPECT_EQ(exact->nodes().size(), onGrid->nodes().size());

  // A box turned off the grid's axes: nodes on its faces, not across its
  // edges and corners.
  TriangleMesh box = lsdem::test::boxMesh(Vec<3>::Zero(), Vec<3>(0.3, 0.2, 0.15));
  const Mat<3> turn = Eigen::AngleAxisd(0.5, Vec<3>(1, 2, 3).normalized()).toRotationMatrix();
  for (Vec<3>& v : box.vertices) v = turn * v;
  const std::string boxFile = lsdem::test::tempPath("box.stl").string();
  writeStl(box, boxFile);
  const SurfaceProjector<3> onBox = meshSurfaceProjector(readMesh(boxFile), 1e3);
  def.meshFile = boxFile;
  def.cellsAcross = 6;
  const auto worstGap = [&](bool exactNodes) {
    def.exactNodes = exactNodes;
    const auto s = buildShape(def);
    double worst = 0.0;
    for (const Vec<3>& node : s->nodes().positions) {
      const Vec<3> x = s->bodyToGrid().apply(node);
      worst = std::max(worst, (onBox(x) - x).norm() / s->grid().spacing());
    }
    return worst;
  };
  const double boxExact = worstGap(true), boxGrid = worstGap(false);
  std::printf("box mesh at 6 cells, worst node distance to the mesh: grid %.3e cells, exact %.3e cells\n", boxGrid,
              boxExact);
  EXPECT_LT(boxExact, 1e-9);
  EXPECT_GT(boxGrid, 0.05);
}

TEST(ShapeDef, ExactNodesOnAnEllipseAndAPolygon2D) {
  ShapeDef<2> ellipse;
  ellipse.kind = ShapeKind::Ellipsoid;
  ellipse.semiAxes = Vec<2>(0.5, 0.3);
  ellipse.cellsAcross = 8;
  ellipse.options.nodesPerCell = 1.0;
  const auto shape = buildShape(ellipse);
  for (const Vec<2>& x : shape->nodes().positions) {
    EXPECT_NEAR(sdfEllipsoid<2>(shape->bodyToGrid().apply(x), ellipse.semiAxes), 0.0, 1e-9);
  }
  ShapeDef<2> triangle;
  triangle.kind = ShapeKind::Polygon;
  triangle.vertices = {Vec<2>(0.0, 0.0), Vec<2>(1.0, 0.1), Vec<2>(0.2, 0.5)};
  triangle.cellsAcross = 6;
  const auto tri = buildShape(triangle);
  for (const Vec<2>& x : tri->nodes().positions) {
    EXPECT_NEAR(sdfPolygon(tri->bodyToGrid().apply(x), triangle.vertices), 0.0, 1e-9);
  }
}
