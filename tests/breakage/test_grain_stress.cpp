/// @file test_grain_stress.cpp
/// @brief Grain stress (eq. 5-6): the exact tensor of a disc / sphere squeezed
/// or pulled by two and four forces, the symmetric part, principal stresses in
/// descending order with their invariants, and the per-particle gathering from
/// the contact solver (particle, plane and tool records) with the strongest
/// contact point per pair for the fracture-plane rule (eq. 18-20).

#include "support/Shapes.h"
#include "lsdem/breakage/GrainStress.h"
#include "lsdem/geometry/ShapeDef.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>

using namespace lsdem;
using namespace lsdem::breakage;

namespace {

// Volume of a ball of radius r: area in 2D.
template <int D>
double ballVolume(double r) {
  return D == 2 ? std::numbers::pi * r * r : 4.0 / 3.0 * std::numbers::pi * r * r * r;
}

// A unit vector in a generic direction.
template <int D>
Vec<D> direction() {
  Vec<D> n;
  if constexpr (D == 2) {
    n << 0.6, 0.8;
  } else {
    n << 2.0, -1.0, 2.0;
  }
  return n.normalized();
}

// A unit vector orthogonal to direction<D>().
template <int D>
Vec<D> orthogonal() {
  Vec<D> t;
  if constexpr (D == 2) {
    t << -0.8, 0.6;
  } else {
    t << 1.0, 2.0, 0.0;
  }
  return t.normalized();
}

// Two equal and opposite forces F along a diameter d = 2R: sigma = -F d / V n n^T
// (squeezing), +F d / V n n^T (pulling).
template <int D>
void checkTwoForces() {
  const double r = 0.3, f = 1.7e4, v = ballVolume<D>(r);
  const Vec<D> n = direction<D>();
  const Vec<D> branches[2] = {r * n, -r * n};
  const Vec<D> squeeze[2] = {-f * n, f * n};
  const Mat<D> sigma = averageStress<D>(branches, squeeze, v);
  const Mat<D> expected = -f * 2.0 * r / v * n * n.transpose();
  EXPECT_LT((sigma - expected).cwiseAbs().maxCoeff(), 1e-12 * f / v);
  // Principal stresses: (0, ..., -F d / V), descending.
  const Vec<D> s = principalStresses<D>(sigma);
  EXPECT_NEAR(s[D - 1], -f * 2.0 * r / v, 1e-10 * f / v);
  for (int a = 0; a + 1 < D; ++a) EXPECT_NEAR(s[a], 0.0, 1e-10 * f / v);
  // Pulling: tension positive.
  const Vec<D> pull[2] = {f * n, -f * n};
  EXPECT_NEAR(principalStresses<D>(averageStress<D>(branches, pull, v))[0], f * 2.0 * r / v, 1e-10 * f / v);
}

// Two diametral pairs, F along n and G along t: sigma = -(d/V)(F n n^T + G t t^T).
template <int D>
void checkFourForces() {
  const double r = 0.25, f = 3e3, g = 1e3, v = ballVolume<D>(r), d = 2.0 * r;
  const Vec<D> n = direction<D>(), t = orthogonal<D>();
  const Vec<D> branches[4] = {r * n, -r * n, r * t, -r * t};
  const Vec<D> forces[4] = {-f * n, f * n, -g * t, g * t};
  const Mat<D> sigma = averageStress<D>(branches, forces, v);
  const Mat<D> expected = -(d / v) * (f * n * n.transpose() + g * t * t.transpose());
  EXPECT_LT((sigma - expected).cwiseAbs().maxCoeff(), 1e-12 * f / v);
  const Vec<D> s = principalStresses<D>(sigma);
  EXPECT_NEAR(s[D - 1], -f * d / v, 1e-10 * f / v);
  EXPECT_NEAR(s[D - 2], -g * d / v, 1e-10 * f / v);
  if (D == 3) {
    EXPECT_NEAR(s[0], 0.0, 1e-10 * f / v);
  }
  // The triple the criteria read: 2D plane stress pads a zero.
  const Vec<3> triple = principalStressTriple<D>(sigma);
  EXPECT_NEAR(triple.minCoeff(), -f * d / v, 1e-10 * f / v);
  EXPECT_NEAR(triple.maxCoeff(), 0.0, 1e-10 * f / v);
}

}  // namespace

TEST(GrainStress, TwoOpposingForces2D) { checkTwoForces<2>(); }
TEST(GrainStress, TwoOpposingForces3D) { checkTwoForces<3>(); }
TEST(GrainStress, FourForces2D) { checkFourForces<2>(); }
TEST(GrainStress, FourForces3D) { checkFourForces<3>(); }

