#include "lsdem/geometry/Primitives.h"
#include "lsdem/geometry/Shape.h"
#include "lsdem/geometry/ShapeDef.h"
#include "support/Shapes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
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
  for (int k = 0; k < 200000; ++k) {
    Vec<D> c;
    for (int a = 0; a < D; ++a) c[a] = u(rng) * double(g.dims()[a] - 1);
    const double cubic = g.cubicValueAtCells(c);
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
