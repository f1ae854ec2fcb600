#include "lsdem/breakage/FracturePlane.h"

#include "lsdem/geometry/ShapeDef.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

using namespace lsdem::breakage;
using lsdem::geometry::HalfSpace;
using lsdem::geometry::Mat;
using lsdem::geometry::Vec;

namespace {

template <int D>
std::vector<ContactPoint<D>> pts(std::initializer_list<Vec<D>> list) {
  std::vector<ContactPoint<D>> out;
  double f = 10.0;
  for (const Vec<D>& x : list) out.push_back({x, f--});
  return out;
}

template <int D>
void expectOn(const HalfSpace<D>& h, const Vec<D>& x) {
  EXPECT_NEAR(h.distance(x), 0.0, 1e-12) << x.transpose();
}

template <int D>
void expectUnit(const HalfSpace<D>& h) {
  ASSERT_TRUE(h.normal.allFinite());
  EXPECT_NEAR(h.normal.norm(), 1.0, 1e-12);
}

}  // namespace

// eq. 18: the line through the two strongest points (the third is ignored).
TEST(FracturePlane, TwoDLineThroughTwoStrongest) {
  const auto p = pts<2>({Vec<2>(1, 0), Vec<2>(-1, 0.5), Vec<2>(0, 3)});
  const auto h = fracturePlane<2>(Vec<2>(0, 0.1), p, 2.0);
  ASSERT_TRUE(h);
  expectUnit(*h);
  expectOn(*h, Vec<2>(1, 0));
  expectOn(*h, Vec<2>(-1, 0.5));
  EXPECT_GT(std::abs(h->distance(Vec<2>(0, 3))), 1.0);
}

// One contact: the line through it and the centroid; none: no line.
TEST(FracturePlane, TwoDSingleContactUsesCentroid) {
  const auto p = pts<2>({Vec<2>(1, 1)});
  const auto h = fracturePlane<2>(Vec<2>(0.5, 0), p, 1.0);
  ASSERT_TRUE(h);
  expectUnit(*h);
  expectOn(*h, Vec<2>(1, 1));
  expectOn(*h, Vec<2>(0.5, 0));
  EXPECT_FALSE(fracturePlane<2>(Vec<2>(0, 0), std::span<const ContactPoint<2>>{}, 1.0));
}

// Coincident points: the next strongest distinct point, then the centroid;
// a single point at the centroid defines no line.
TEST(FracturePlane, TwoDCoincidentPointsFallBack) {
  const auto p = pts<2>({Vec<2>(1, 0), Vec<2>(1, 1e-9), Vec<2>(0, 1)});
  const auto h = fracturePlane<2>(Vec<2>(5, 5), p, 1.0);
  ASSERT_TRUE(h);
  expectOn(*h, Vec<2>(1, 0));
  expectOn(*h, Vec<2>(0, 1));
  const auto q = pts<2>({Vec<2>(1, 0), Vec<2>(1, 0)});
  const auto g = fracturePlane<2>(Vec<2>(0, 2), q, 1.0);
  ASSERT_TRUE(g);
  expectOn(*g, Vec<2>(1, 0));
  expectOn(*g, Vec<2>(0, 2));
  const auto c = pts<2>({Vec<2>(0.3, 0.3), Vec<2>(0.3, 0.3)});
  EXPECT_FALSE(fracturePlane<2>(Vec<2>(0.3, 0.3), c, 1.0));
  EXPECT_THROW(fracturePlane<2>(Vec<2>(0, 0), p, 0.0), std::invalid_argument);
  EXPECT_THROW(fracturePlane<2>(Vec<2>(0, 0), p, std::nan("")), std::invalid_argument);
}

// eq. 19-20: the plane through the three strongest points.
TEST(FracturePlane, ThreeDPlaneThroughThreeStrongest) {
  const auto p = pts<3>({Vec<3>(1, 0, 0), Vec<3>(0, 1, 0), Vec<3>(0, 0, 1), Vec<3>(5, 5, 5)});
  const auto h = fracturePlane<3>(Vec<3>(0, 0, 0), p, 1.0);
  ASSERT_TRUE(h);
  expectUnit(*h);
  EXPECT_NEAR(std::abs(h->normal.dot(Vec<3>(1, 1, 1).normalized())), 1.0, 1e-12);
  EXPECT_NEAR(std::abs(h->offset), 1.0 / std::sqrt(3.0), 1e-12);
}

