#include "lsdem/dynamics/Integrator.h"
#include "lsdem/dynamics/TimeStep.h"
#include "lsdem/geometry/ShapeDef.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <string>

using namespace lsdem;
using namespace lsdem::dynamics;

namespace {

template <int D>
std::shared_ptr<const geometry::Shape<D>> sphere(double radius, double cellsAcross, double nodesPerCell = 1.0) {
  geometry::ShapeDef<D> def;
  def.kind = geometry::ShapeKind::Sphere;
  def.radius = radius;
  def.cellsAcross = cellsAcross;
  def.options.nodesPerCell = nodesPerCell;
  return geometry::buildShape(def);
}

template <int D>
std::shared_ptr<const geometry::Shape<D>> box(const Vec<D>& halfExtents, double spacing, double nodesPerCell = 1.0) {
  geometry::ShapeDef<D> def;
  def.kind = geometry::ShapeKind::Box;
  def.halfExtents = halfExtents;
  def.spacing = spacing;
  def.options.nodesPerCell = nodesPerCell;
  return geometry::buildShape(def);
}

// A mass on a linear spring (and dashpot) integrated with kickDrift/kick at
// dt = factor x dt_crit; returns max |x| / x0 over the run (stops once it exceeds 1e6).
double springRun(double factor, double dampingRatio, int steps, double* finalRatio = nullptr) {
  Particles<2> p;
  ParticleDef<2> def;
  def.shape = sphere<2>(0.5, 8);
  def.position = Vec<2>(1e-3, 0.0);
  p.add(def);
  const double m = p.mass[0], k = 1e4;
  const double c = 2 * dampingRatio * std::sqrt(k * m);
  const double dt = factor * criticalTimeStep({m}, {k}, dampingRatio);
  double worst = 1.0;
  p.force[0] = -k * p.position[0];
  for (int n = 0; n < steps && worst < 1e6; ++n) {
    kickDrift(p, dt);
    p.force[0] = -k * p.position[0] - c * p.velocity[0];  // the half-step velocity, as the contact laws see it
    kick(p, dt);
    worst = std::max(worst, p.position[0].norm() / 1e-3);
  }
  if (finalRatio) *finalRatio = p.position[0].norm() / 1e-3;
  return worst;
}

// Rigid body resting on a wall through bonded linear node springs on the
// estimate's stiffest patch: normal k_i along the patch normal and
// tangentialRatio k_i across it. Integrated at dt = factor x dt_crit from a
// small random velocity; returns max energy / initial energy (stops above 1e6).
template <int D>
double bondedPatchRun(const geometry::Shape<D>& shape, const NodeStiffness& law, double factor, int steps,
                      std::uint32_t seed) {
  Particles<D> p;
  ParticleDef<D> def;
  def.shape = std::shared_ptr<const geometry::Shape<D>>(&shape, [](const geometry::Shape<D>*) {});
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss;
  for (int a = 0; a < D; ++a) def.velocity[a] = 1e-4 * gauss(rng);
  if constexpr (D == 2) {
    def.angularVelocity = 1e-4 * gauss(rng);
  } else {
    def.angularVelocity = 1e-4 * Vec<3>(gauss(rng), gauss(rng), gauss(rng));
  }
  p.add(def);

  ContactStiffnessOptions options;
  options.particlePairs = false;
  const StiffestContact<D> sc = stiffestContact(shape, law, options);
  const double dt = factor * criticalTimeStep({p.mass[0]}, {sc.stiffness});

  // The patch: nodes within 0.1 h of the supporting plane (the estimate's default depth).
  const auto& X = shape.nodes().positions;
  const auto& w = shape.nodes().weights;
  const Vec<D> n = sc.normal;
  double support = -1e300;
  for (const auto& x : X) support = std::max(support, n.dot(x));
  std::vector<std::size_t> patch;
  for (std::size_t i = 0; i < X.size(); ++i) {
    if (n.dot(X[i]) >= support - 0.1 * shape.grid().spacing()) patch.push_back(i);
  }
  EXPECT_EQ(patch.size(), sc.nodeCount);

  // Spring forces and energy at the current pose.
  const auto forces = [&](double& elastic) {
    const Mat<D> R = p.rotation(0);
    Vec<D> F = Vec<D>::Zero();
    Spin<D> T = Rotation<D>::zeroSpin();
    elastic = 0.0;
    for (std::size_t i : patch) {
      const Vec<D> arm = R * X[i];
      const Vec<D> u = p.position[0] + arm - X[i];
      const double k = law.perNode + law.perWeight * w[i];
      const Vec<D> un = n.dot(u) * n, ut = u - un;
      const Vec<D> f = -k * (un + law.tangentialRatio * ut);
      F += f;
      T += Rotation<D>::moment(arm, f);
      elastic += 0.5 * k * (un.squaredNorm() + law.tangentialRatio * ut.squaredNorm());
    }
    p.force[0] = F;
    p.torque[0] = T;
  };
  double elastic = 0.0;
  forces(elastic);
  const double e0 = p.kineticEnergy(0) + elastic;
  double worst = 1.0;
  for (int s = 0; s < steps && worst < 1e6; ++s) {
    kickDrift(p, dt);
    forces(elastic);
    kick(p, dt);
    worst = std::max(worst, (p.kineticEnergy(0) + elastic) / e0);
  }
  return worst;
}

}  // namespace