// A couple of tangential forces: x (outer) F is not symmetric; its symmetric part is kept.
TEST(GrainStress, KeepsTheSymmetricPart) {
  const double r = 0.5, t = 2.0, v = ballVolume<2>(r);
  const Vec<2> branches[2] = {Vec<2>(r, 0.0), Vec<2>(-r, 0.0)};
  const Vec<2> forces[2] = {Vec<2>(0.0, t), Vec<2>(0.0, -t)};
  const Mat<2> sigma = averageStress<2>(branches, forces, v);
  EXPECT_DOUBLE_EQ(sigma(0, 1), r * t / v);
  EXPECT_DOUBLE_EQ(sigma(1, 0), r * t / v);
  EXPECT_DOUBLE_EQ(sigma(0, 0), 0.0);
  EXPECT_DOUBLE_EQ(sigma(1, 1), 0.0);
  // No contacts: zero stress.
  EXPECT_EQ(averageStress<3>({}, {}, 1.0), Mat<3>::Zero());
}

// eq. 6: descending eigenvalues of random symmetric tensors with trace and
// determinant preserved and sigma n = s n.
TEST(GrainStress, PrincipalStressesOfRandomTensors) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1e7, 1e7);
  for (int k = 0; k < 50; ++k) {
    Mat<3> a;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) a(i, j) = u(rng);
    const Mat<3> sigma = 0.5 * (a + a.transpose());
    const Vec<3> s = principalStresses<3>(sigma);
    EXPECT_GE(s[0], s[1]);
    EXPECT_GE(s[1], s[2]);
    EXPECT_NEAR(s.sum(), sigma.trace(), 1e-6);
    EXPECT_NEAR(s.prod(), sigma.determinant(), 1e-9 * std::abs(sigma.determinant()) + 1e6);
    for (int i = 0; i < 3; ++i) EXPECT_NEAR((sigma - s[i] * Mat<3>::Identity()).determinant() / 1e21, 0.0, 1e-6);
    const Mat<2> sigma2 = sigma.topLeftCorner<2, 2>();
    const Vec<2> s2 = principalStresses<2>(sigma2);
    EXPECT_GE(s2[0], s2[1]);
    const double mean = 0.5 * sigma2.trace();
    const double radius = std::hypot(0.5 * (sigma2(0, 0) - sigma2(1, 1)), sigma2(0, 1));
    EXPECT_NEAR(s2[0], mean + radius, 1e-8);
    EXPECT_NEAR(s2[1], mean - radius, 1e-8);
  }
}

TEST(GrainStress, RejectsBadInput) {
  const Vec<2> x[2] = {Vec<2>::Zero(), Vec<2>::Zero()};
  const Vec<2> f[1] = {Vec<2>::Zero()};
  EXPECT_THROW(averageStress<2>(x, f, 1.0), std::invalid_argument);
  EXPECT_THROW(averageStress<2>(f, f, 0.0), std::invalid_argument);
  EXPECT_THROW(averageStress<2>(f, f, std::nan("")), std::invalid_argument);
}

