/// @file test_contact_law.cpp
/// @brief The contact law's parts: parameter checks and closed forms, Coulomb
/// friction with shear history (a block on an incline sticks below the
/// friction angle and slides with a = g (sin - mu cos) above it, dissipating
/// mu N v), the tangential spring, and the area-weighted formulation's
/// independence of the node density.

#include "lsdem/dynamics/ContactLaw.h"
#include "lsdem/dynamics/Integrator.h"
#include "lsdem/dynamics/NarrowPhase.h"
#include "lsdem/dynamics/World.h"
#include "lsdem/geometry/ShapeDef.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <string>
#include <utility>

using namespace lsdem;
using namespace lsdem::dynamics;

namespace {

constexpr double kGravity = 9.81;

// Expects `law` to be rejected with a message naming `name`.
void expectRejected(const ContactLawDef& law, const std::string& name) {
  try {
    validateContactLaw(law);
    ADD_FAILURE() << "accepted a bad " << name;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
  }
}

// A block: half extents 0.2 x 0.1 (x 0.15) m, 10 (2D) or 8 (3D) cells across
// its smallest dimension.
template <int D>
std::shared_ptr<const geometry::Shape<D>> block(double nodesPerCell) {
  geometry::ShapeDef<D> def;
  def.kind = geometry::ShapeKind::Box;
  if constexpr (D == 2) {
    def.halfExtents = Vec<2>(0.2, 0.1);
    def.cellsAcross = 10;
  } else {
    def.halfExtents = Vec<3>(0.2, 0.1, 0.15);
    def.cellsAcross = 8;
  }
  def.options.nodesPerCell = nodesPerCell;
  return geometry::buildShape(def);
}

// The orientation putting the block's -y face (in its grid frame) flat on a
// plane of normal +y: body vector u = bodyToGrid^T (-y) turned onto world -y.
template <int D>
Orientation<D> faceDown(const geometry::Shape<D>& shape) {
  const Vec<D> u = shape.bodyToGrid().rotation.transpose() * Vec<D>(-Vec<D>::UnitY());
  if constexpr (D == 2) {
    return -0.5 * std::numbers::pi - std::atan2(u[1], u[0]);
  } else {
    return Eigen::Quaterniond::FromTwoVectors(u, -Vec<3>::UnitY());
  }
}

// One step with a constant body force (gravity) on every particle.
template <int D>
void step(Particles<D>& p, ContactSolver<D>& solver, const std::vector<Plane<D>>& planes, const Vec<D>& gravity,
          double dt) {
  kickDrift(p, dt);
  for (std::size_t i = 0; i < p.size(); ++i) {
    p.force[i] = p.mass[i] * gravity;
    p.torque[i] = Rotation<D>::zeroSpin();
  }
  solver.compute(p, {}, planes, {}, dt);
  solver.accumulate(p);
  kick(p, dt);
}

struct InclineResult {
  double displacement = 0.0;      // m, along the slope after 1 s
  double speed = 0.0;             // m/s, along the slope after 1 s
  double acceleration = 0.0;      // m/s^2, (v(1 s) - v(0.5 s)) / 0.5 s
  double dissipatedPower = 0.0;   // W, at 1 s
  double energyError = 0.0;       // J, kinetic + potential + elastic + dissipated, change over 1 s
  double dissipated = 0.0;        // J, dissipated over 1 s
};

// A block resting on the plane y = 0 under gravity tilted by theta (the
// incline's frame: x down the slope, y its normal), for 1 s. The stiffness is
// scaled to a contact period of ~4 ms (3D blocks have ~300 nodes on a face).
// With `wallMu`, the incline is a wall of its own material of that friction
// (and the grains' stiffness).
template <int D>
InclineResult incline(double theta, double mu, std::optional<double> wallMu = std::nullopt) {
  const auto shape = block<D>(1.0);
  ContactLawDef law;
  law.kn = D == 2 ? 3e7 : 3e5;
  law.ks = 0.8 * law.kn;
  law.friction = mu;
  law.dampingRatio = 0.4;
  ContactSolver<D> solver(law);
  if (wallMu) {
    BoundaryMaterial wall;
    wall.kn = law.kn;
    wall.friction = *wallMu;
    solver.setPlaneMaterial(0, wall);
  }
  Particles<D> p;
  ParticleDef<D> def;
  def.shape = shape;
  def.orientation = faceDown(*shape);
  def.position = 0.1 * Vec<D>::UnitY();
  p.add(def);
  const std::vector<Plane<D>> planes{Plane<D>{Vec<D>::Zero(), Vec<D>::UnitY(), Vec<D>::Zero()}};
  Vec<D> gravity = Vec<D>::Zero();
  gravity[0] = kGravity * std::sin(theta);
  gravity[1] = -kGravity * std::cos(theta);

  // Integrate 1 s, keeping the energy books: E = kinetic + potential + elastic + dissipated.
  const double dt = 2e-5;
  const auto energy = [&] { return p.kineticEnergy(0) - p.mass[0] * gravity.dot(p.position[0]) + solver.elasticEnergy(); };
  InclineResult r;
  const Vec<D> x0 = p.position[0];
  double e0 = 0.0, speedHalf = 0.0;
  const int steps = int(std::lround(1.0 / dt));
  for (int s = 0; s < steps; ++s) {
    step<D>(p, solver, planes, gravity, dt);
    if (s == 0) {
      e0 = energy();
    } else {
      r.dissipated += dt * solver.dissipatedPower();
    }
    if (s + 1 == steps / 2) speedHalf = p.velocity[0][0];
  }
  r.displacement = p.position[0][0] - x0[0];
  r.speed = p.velocity[0][0];
  r.acceleration = (r.speed - speedHalf) / 0.5;
  r.dissipatedPower = solver.dissipatedPower();
  r.energyError = energy() + r.dissipated - e0;
  return r;
}

// Total normal stiffness of the block's flat face pressed on a plane, from the
// force at two overlaps (1e-7 and 2e-7 cells: only the nodes of the face
// touch, not those rounding its edges), and the nodes touching.
template <int D>
std::pair<double, std::size_t> faceStiffness(const std::shared_ptr<const geometry::Shape<D>>& shape,
                                             ForceFormulation formulation) {
  ContactLawDef law;
  law.formulation = formulation;
  law.hasFriction = false;
  law.hasDamping = false;
  ContactSolver<D> solver(law);
  Particles<D> p;
  ParticleDef<D> def;
  def.shape = shape;
  def.orientation = faceDown(*shape);
  p.add(def);
  const std::vector<Plane<D>> planes{Plane<D>{Vec<D>::Zero(), Vec<D>::UnitY(), Vec<D>::Zero()}};
  const double h = shape->grid().spacing();
  double force[2];
  std::size_t nodes[2];
  for (int k = 0; k < 2; ++k) {
    p.position[0] = (0.1 - 1e-7 * h * (k + 1)) * Vec<D>::UnitY();
    solver.compute(p, {}, planes, {}, 1e-5);
    EXPECT_EQ(solver.pairContacts().size(), 1u);
    force[k] = solver.pairContacts()[0].force[1];
    nodes[k] = solver.pairContacts()[0].nodeCount;
  }
  EXPECT_EQ(nodes[0], nodes[1]);
  return {(force[1] - force[0]) / (1e-7 * h), nodes[1]};
}

template <int D>
void checkAreaWeighted() {
  double areaK[3], perNodeK[3];
  std::size_t count[3];
  const double densities[3] = {1.0, 2.0, 4.0};
  for (int k = 0; k < 3; ++k) {
    const auto shape = block<D>(densities[k]);
    std::tie(areaK[k], count[k]) = faceStiffness<D>(shape, ForceFormulation::AreaWeighted);
    perNodeK[k] = faceStiffness<D>(shape, ForceFormulation::PerNode).first;
    // PerNode: every touching node carries kn.
    EXPECT_NEAR(perNodeK[k], 3e7 * double(count[k]), 1e-5 * perNodeK[k]);
  }
  for (int k = 1; k < 3; ++k) {
    // AreaWeighted: the face keeps its stiffness.
    EXPECT_NEAR(areaK[k], areaK[0], 0.05 * areaK[0]) << "density " << densities[k];
    // PerNode: grows like the node count, ~ density^(D-1).
    const double growth = std::pow(densities[k], D - 1);
    EXPECT_NEAR(perNodeK[k] / perNodeK[0], growth, 0.15 * growth) << "density " << densities[k];
  }
  // At 1 node per cell the two formulations agree (to the spread of node areas).
  EXPECT_NEAR(areaK[0], perNodeK[0], 0.1 * perNodeK[0]);
  // AreaWeighted is kn per reference node weight: K = kn x (face length / area) / w_ref.
  const double face = D == 2 ? 0.4 : 0.4 * 0.3;
  const double kExpected = 3e7 * face / referenceNodeWeight<D>(block<D>(1.0)->grid().spacing());
  EXPECT_NEAR(areaK[0], kExpected, 0.06 * kExpected);
}

}  // namespace