// ---------------------------------------------------------------------------
// The single oscillator: the estimate and the integrator's real limit
// ---------------------------------------------------------------------------

TEST(TimeStep, MassOnSpringMatchesTwoOverOmega) {
  const double m = 2.0, k = 50.0;
  EXPECT_DOUBLE_EQ(criticalTimeStep({m}, {k}), 2.0 / std::sqrt(k / m));
  EXPECT_DOUBLE_EQ(criticalTimeStep({m}, {k}), 0.4);
  // The lightest / stiffest particle decides; no stiffness at all: infinity.
  EXPECT_DOUBLE_EQ(criticalTimeStep({8.0, m, 1.0}, {50.0, k, 0.0}), 0.4);
  EXPECT_EQ(criticalTimeStep({1.0}, {0.0}), std::numeric_limits<double>::infinity());
  EXPECT_EQ(criticalTimeStep({}, {}), std::numeric_limits<double>::infinity());
  // Damping lowers the limit: (2 / omega)(sqrt(1 + zeta^2) - zeta), 0.677 at C_res = 0.4.
  EXPECT_NEAR(criticalTimeStep({m}, {k}, 0.4) / 0.4, std::sqrt(1.16) - 0.4, 1e-15);
}

TEST(TimeStep, IntegratorIsStableBelowAndUnstableAboveTheLimit) {
  // Undamped: bounded (leapfrog's amplitude factor 1/sqrt(1 - (w/2)^2)) below, exponential growth above.
  EXPECT_LT(springRun(0.9, 0.0, 20000), 2.5);
  EXPECT_LT(springRun(0.99, 0.0, 20000), 7.2);
  EXPECT_GT(springRun(1.01, 0.0, 2000), 1e6);
  EXPECT_GT(springRun(1.1, 0.0, 2000), 1e6);
  // Damped (zeta = 0.4): decays just below the damped limit, grows just above it.
  double final = 0.0;
  EXPECT_LT(springRun(0.99, 0.4, 5000, &final), 10.0);
  EXPECT_LT(final, 1e-3);
  EXPECT_GT(springRun(1.01, 0.4, 5000), 1e6);
  // ... which is well below the undamped limit: the undamped estimate would be unstable with damping.
  EXPECT_GT(springRun(0.75 / (std::sqrt(1.16) - 0.4), 0.4, 5000), 1e6);
}

// ---------------------------------------------------------------------------
// The stiffest contact of a shape
// ---------------------------------------------------------------------------