namespace {

// Particles a (at 0) and b (at 0.97 x) of radius 0.5 touch; a plane at x = -0.46
// presses a (4 cm overlap), a spherical tool at 1.96 x presses b (1 cm).
template <int D>
void checkGathering() {
  using namespace lsdem::dynamics;
  const auto shape = test::sphereShape<D>(0.5, 16);
  Particles<D> p;
  ParticleDef<D> def;
  def.shape = shape;
  p.add(def);
  def.position = 0.97 * Vec<D>::UnitX();
  p.add(def);
  const std::vector<Plane<D>> planes{Plane<D>{-0.46 * Vec<D>::UnitX(), Vec<D>::UnitX(), Vec<D>::Zero()}};
  ToolPose<D> tool;
  tool.shape = shape.get();
  tool.position = 1.96 * Vec<D>::UnitX();
  const std::vector<ToolPose<D>> tools{tool};
  ContactLawDef law;
  law.hasFriction = false;
  law.hasDamping = false;
  ContactSolver<D> solver(law);
  solver.compute(p, {{0, 1}}, planes, tools, 1e-5);
  ASSERT_EQ(solver.particleContacts().size(), 1u);
  ASSERT_EQ(solver.planeContacts().size(), 1u);
  ASSERT_EQ(solver.toolContacts().size(), 1u);

  // Reference: eq. 5 from branch and force lists gathered by hand.
  std::vector<Vec<D>> branches[2], forces[2];
  const auto& nodes = solver.nodeContacts();
  const auto collect = [&](const PairContact<D>& pair, bool particlePair) {
    for (std::uint32_t k = 0; k < pair.nodeCount; ++k) {
      const NodeContact<D>& c = nodes[pair.firstNode + k];
      branches[pair.a].push_back(c.point - p.position[pair.a]);
      forces[pair.a].push_back(c.force);
      if (particlePair) {
        branches[pair.b].push_back(c.point - p.position[pair.b]);
        forces[pair.b].push_back(-c.force);
      }
    }
  };
  collect(solver.particleContacts()[0], true);
  collect(solver.planeContacts()[0], false);
  collect(solver.toolContacts()[0], false);

  std::vector<Mat<D>> sigma;
  grainStresses(p, solver, sigma);
  ASSERT_EQ(sigma.size(), 2u);
  double scale = 0.0;
  for (int i = 0; i < 2; ++i) {
    const Mat<D> expected = averageStress<D>(branches[i], forces[i], shape->volume());
    scale = std::max(scale, expected.cwiseAbs().maxCoeff());
    EXPECT_LT((sigma[i] - expected).cwiseAbs().maxCoeff(), 1e-12 * scale) << "particle " << i;
    EXPECT_LT((sigma[i] - sigma[i].transpose()).cwiseAbs().maxCoeff(), 1e-12 * scale);
  }
  // Physics: both grains are squeezed along x; with total loads P (pair) and Q
  // (boundary) at about R from the centroid, sigma_xx ~ -(P + Q) R / V.
  const double pairLoad = solver.particleContacts()[0].force.norm();
  const double planeLoad = solver.planeContacts()[0].force.norm();
  const double toolLoad = solver.toolContacts()[0].force.norm();
  EXPECT_GT(planeLoad, pairLoad);
  EXPECT_NEAR(sigma[0](0, 0), -(pairLoad + planeLoad) * 0.49 / shape->volume(),
              0.03 * (pairLoad + planeLoad) * 0.49 / shape->volume());
  EXPECT_NEAR(sigma[1](0, 0), -(pairLoad + toolLoad) * 0.49 / shape->volume(),
              0.03 * (pairLoad + toolLoad) * 0.49 / shape->volume());
  EXPECT_LT(principalStresses<D>(sigma[0])[D - 1], 0.0);

  // Strongest contacts: one entry per pair, its strongest node, sorted descending.
  GrainContactPoints<D> points;
  strongestContacts(p, solver, points);
  ASSERT_EQ(points.offset.size(), 3u);
  ASSERT_EQ(points.of(0).size(), 2u);
  ASSERT_EQ(points.of(1).size(), 2u);
  const auto strongest = [&](const PairContact<D>& pair) {
    const NodeContact<D>* best = &nodes[pair.firstNode];
    for (std::uint32_t k = 1; k < pair.nodeCount; ++k) {
      if (nodes[pair.firstNode + k].force.norm() > best->force.norm()) best = &nodes[pair.firstNode + k];
    }
    return best;
  };
  const NodeContact<D>* pairBest = strongest(solver.particleContacts()[0]);
  const NodeContact<D>* planeBest = strongest(solver.planeContacts()[0]);
  const NodeContact<D>* toolBest = strongest(solver.toolContacts()[0]);
  EXPECT_GT(solver.particleContacts()[0].nodeCount, 1u);
  // Node forces: k x overlap for planes and tools, (k / 2) x overlap per
  // direction for particle pairs (two-sided test). a: the plane (4 cm) beats
  // the pair (3 cm / 2); b: the pair beats the tool (1 cm).
  EXPECT_EQ(points.of(0)[0].point, planeBest->point);
  EXPECT_EQ(points.of(0)[0].force, planeBest->force.norm());
  EXPECT_EQ(points.of(0)[1].point, pairBest->point);
  EXPECT_EQ(points.of(1)[0].point, pairBest->point);
  EXPECT_EQ(points.of(1)[0].force, pairBest->force.norm());
  EXPECT_EQ(points.of(1)[1].point, toolBest->point);
  EXPECT_GE(points.of(0)[0].force, points.of(0)[1].force);
  EXPECT_GE(points.of(1)[0].force, points.of(1)[1].force);
  // The strongest point of a plane contact lies on the plane's side of a.
  EXPECT_LT(points.of(0)[0].point[0], -0.4);

  // Buffers are reused: a second call gives the same rows.
  const std::vector<ContactPoint<D>> before = points.points;
  strongestContacts(p, solver, points);
  ASSERT_EQ(points.points.size(), before.size());
  for (std::size_t k = 0; k < before.size(); ++k) EXPECT_EQ(points.points[k].point, before[k].point);

  // Records naming particles the store does not hold are refused.
  Particles<D> fewer;
  def.position = Vec<D>::Zero();
  fewer.add(def);
  EXPECT_THROW(grainStresses(fewer, solver, sigma), std::invalid_argument);
  EXPECT_THROW(strongestContacts(fewer, solver, points), std::invalid_argument);
}

}  // namespace

TEST(GrainStress, GathersEveryContactRecord2D) { checkGathering<2>(); }
TEST(GrainStress, GathersEveryContactRecord3D) { checkGathering<3>(); }