// Two contacts: through them and the centroid; one: held (nullopt).
TEST(FracturePlane, ThreeDTwoContactsUseCentroidOneIsHeld) {
  const auto p = pts<3>({Vec<3>(1, 0, 0), Vec<3>(-1, 0, 0)});
  const Vec<3> c(0, 0.2, 0.3);
  const auto h = fracturePlane<3>(c, p, 2.0);
  ASSERT_TRUE(h);
  expectUnit(*h);
  expectOn(*h, Vec<3>(1, 0, 0));
  expectOn(*h, Vec<3>(-1, 0, 0));
  expectOn(*h, c);
  EXPECT_FALSE(fracturePlane<3>(c, std::span(p).first(1), 2.0));
  const auto same = pts<3>({Vec<3>(1, 0, 0), Vec<3>(1, 0, 1e-9)});
  EXPECT_FALSE(fracturePlane<3>(c, same, 2.0));
}

// Collinear third point: skipped for the next strongest off the line, then the
// centroid, then the plane containing the line and tilted by a world axis.
TEST(FracturePlane, ThreeDCollinearFallBacks) {
  const auto p = pts<3>({Vec<3>(0, 0, 0), Vec<3>(1, 1, 0), Vec<3>(2, 2, 0), Vec<3>(0, 0, 1)});
  const auto h = fracturePlane<3>(Vec<3>(9, 0, 0), p, 1.0);
  ASSERT_TRUE(h);
  expectOn(*h, Vec<3>(0, 0, 0));
  expectOn(*h, Vec<3>(1, 1, 0));
  expectOn(*h, Vec<3>(0, 0, 1));
  EXPECT_GT(std::abs(h->distance(Vec<3>(9, 0, 0))), 1.0);

  const auto line = pts<3>({Vec<3>(0, 0, 0), Vec<3>(1, 1, 0), Vec<3>(2, 2, 0)});
  const auto g = fracturePlane<3>(Vec<3>(0, 0, 2), line, 1.0);
  ASSERT_TRUE(g);
  expectOn(*g, Vec<3>(0, 0, 2));
  expectOn(*g, Vec<3>(2, 2, 0));

  // Everything on the x axis: the plane contains it, normal = x cross e_y = z.
  const auto axis = pts<3>({Vec<3>(1, 0, 0), Vec<3>(-1, 0, 0), Vec<3>(0.5, 0, 0)});
  const auto a = fracturePlane<3>(Vec<3>(0, 0, 0), axis, 1.0);
  ASSERT_TRUE(a);
  expectUnit(*a);
  expectOn(*a, Vec<3>(3, 0, 0));
  EXPECT_NEAR(std::abs(a->normal[2]), 1.0, 1e-15);
}

// eq. 21: the buckling plane of an elongated box passes through the centroid
// and the closest surface node (a point on a long side, at distance b).
TEST(FracturePlane, BucklingThroughCentroidAndClosestNode) {
  lsdem::geometry::ShapeDef<2> d2;
  d2.kind = lsdem::geometry::ShapeKind::Box;
  d2.halfExtents = Vec<2>(0.5, 0.05);
  d2.cellsAcross = 8;
  const auto s2 = lsdem::geometry::buildShape(d2);
  EXPECT_GT(circumscribedVolumeRatio(*s2), 3.14159 * 0.5 * 0.5 / (1.0 * 0.1) * 0.9);
  const Vec<2> x(2, 3);
  const Mat<2> r = Eigen::Rotation2Dd(0.3).toRotationMatrix();
  const auto h2 = bucklingPlane<2>(*s2, x, r, 1, 7);
  ASSERT_TRUE(h2);
  expectUnit(*h2);
  expectOn(*h2, x);
  // The line runs across the slender box: along its short body axis.
  const Vec<2> shortAxis = r * Vec<2>::UnitY();
  EXPECT_LT(std::abs(h2->normal.dot(shortAxis)), 0.2);

  lsdem::geometry::ShapeDef<3> d3;
  d3.kind = lsdem::geometry::ShapeKind::Box;
  d3.halfExtents = Vec<3>(0.5, 0.06, 0.06);
  d3.cellsAcross = 6;
  const auto s3 = lsdem::geometry::buildShape(d3);
  EXPECT_GT(circumscribedVolumeRatio(*s3), 10.0);
  const auto h3 = bucklingPlane<3>(*s3, Vec<3>(1, 2, 3), Mat<3>::Identity(), 1, 7);
  ASSERT_TRUE(h3);
  expectUnit(*h3);
  expectOn(*h3, Vec<3>(1, 2, 3));
  const auto again = bucklingPlane<3>(*s3, Vec<3>(1, 2, 3), Mat<3>::Identity(), 1, 7);
  EXPECT_EQ(h3->normal, again->normal);
}