// A box on its face, bonded to a wall by the patch's node springs (normal and
// tangential): the estimate's omega_max is the exact limit, rocking and
// shearing modes included.
TEST(TimeStep, BoxOnItsFaceHasTheEstimatedLimit2D) {
  const auto shape = box<2>(Vec<2>(0.5, 0.25), 0.05);
  NodeStiffness law;  // Table 1: kn = 3e7, ks = 0.8 kn
  EXPECT_LT(bondedPatchRun(*shape, law, 0.9, 20000, 1), 10.0);
  EXPECT_LT(bondedPatchRun(*shape, law, 0.98, 20000, 2), 30.0);
  EXPECT_GT(bondedPatchRun(*shape, law, 1.02, 5000, 3), 1e6);
  // Frictionless: the normal mode alone.
  law.tangentialRatio = 0.0;
  EXPECT_LT(bondedPatchRun(*shape, law, 0.98, 20000, 4), 30.0);
  EXPECT_GT(bondedPatchRun(*shape, law, 1.02, 5000, 5), 1e6);
}

TEST(TimeStep, BoxOnItsFaceHasTheEstimatedLimit3D) {
  const auto shape = box<3>(Vec<3>(0.5, 0.35, 0.25), 0.0625);
  NodeStiffness law;
  EXPECT_LT(bondedPatchRun(*shape, law, 0.98, 10000, 6), 30.0);
  EXPECT_GT(bondedPatchRun(*shape, law, 1.02, 5000, 7), 1e6);
}

// The real per-node contact law (unilateral, kn per node, frictionless) under
// gravity: the stiffness of a flat box face resting on a plane, measured from
// its static overlap, is bounded by the estimate (and the bound is tight).
// Undamped bouncing on the face conserves energy at 0.5 dt_crit. (Measured in
// this set-up: stable up to 0.7 dt_crit; from 0.8 dt_crit the unresolved
// impacts of a contact lasting ~3 steps pump energy into rocking: contact
// switching, one of the things the safety factor covers.)
TEST(TimeStep, FlatFaceRestingOnAPlaneIsBoundedByTheEstimate) {
  const auto shape = box<2>(Vec<2>(0.5, 0.25), 0.05);
  NodeStiffness law;
  law.tangentialRatio = 0.0;
  ContactStiffnessOptions options;
  options.particlePairs = false;
  const StiffestContact<2> sc = stiffestContact(*shape, law, options);
  // The stiffest patch is a long face: the normal is +/- the body's y axis.
  EXPECT_NEAR(std::abs(sc.normal[1]), 1.0, 1e-9);
  EXPECT_GE(sc.nodeCount, 20u);

  Particles<2> p;
  ParticleDef<2> def;
  def.shape = shape;
  def.density = 2650;
  def.orientation = sc.normal[1] > 0 ? std::numbers::pi : 0.0;  // the patch face down
  p.add(def);
  const double m = p.mass[0], g = 9.81, kn = law.perNode;
  const auto& X = shape->nodes().positions;
  double lowest = 1e300;
  for (const auto& x : X) lowest = std::min(lowest, (p.rotation(0) * x)[1]);
  p.position[0][1] = -lowest;  // the face touches the plane y = 0

  // Contact: every node below the plane pushes with kn x overlap; optional body damping (rate, 1/s) to settle.
  const auto forces = [&](double damping, double& elastic, int& touching, double& overlapSum) {
    const Mat<2> R = p.rotation(0);
    Vec<2> F(0.0, -m * g);
    double T = 0.0;
    elastic = overlapSum = 0.0;
    touching = 0;
    for (const auto& x : X) {
      const Vec<2> arm = R * x;
      const double overlap = -(p.position[0][1] + arm[1]);
      if (overlap <= 0.0) continue;
      const Vec<2> f(0.0, kn * overlap);
      F += f;
      T += Rotation<2>::moment(arm, f);
      elastic += 0.5 * kn * overlap * overlap;
      overlapSum += overlap;
      ++touching;
    }
    p.force[0] = F - damping * m * p.velocity[0];
    p.torque[0] = T - damping * p.inertia[0] * p.angularVelocity[0];
  };

  // Undamped bouncing on the face at 0.5 dt_crit: the energy stays bounded.
  const double dt = 0.5 * criticalTimeStep({m}, {sc.stiffness});
  double elastic = 0.0, overlapSum = 0.0;
  int touching = 0;
  forces(0.0, elastic, touching, overlapSum);
  const auto energy = [&] { return p.kineticEnergy(0) + m * g * p.position[0][1] + elastic; };
  const double e0 = energy();
  const double eScale = m * g * (m * g / (kn * sc.nodeCount));  // m g x the static overlap
  double drift = 0.0;
  for (int s = 0; s < 20000; ++s) {
    kickDrift(p, dt);
    forces(0.0, elastic, touching, overlapSum);
    kick(p, dt);
    drift = std::max(drift, std::abs(energy() - e0));
  }
  EXPECT_LT(drift, eScale);

  // Settle with damping and measure the static stiffness m g / overlap.
  const double rate = 0.5 * std::sqrt(sc.stiffness / m);  // damping ratio 0.25 of the face mode
  for (int s = 0; s < 20000; ++s) {
    kickDrift(p, dt);
    forces(rate, elastic, touching, overlapSum);
    kick(p, dt);
  }
  ASSERT_GT(touching, 0);
  const double measured = m * g / (overlapSum / touching);
  EXPECT_EQ(std::size_t(touching), sc.nodeCount);
  EXPECT_NEAR(measured, kn * touching, 1e-6 * kn * touching);
  EXPECT_LE(measured, sc.normalStiffness * (1 + 1e-9));
  EXPECT_LE(measured, sc.stiffness);
  EXPECT_GE(measured, 0.999 * sc.normalStiffness);
}