TEST(ContactLaw, RejectsBadParameters) {
  const ContactLawDef good;
  EXPECT_NO_THROW(validateContactLaw(good));
  ContactLawDef law = good;
  law.kn = 0.0;
  expectRejected(law, "kn");
  law = good;
  law.kn = std::numeric_limits<double>::quiet_NaN();
  expectRejected(law, "kn");
  law = good;
  law.ks = -1.0;
  expectRejected(law, "ks");
  law = good;
  law.friction = -0.1;
  expectRejected(law, "friction");
  law = good;
  law.frictionFrom = -1e-3;
  expectRejected(law, "friction_from");
  law = good;
  law.frictionFrom = std::numeric_limits<double>::infinity();
  expectRejected(law, "friction_from");
  law = good;
  law.dampingRatio = 1.0;
  expectRejected(law, "dampingRatio");
  law = good;
  law.dampingRatio = -0.1;
  expectRejected(law, "dampingRatio");
  law = good;
  law.normal = NormalModel::Hertz;
  expectRejected(law, "youngsModulus");  // E = 0 by default
  law.youngsModulus = 1e9;
  EXPECT_NO_THROW(validateContactLaw(law));
  law.poissonRatio = 0.5;
  expectRejected(law, "poissonRatio");
  // The solver checks its law and its inputs.
  law = good;
  law.ks = -1.0;
  EXPECT_THROW(ContactSolver<2>{law}, std::invalid_argument);
  ContactSolver<2> solver(good);
  Particles<2> p;
  EXPECT_THROW(solver.compute(p, {}, {}, {}, 0.0), std::invalid_argument);
  EXPECT_THROW(solver.compute(p, {}, {}, {}, std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
  const std::vector<Plane<2>> bad{Plane<2>{Vec<2>::Zero(), Vec<2>(0.0, 2.0), Vec<2>::Zero()}};
  EXPECT_THROW(solver.compute(p, {}, bad, {}, 1e-5), std::invalid_argument);
  const std::vector<ToolPose<2>> noShape(1);
  EXPECT_THROW(solver.compute(p, {}, {}, noShape, 1e-5), std::invalid_argument);
}

namespace {

// The clipped linear spring-dashpot integrated directly (RK4, omega = 1, v0 = 1):
// x'' = min(0, -(x + 2 zeta x')) while x > 0; returns the exit speed and the
// time from touch to parting.
std::pair<double, double> clippedOscillator(double zeta) {
  const auto accel = [zeta](double x, double v) { return std::min(0.0, -(x + 2.0 * zeta * v)); };
  const double h = 1e-5;
  double x = 0.0, v = 1.0, t = 0.0;
  while (true) {
    const double k1x = v, k1v = accel(x, v);
    const double k2x = v + 0.5 * h * k1v, k2v = accel(x + 0.5 * h * k1x, v + 0.5 * h * k1v);
    const double k3x = v + 0.5 * h * k2v, k3v = accel(x + 0.5 * h * k2x, v + 0.5 * h * k2v);
    const double k4x = v + h * k3v, k4v = accel(x + h * k3x, v + h * k3v);
    const double xn = x + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
    const double vn = v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
    if (t > 0.0 && xn <= 0.0) return {-vn, t + h * x / (x - xn)};
    x = xn;
    v = vn;
    t += h;
  }
}

}  // namespace

TEST(ContactLaw, ClosedForms) {
  // Restitution and contact duration of the clipped law against its direct
  // integration; e(0) = 1; restitution and damping ratio are inverse.
  EXPECT_DOUBLE_EQ(restitutionCoefficient(0.0), 1.0);
  for (const double zeta : {0.1, 0.4, 0.8}) {
    const auto [e, duration] = clippedOscillator(zeta);
    EXPECT_NEAR(restitutionCoefficient(zeta), e, 1e-6) << zeta;
    EXPECT_NEAR(contactDuration(zeta, 1.0), duration, 1e-5) << zeta;
  }
  // The clip matters: at the paper's C_res = 0.4 the unclipped law would give 0.254.
  EXPECT_NEAR(restitutionCoefficient(0.4), 0.36353, 1e-5);
  EXPECT_NEAR(restitutionCoefficient(0.999999), std::exp(-2.0), 1e-2);
  for (const double zeta : {0.05, 0.4, 0.9}) {
    EXPECT_NEAR(dampingRatioForRestitution(restitutionCoefficient(zeta)), zeta, 1e-12);
  }
  EXPECT_DOUBLE_EQ(dampingRatioForRestitution(1.0), 0.0);
  EXPECT_THROW(dampingRatioForRestitution(0.0), std::invalid_argument);
  EXPECT_THROW(dampingRatioForRestitution(0.13), std::invalid_argument);  // below exp(-2): out of reach
  // Hertz: E* = E / (2 (1 - nu^2)); F and dF/ddelta at a known point.
  ContactLawDef law;
  law.youngsModulus = 2e9;
  law.poissonRatio = 0.5 * std::sqrt(2.0);  // 1 - nu^2 = 1/2 (the formula, not the validator)
  EXPECT_NEAR(effectiveModulus(law), 2e9, 1e-3);
  EXPECT_NEAR(hertzForce(3.0, 4.0, 0.25), 4.0 / 3.0 * 3.0 * 2.0 * 0.125, 1e-15);
  EXPECT_NEAR(hertzStiffness(3.0, 4.0, 0.25), 2.0 * 3.0 * 1.0, 1e-15);
  EXPECT_EQ(hertzForce(3.0, 4.0, -1.0), 0.0);
  // Equal-volume radii; a plane is an infinite radius.
  EXPECT_NEAR(equivalentRadius<2>(std::numbers::pi * 0.25), 0.5, 1e-15);
  EXPECT_NEAR(equivalentRadius<3>(4.0 / 3.0 * std::numbers::pi * 8.0), 2.0, 1e-14);
  EXPECT_DOUBLE_EQ(combinedRadius(2.0, std::numeric_limits<double>::infinity()), 2.0);
  EXPECT_DOUBLE_EQ(combinedRadius(2.0, 2.0), 1.0);
  EXPECT_DOUBLE_EQ(dampingCoefficient(0.5, 4.0, 9.0), 6.0);
  EXPECT_DOUBLE_EQ(referenceNodeWeight<2>(0.1), 0.1);
  EXPECT_DOUBLE_EQ(referenceNodeWeight<3>(0.1), kNodeAreaPerCellArea3D * 0.01);
}

// Below the friction angle (tan theta = mu / 2) the block holds: after 1 s it
// has moved by its shear springs' deflection only (~1 um; sliding freely it
// would have gone 1.4 m).
TEST(ContactLaw, BlockSticksBelowFrictionAngle2D) {
  const InclineResult r = incline<2>(std::atan(0.3), 0.6);
  EXPECT_LT(std::abs(r.displacement), 1e-5);
  EXPECT_LT(std::abs(r.speed), 1e-4);
}
TEST(ContactLaw, BlockSticksBelowFrictionAngle3D) {
  const InclineResult r = incline<3>(std::atan(0.3), 0.6);
  EXPECT_LT(std::abs(r.displacement), 1e-4);
  EXPECT_LT(std::abs(r.speed), 1e-3);
}

// Above it (tan theta = 1.5 mu) the block slides with a = g (sin theta -
// mu cos theta), friction dissipates mu N v, and kinetic + potential + elastic
// energy plus the reported dissipation stays constant.
template <int D>
void checkSliding(bool onWallMaterial) {
  // On a wall of its own material, the wall's mu counts, not the grains'.
  const double mu = 0.6, theta = std::atan(1.5 * mu);
  const InclineResult r = onWallMaterial ? incline<D>(theta, 0.95, mu) : incline<D>(theta, mu);
  const double a = kGravity * (std::sin(theta) - mu * std::cos(theta));
  EXPECT_NEAR(r.acceleration, a, 0.03 * a);
  EXPECT_NEAR(r.speed, a * 1.0, 0.05 * a);
  const double mass = 2650.0 * block<D>(1.0)->volume();
  const double frictionPower = mu * mass * kGravity * std::cos(theta) * r.speed;
  EXPECT_NEAR(r.dissipatedPower, frictionPower, 0.03 * frictionPower);
  EXPECT_LT(std::abs(r.energyError), 0.01 * r.dissipated);
}
TEST(ContactLaw, BlockSlidesAboveFrictionAngle2D) { checkSliding<2>(false); }
TEST(ContactLaw, BlockSlidesAboveFrictionAngle3D) { checkSliding<3>(false); }
TEST(ContactLaw, BlockSlidesOnAWallOfLowerFriction2D) { checkSliding<2>(true); }
TEST(ContactLaw, BlockHoldsOnAWallOfHigherFriction2D) {
  // Grains of mu 0.1 would slide at tan theta = 0.3; the wall's 0.6 holds them.
  const InclineResult r = incline<2>(std::atan(0.3), 0.1, 0.6);
  EXPECT_LT(std::abs(r.displacement), 1e-5);
}

// A wall's own material: the constants of its contacts (Hertz: compliances
// add, a rigid wall has none; linear: its own kn and ks, a rigid wall 2 kn and
// 2 ks), and the checks.
TEST(ContactLaw, BoundaryMaterialConstants) {
  ContactLawDef hertz;
  hertz.normal = NormalModel::Hertz;
  hertz.tangential = TangentialModel::Mindlin;
  hertz.youngsModulus = 70e9;
  hertz.poissonRatio = 0.25;
  hertz.friction = 0.3;
  const double g = 70e9 / 2.5;
  const ContactConstants grains = lawConstants(hertz);
  EXPECT_NEAR(grains.eStar, 70e9 / (2.0 * 0.9375), 1e-3);
  EXPECT_NEAR(grains.gStar, g / (2.0 * 1.75), 1e-3);
  EXPECT_EQ(grains.ks, 0.0);  // Mindlin's spring replaces ks
  BoundaryMaterial rigid;
  rigid.rigid = true;
  ContactConstants c = boundaryConstants(hertz, rigid);
  EXPECT_NEAR(c.eStar, 70e9 / 0.9375, 1e-3);  // twice the grains' E*
  EXPECT_NEAR(c.gStar, g / 1.75, 1e-3);
  EXPECT_EQ(c.friction, 0.3);
  BoundaryMaterial steel;
  steel.youngsModulus = 210e9;
  steel.poissonRatio = 0.3;
  steel.friction = 0.5;
  c = boundaryConstants(hertz, steel);
  EXPECT_NEAR(c.eStar, 1.0 / (0.9375 / 70e9 + 0.91 / 210e9), 1e-3);
  EXPECT_NEAR(c.gStar, 1.0 / (1.75 / g + 1.7 / (210e9 / 2.6)), 1e-3);
  EXPECT_EQ(c.friction, 0.5);
  EXPECT_NEAR(mindlinStiffness(2.0, 4.0, 0.25), 8.0 * 2.0 * 1.0, 1e-15);

  ContactLawDef linear;
  linear.kn = 1e6;
  linear.ks = 5e5;
  c = boundaryConstants(linear, rigid);
  EXPECT_EQ(c.kn, 2e6);
  EXPECT_EQ(c.ks, 1e6);
  BoundaryMaterial wall;
  wall.kn = 4e6;
  c = boundaryConstants(linear, wall);
  EXPECT_EQ(c.kn, 4e6);
  EXPECT_EQ(c.ks, 2e6);  // the grains' ks / kn
  wall.ks = 1e5;
  EXPECT_EQ(boundaryConstants(linear, wall).ks, 1e5);

  // Refused: a wall without its stiffness, friction on a frictionless law, Mindlin ks.
  EXPECT_THROW(boundaryConstants(linear, BoundaryMaterial{}), std::invalid_argument);
  EXPECT_THROW(boundaryConstants(hertz, BoundaryMaterial{}), std::invalid_argument);
  BoundaryMaterial slippery = rigid;
  slippery.friction = 0.2;
  ContactLawDef frictionless = linear;
  frictionless.hasFriction = false;
  EXPECT_THROW(boundaryConstants(frictionless, slippery), std::invalid_argument);
  BoundaryMaterial withKs = rigid;
  withKs.ks = 1e5;
  EXPECT_THROW(boundaryConstants(hertz, withKs), std::invalid_argument);
  ContactLawDef mindlinLinear = linear;
  mindlinLinear.tangential = TangentialModel::Mindlin;
  EXPECT_THROW(validateContactLaw(mindlinLinear), std::invalid_argument);
}

// The tangential spring: a sphere pressed on a plane and moved sideways at
// constant speed carries F_t = -ks s per node (s = v t accumulated in the
// history) until |F_t| reaches mu F_n, then slides at the cap; the history is
// dropped once the node leaves the plane.
TEST(ContactLaw, ShearSpringAndCoulombCap) {
  geometry::ShapeDef<2> def;
  def.kind = geometry::ShapeKind::Sphere;
  def.radius = 0.5;
  def.cellsAcross = 10;
  def.options.nodesPerCell = 1.0;
  const auto shape = geometry::buildShape(def);
  // Put node 0 at the bottom, 0.1 mm into the plane y = 0.
  const Vec<2> xb = shape->nodes().positions[0];
  Particles<2> p;
  ParticleDef<2> pd;
  pd.shape = shape;
  pd.orientation = -0.5 * std::numbers::pi - std::atan2(xb[1], xb[0]);
  pd.position = Vec<2>(0.0, xb.norm() - 1e-4);
  pd.velocity = Vec<2>(0.01, 0.0);
  p.add(pd);
  ContactLawDef law;
  law.hasDamping = false;
  law.friction = 0.5;
  ContactSolver<2> solver(law);
  const std::vector<Plane<2>> planes{Plane<2>{Vec<2>::Zero(), Vec<2>::UnitY(), Vec<2>::Zero()}};
  const double dt = 1e-5, fn = law.kn * 1e-4;
  // Stick: the shear grows by v dt per step (the body is held in place: no integration).
  for (int s = 1; s <= 10; ++s) {
    solver.compute(p, {}, planes, {}, dt);
    ASSERT_EQ(solver.nodeContacts().size(), 1u);
    const NodeContact<2>& c = solver.nodeContacts()[0];
    const double shear = 0.01 * dt * s;
    const double ft = std::min(law.ks * shear, law.friction * fn);
    EXPECT_NEAR(c.force[0], -ft, 1e-9 * fn) << "step " << s;
    EXPECT_NEAR(c.force[1], fn, 1e-9 * fn);
    EXPECT_NEAR(solver.nodeShear()[0][0], ft / law.ks, 1e-15);
  }
  // Slide: a faster motion takes the force to the cap and dissipates mu F_n |v_t|.
  p.velocity[0] = Vec<2>(10.0, 0.0);
  solver.compute(p, {}, planes, {}, dt);
  EXPECT_NEAR(solver.nodeContacts()[0].force[0], -law.friction * fn, 1e-9 * fn);
  EXPECT_NEAR(solver.nodeShear()[0][0], law.friction * fn / law.ks, 1e-15);
  EXPECT_GT(solver.dissipatedPower(), 0.0);
  EXPECT_NEAR(solver.elasticEnergy(), 0.5 * law.kn * 1e-8 + std::pow(law.friction * fn, 2) / (2.0 * law.ks),
              1e-9 * fn * 1e-4);
  EXPECT_EQ(solver.historySize(), 1u);
  // Lift off: the history is dropped; touching again starts from zero shear.
  p.position[0][1] += 2e-4;
  solver.compute(p, {}, planes, {}, dt);
  EXPECT_TRUE(solver.nodeContacts().empty());
  EXPECT_EQ(solver.historySize(), 0u);
  p.position[0][1] -= 2e-4;
  p.velocity[0] = Vec<2>(0.01, 0.0);
  solver.compute(p, {}, planes, {}, dt);
  EXPECT_NEAR(solver.nodeShear()[0][0], 0.01 * dt, 1e-15);
}

TEST(ContactLaw, AreaWeightedStiffnessIndependentOfNodeDensity2D) { checkAreaWeighted<2>(); }
TEST(ContactLaw, AreaWeightedStiffnessIndependentOfNodeDensity3D) { checkAreaWeighted<3>(); }

// Friction from a given time (ContactLawDef::frictionFrom): a block sliding
// on a floor keeps its speed exactly while the law is frictionless (no
// tangential force, no shear history), then slows at mu g, booking the
// friction's dissipation, from the time friction acts.
template <int D>
void checkFrictionFrom() {
  const double mu = 0.3, v0 = 1.0, from = 0.2;
  WorldDef<D> def;
  def.gravity = -kGravity * Vec<D>::UnitY();
  def.contact.kn = D == 2 ? 3e7 : 3e5;
  def.contact.ks = 0.8 * def.contact.kn;
  def.contact.friction = mu;
  def.contact.frictionFrom = from;
  def.contact.hasDamping = true;
  def.contact.dampingRatio = 0.4;
  def.dt = 2e-5;
  World<D> w(def);
  PlaneDef<D> floor;
  floor.plane.point = Vec<D>::Zero();
  floor.plane.normal = Vec<D>::UnitY();
  w.addPlane(floor);
  ParticleDef<D> p;
  p.shape = block<D>(1.0);
  p.orientation = faceDown(*p.shape);
  p.position = 0.1 * Vec<D>::UnitY();
  p.velocity = v0 * Vec<D>::UnitX();
  w.addParticle(p);
  w.run(std::uint64_t(std::lround(0.1 / def.dt)));  // settled on the floor, still frictionless
  EXPECT_EQ(w.particles().velocity[0][0], v0);
  w.run(std::uint64_t(std::lround(0.1 / def.dt)) - 1);  // the last frictionless step ends at t = from
  EXPECT_EQ(w.particles().velocity[0][0], v0);
  const double lossBefore = w.energy().contactLoss;
  w.run(std::uint64_t(std::lround(0.1 / def.dt)) + 1);  // t = from + 0.1 s
  const double dv = mu * kGravity * 0.1;
  EXPECT_NEAR(w.particles().velocity[0][0], v0 - dv, 0.02 * dv);
  // Sliding friction dissipates mu m g times the distance slid.
  const double slid = (v0 - 0.5 * dv) * 0.1;
  const double frictionWork = mu * w.particles().mass[0] * kGravity * slid;
  EXPECT_NEAR(w.energy().contactLoss - lossBefore, frictionWork, 0.03 * frictionWork);
}
TEST(ContactLaw, FrictionActsFromItsStartTime2D) { checkFrictionFrom<2>(); }
TEST(ContactLaw, FrictionActsFromItsStartTime3D) { checkFrictionFrom<3>(); }