// One node touching a curved body: the stiffest mode is shear with rolling,
// omega^2 = ks (1/m + R^2 / I): k_eff = 2.4 kn for a disc (I = m R^2 / 2),
// 2.8 kn for a sphere (I = 2/5 m R^2), at ks = 0.8 kn; particle pairs double it.
TEST(TimeStep, SingleNodeOnACurvedBody) {
  NodeStiffness law;
  ContactStiffnessOptions options;
  options.maxOverlap = 1e-9;
  options.particlePairs = false;
  const StiffestContact<2> disc = stiffestContact(*sphere<2>(0.5, 12), law, options);
  EXPECT_EQ(disc.nodeCount, 1u);
  EXPECT_NEAR(disc.stiffness / law.perNode, 2.4, 0.05);
  const StiffestContact<3> ball = stiffestContact(*sphere<3>(0.5, 10), law, options);
  EXPECT_EQ(ball.nodeCount, 1u);
  EXPECT_NEAR(ball.stiffness / law.perNode, 2.8, 0.08);
  options.particlePairs = true;
  EXPECT_DOUBLE_EQ(stiffestContact(*sphere<2>(0.5, 12), law, options).stiffness, 2 * disc.stiffness);
  // Deeper overlaps engage more nodes of a curved surface.
  options.maxOverlap = 0.0;
  EXPECT_GT(stiffestContact(*sphere<2>(0.5, 12), law, options).nodeCount, 1u);
}

// Per-node law: the face's stiffness grows with the node density; the
// area-weighted law (k_i = kn w_i / h^(D-1)) keeps it at kn x face length / h.
TEST(TimeStep, NodeDensityPerNodeVersusAreaWeighted) {
  const double h = 0.05, kn = 3e7;
  double perNode1 = 0.0;
  for (double density : {1.0, 2.0, 4.0}) {
    const auto shape = box<2>(Vec<2>(0.5, 0.25), h, density);
    NodeStiffness perNode;
    perNode.perNode = kn;
    NodeStiffness area;
    area.perNode = 0.0;
    area.perWeight = kn / h;
    const StiffestContact<2> a = stiffestContact(*shape, area);
    EXPECT_NEAR(a.normalStiffness, kn * 1.0 / h, 0.05 * kn / h) << density;
    const double k = stiffestContact(*shape, perNode).normalStiffness;
    if (density == 1.0) perNode1 = k;
    EXPECT_NEAR(k / perNode1, density, 0.15 * density) << density;
  }
}

// The Particles overload: each distinct shape once, the minimum over particles.
TEST(TimeStep, ParticlesOverloadTakesTheMinimumOverParticles) {
  const auto disc = sphere<2>(0.1, 10), brick = box<2>(Vec<2>(0.2, 0.1), 0.02);
  Particles<2> p;
  ParticleDef<2> def;
  def.shape = disc;
  def.density = 2650;
  p.add(def);
  def.shape = brick;
  def.density = 500;
  p.add(def);
  def.shape = disc;
  def.density = 4000;
  p.add(def);
  NodeStiffness law;
  const double kDisc = stiffestContact(*disc, law).stiffness, kBrick = stiffestContact(*brick, law).stiffness;
  const double expected = std::min({2 * std::sqrt(p.mass[0] / kDisc), 2 * std::sqrt(p.mass[1] / kBrick),
                                    2 * std::sqrt(p.mass[2] / kDisc)}) *
                          (std::sqrt(1.16) - 0.4);
  EXPECT_DOUBLE_EQ(criticalTimeStep(p, law, 0.4), expected);
}

// ---------------------------------------------------------------------------
// Safety and the user's dt
// ---------------------------------------------------------------------------

TEST(TimeStep, StableStepAndUserCheck) {
  EXPECT_DOUBLE_EQ(stableTimeStep(1e-5), 2e-6);
  EXPECT_DOUBLE_EQ(stableTimeStep(1e-5, 0.5), 5e-6);
  EXPECT_EQ(stableTimeStep(std::numeric_limits<double>::infinity()), std::numeric_limits<double>::infinity());
  EXPECT_NO_THROW(checkUserTimeStep(1.8e-6, 1e-5, false));
  EXPECT_NO_THROW(checkUserTimeStep(5e-6, 1e-5, true));
  try {
    checkUserTimeStep(5e-6, 1e-5, false);
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(),
                 "dt = 5e-06 s exceeds the critical time step 2e-06 s (safety 0.2 of the stability limit 1e-05 s); "
                 "lower it or set force_dt = true");
  }
}

TEST(TimeStep, InvalidInputThrowsOneLineMessages) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const auto expectInvalid = [](auto&& f, const std::string& name) {
    try {
      f();
      ADD_FAILURE() << "no exception for " << name;
    } catch (const std::invalid_argument& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(name), std::string::npos) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    }
  };
  expectInvalid([] { criticalTimeStep({1.0, 2.0}, {1.0}); }, "stiffnesses");
  expectInvalid([] { criticalTimeStep({-1.0}, {1.0}); }, "mass");
  expectInvalid([] { criticalTimeStep({1.0}, {-1.0}); }, "stiffness");
  expectInvalid([&] { criticalTimeStep({1.0}, {nan}); }, "stiffness");
  expectInvalid([] { criticalTimeStep({1.0}, {1.0}, -0.1); }, "dampingRatio");
  expectInvalid([] { stableTimeStep(0.0); }, "critical time step");
  expectInvalid([] { stableTimeStep(1.0, 1.5); }, "safety");
  expectInvalid([] { checkUserTimeStep(0.0, 1.0, false); }, "dt");
  expectInvalid([&] { checkUserTimeStep(nan, 1.0, true); }, "dt");
  const auto shape = sphere<2>(0.5, 8);
  NodeStiffness law;
  law.perNode = -1.0;
  expectInvalid([&] { stiffestContact(*shape, law); }, "perNode");
  law = {};
  law.tangentialRatio = nan;
  expectInvalid([&] { stiffestContact(*shape, law); }, "tangentialRatio");
  law = {};
  law.perNode = 0.0;
  expectInvalid([&] { stiffestContact(*shape, law); }, "perNode");
  ContactStiffnessOptions options;
  options.maxOverlap = -1.0;
  expectInvalid([&] { stiffestContact(*shape, NodeStiffness{}, options); }, "maxOverlap");
}
