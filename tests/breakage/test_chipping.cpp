#include "support/Shapes.h"
#include "lsdem/breakage/Breakage.h"
#include "lsdem/breakage/Chipping.h"

#include "lsdem/dynamics/World.h"
#include "lsdem/geometry/ShapeDef.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>

using namespace lsdem;
using namespace lsdem::breakage;
using dynamics::ParticleDef;
using dynamics::PlaneDef;
using dynamics::World;
using dynamics::WorldDef;
using geometry::Mat;
using geometry::Vec;

namespace {

template <int D>
void addPlane(World<D>& w, const Vec<D>& point, const Vec<D>& normal, const Vec<D>& velocity = Vec<D>::Zero()) {
  PlaneDef<D> p;
  p.plane.point = point;
  p.plane.normal = normal;
  p.plane.velocity = velocity;
  w.addPlane(p);
}

template <int D>
std::size_t indexOf(const dynamics::Particles<D>& p, std::uint64_t id) {
  return std::size_t(std::find(p.id.begin(), p.id.end(), id) - p.id.begin());
}

}  // namespace

// Depth rules (Chipping.h): a fraction of the local radius, or a multiple of
// the Hertz contact radius, capped at maxDepthFraction r.
TEST(Chipping, DepthRules) {
  ChippingDef def;
  def.depthFraction = 0.2;
  def.maxDepthFraction = 0.3;
  EXPECT_DOUBLE_EQ(chipDepth<3>(def, 5.0, 0.01), 0.002);
  EXPECT_DOUBLE_EQ(chipDepth<2>(def, 5.0, 0.01), 0.002);
  EXPECT_EQ(chipDepth<3>(def, 0.0, 0.01), 0.0);
  EXPECT_EQ(chipDepth<3>(def, 5.0, -0.01), 0.0);

  def.depth = ChipDepthMode::Hertz;
  def.youngsModulus = 60e9;
  def.poissonRatio = 0.2;
  def.hertzFactor = 2.0;
  const double eStar = 60e9 / (1.0 - 0.04);
  // 3D: a = (3 F r / 4 E*)^(1/3); F = 1 kN on r = 1 cm.
  const double a3 = std::cbrt(3.0 * 1e3 * 0.01 / (4.0 * eStar));
  EXPECT_NEAR(chipDepth<3>(def, 1e3, 0.01), 2.0 * a3, 1e-15);
  // 2D line contact: a = (4 F r / (pi E*))^(1/2), F per unit thickness.
  const double a2 = std::sqrt(4.0 * 1e5 * 0.01 / (std::numbers::pi * eStar));
  EXPECT_NEAR(chipDepth<2>(def, 1e5, 0.01), 2.0 * a2, 1e-15);
  // The cap: a huge force chips at most 0.3 r.
  EXPECT_DOUBLE_EQ(chipDepth<3>(def, 1e15, 0.01), 0.003);
}

// Strengths: eq. 12 at the chip's depth; one number per (seed, grain,
// partner); smaller chips are stronger (size effect).
TEST(Chipping, StrengthIsKeyedAndSizeDependent) {
  ChippingDef def;
  def.weibull = {1e8, 1e-3, 3.0};
  const std::uint64_t plane0 = contactPartnerKey(PartnerKind::Plane, 0);
  const std::uint64_t grain7 = contactPartnerKey(PartnerKind::Particle, 7);
  const double u = chipUniform(5, 42, plane0);
  EXPECT_EQ(u, chipUniform(5, 42, plane0));
  EXPECT_NE(u, chipUniform(5, 42, grain7));
  EXPECT_NE(u, chipUniform(5, 43, plane0));
  EXPECT_NE(u, chipUniform(6, 42, plane0));
  // Not the grain's own strength stream.
  EXPECT_NE(u, keyedUniform(5, 42));
  EXPECT_DOUBLE_EQ(chipStrength(def, 1e-3, u), 1e8 * std::pow(-std::log1p(-u), 1.0 / 3.0));
  // Half the depth: 2^(3/m) = 2 times the strength at m = 3.
  EXPECT_NEAR(chipStrength(def, 0.5e-3, u) / chipStrength(def, 1e-3, u), 2.0, 1e-12);
  EXPECT_NE(contactPartnerKey(PartnerKind::Plane, 3), contactPartnerKey(PartnerKind::Tool, 3));
  EXPECT_NE(contactPartnerKey(PartnerKind::Plane, 3), contactPartnerKey(PartnerKind::Particle, 3));
}

// The cap a plane cuts: a corner's width is a few depths, a face's is the face.
TEST(Chipping, CapWidthTellsACornerFromAFace) {
  geometry::ShapeDef<2> sd;
  sd.kind = geometry::ShapeKind::Box;
  sd.halfExtents = Vec<2>(0.01, 0.01);
  sd.cellsAcross = 40;
  sd.options.nodesPerCell = 2.0;
  const auto square = geometry::buildShape(sd);
  const Mat<2> r = square->bodyToGrid().rotation.transpose();  // world = the square's own axes
  const Vec<2> x = r * square->bodyToGrid().applyInverse(Vec<2>::Zero());
  // A corner cut 2 mm deep along the diagonal: the cap is the triangle of
  // hypotenuse 2 x 2 mm = 4 mm; a face cut 1 mm deep: the whole 20 mm side.
  const Vec<2> diagonal = Vec<2>(1.0, 1.0).normalized();
  const double corner = capWidth<2>(*square, r, x, diagonal, diagonal.dot(Vec<2>(0.01, 0.01) + x) - 0.002);
  const double face = capWidth<2>(*square, r, x, Vec<2>::UnitY(), x[1] + 0.009);
  const double h = square->grid().spacing();
  EXPECT_NEAR(corner, 0.004, 2.0 * h);
  EXPECT_NEAR(face, 0.02, 2.0 * h);
  EXPECT_EQ(capWidth<2>(*square, r, x, Vec<2>::UnitY(), x[1] + 0.02), 0.0);  // the plane misses it
  // 3D: a sphere cut at a tenth of its radius: 2 sqrt(2 R d - d^2) = 0.87 R.
  const auto ball = test::sphereShape<3>(0.01, 30);
  const double cap = capWidth<3>(*ball, Mat<3>::Identity(), Vec<3>::Zero(), Vec<3>::UnitZ(), 0.009);
  EXPECT_NEAR(cap, 2.0 * std::sqrt(2.0 * 0.01 * 0.001 - 1e-6), 1.5 * ball->grid().spacing());
}

TEST(Chipping, RejectsBadDefinitions) {
  const auto bad = [](auto change) {
    BreakageDef<3> def;
    def.chipping = ChippingDef{};
    change(*def.chipping);
    EXPECT_THROW(Breakage<3>{def}, std::invalid_argument);
  };
  bad([](ChippingDef& c) { c.depthFraction = 0.0; });
  bad([](ChippingDef& c) { c.depthFraction = 1.0; });
  bad([](ChippingDef& c) { c.maxDepthFraction = 1.5; });
  bad([](ChippingDef& c) { c.minDepthCells = 0.1; });
  bad([](ChippingDef& c) { c.maxWidthToDepth = 0.0; });
  bad([](ChippingDef& c) { c.weibull.modulus = 0.0; });
  bad([](ChippingDef& c) { c.depth = ChipDepthMode::Hertz; });  // no Young's modulus
  bad([](ChippingDef& c) {
    c.depth = ChipDepthMode::Hertz;
    c.youngsModulus = 1e9;
    c.poissonRatio = 0.5;
  });
}

namespace {

// A cube 2 cm across, 24 cells, dropped corner first onto a floor (no
// gravity: it hits at 0.5 m/s). Splitting never fails (its strength is out
// of reach); chips at depth 0.25 r, and a chip is too small to break again.
struct CornerDrop {
  std::shared_ptr<const geometry::Shape<3>> cube;
  Vec<3> corner = Vec<3>::Zero();  // the corner pointing down, body frame
  std::unique_ptr<World<3>> world;
  Breakage<3>* breakage = nullptr;
  double initialMass = 0.0;
  // The cube's pose at the start of the step that chipped it.
  Mat<3> rotation = Mat<3>::Identity();
  Vec<3> position = Vec<3>::Zero();
  Vec<3> velocity = Vec<3>::Zero();
  double dt = 0.0;
};

enum class Chips { Off, On, OutOfReach };

CornerDrop dropCube(Chips chips) {
  CornerDrop s;
  const double a = 0.01;
  geometry::ShapeDef<3> sd;
  sd.kind = geometry::ShapeKind::Box;
  sd.halfExtents = Vec<3>::Constant(a);
  sd.cellsAcross = 24;
  sd.options.nodesPerCell = 1.0;
  s.cube = geometry::buildShape(sd);
  s.corner = s.cube->bodyToGrid().applyInverse(Vec<3>::Constant(a));

  WorldDef<3> def;
  def.contact.kn = 2e5;
  def.contact.ks = 1.6e5;
  def.checkFinite = true;
  s.world = std::make_unique<World<3>>(def);
  addPlane<3>(*s.world, Vec<3>::Zero(), Vec<3>::UnitY());

  // The corner straight down, just above the floor.
  ParticleDef<3> p;
  p.shape = s.cube;
  p.density = 2650.0;
  p.orientation = Eigen::Quaterniond::FromTwoVectors(s.corner.normalized(), -Vec<3>::UnitY());
  p.position = Vec<3>(0.0, s.corner.norm() + 0.02 * a, 0.0);
  p.velocity = Vec<3>(0.0, -0.5, 0.0);
  s.world->addParticle(p);

  BreakageDef<3> bdef;
  bdef.weibull.referenceStrength = 1e15;  // no split
  bdef.weibull.referenceDiameter = 2.0 * a;
  bdef.minBreakableVolume = 0.05 * s.cube->volume();  // a chip does not break again
  if (chips != Chips::Off) {
    ChippingDef c;
    c.weibull = {chips == Chips::On ? 2e7 : 1e30, 2e-3, 3.0};
    c.depthFraction = 0.25;
    bdef.chipping = c;
  }
  auto effect = std::make_unique<Breakage<3>>(bdef);
  s.breakage = effect.get();
  s.world->addEffect(std::move(effect));
  s.initialMass = s.world->particleMass();
  return s;
}

}  // namespace

// The corner that is pressed chips off: one chip, one remainder that keeps
// the seven other corners; the chip's volume is the corner tetrahedron the
// prescribed depth cuts; mass is conserved to round-off; sphericity rises.
TEST(Chipping, CubePressedOnACornerLosesThatCornerOnly) {
  CornerDrop s = dropCube(Chips::On);
  World<3>& w = *s.world;
  const Breakage<3>& b = *s.breakage;
  const double h = s.cube->grid().spacing();
  while (b.breakages() == 0 && w.steps() < 20000) {
    const auto& p = w.particles();
    s.rotation = p.rotation(0);
    s.position = p.position[0];
    s.velocity = p.velocity[0];
    w.step();
    const double err = std::abs(w.particleMass() + w.removedMass() - s.initialMass) / s.initialMass;
    ASSERT_LT(err, 1e-13) << "step " << w.steps();
  }
  ASSERT_EQ(b.breakages(), 1u);
  ASSERT_EQ(b.chips(), 1u);
  const BreakageEvent<3>& ev = b.events()[0];
  EXPECT_TRUE(ev.chip);
  EXPECT_EQ(ev.mode(), BreakageMode::Chip);
  EXPECT_STREQ(breakageModeName(ev.mode()), "chip");
  EXPECT_GE(ev.criterionValue, ev.strength);
  EXPECT_NEAR(ev.fragmentMass, ev.parentMass, 1e-14 * ev.parentMass);
  ASSERT_EQ(ev.children.size() + ev.finesVolumes.size(), 2u);  // one chip, one remainder
  ASSERT_EQ(ev.children.size(), 2u);

  // The chip plane is normal to the contact: the pressed corner's direction.
  const Vec<3> down = -Vec<3>::UnitY();
  EXPECT_GT(ev.planeNormal.dot(down), 0.999);
  // Its depth is the prescribed 0.25 r, r the local radius (the contact's tip
  // from the centroid: the corner's distance within the overlap and the
  // nodes' rounding of the corner, a fraction of a cell).
  EXPECT_NEAR(ev.chipDepth, 0.25 * s.corner.norm(), 0.25 * h);

  // The plane in the cube's body frame at the chip (the pose the step moved to).
  const Vec<3> x = s.position + s.velocity * w.dt();
  const Vec<3> nBody = s.rotation.transpose() * ev.planeNormal;
  const double offsetBody = ev.planeOffset - ev.planeNormal.dot(x);
  // The corner tetrahedron it cuts: legs L_k = d / n_k along the three edges,
  // V = d^3 / (6 n_1 n_2 n_3), with n in the box's own (grid) axes.
  const Vec<3> nGrid = s.cube->bodyToGrid().rotation * nBody;
  const double d = nBody.dot(s.corner) - offsetBody;
  EXPECT_NEAR(d, ev.chipDepth, 0.5 * h);
  const double tetra = d * d * d / (6.0 * nGrid[0] * nGrid[1] * nGrid[2]);
  const double chip = std::min(ev.childVolumes[0], ev.childVolumes[1]);
  std::printf("[ chip ] depth %.4g m (%.2f cells; prescribed %.4g), plane %.4g m below the corner, chip %.5g m^3, "
              "corner tetrahedron %.5g m^3 (%+.2f %%)\n",
              ev.chipDepth, ev.chipDepth / h, 0.25 * s.corner.norm(), d, chip, tetra, 100.0 * (chip / tetra - 1.0));
  EXPECT_NEAR(chip, tetra, 0.03 * tetra);

  // The remainder keeps every corner but the pressed one.
  const auto& p = w.particles();
  const std::uint64_t bigger = ev.childVolumes[0] > ev.childVolumes[1] ? ev.children[0] : ev.children[1];
  const std::size_t r = indexOf(p, bigger);
  ASSERT_LT(r, p.size());
  const geometry::Shape<3>& rest = *p.shape[r];
  const Mat<3> toRest = p.rotation(r).transpose();
  int kept = 0;
  for (int k = 0; k < 8; ++k) {
    const Vec<3> sign((k & 1) ? 1.0 : -1.0, (k & 2) ? 1.0 : -1.0, (k & 4) ? 1.0 : -1.0);
    // A point one cell in from the corner on each axis, parent body -> world -> remainder body.
    const Vec<3> inGrid = sign.cwiseProduct(Vec<3>::Constant(0.01 - h));
    const Vec<3> world = x + s.rotation * s.cube->bodyToGrid().applyInverse(inGrid);
    const double phi = rest.value(toRest * (world - p.position[r]));
    if (k == 7) {
      EXPECT_GT(phi, 0.0) << "the pressed corner is gone";
    } else {
      EXPECT_LT(phi, 0.0) << "corner " << k << " is kept";
      kept += phi < 0.0;
    }
  }
  EXPECT_EQ(kept, 7);

  // Sphericity (Wadell, pi^(1/3) (6V)^(2/3) / A) rises: a corner shaved off
  // a cube. Analytic ratio for the tetrahedron of legs L_k: V loses
  // L1 L2 L3 / 6; A loses the three right triangles and gains the cut,
  // (L1 L2 + L2 L3 + L3 L1) / 2 - |(L1 L2, L2 L3, L3 L1)| / 2.
  const Vec<3> legs(d / nGrid[0], d / nGrid[1], d / nGrid[2]);
  const Vec<3> products(legs[0] * legs[1], legs[1] * legs[2], legs[2] * legs[0]);
  const double side = 0.02;
  const double volumeRatio = 1.0 - legs.prod() / 6.0 / std::pow(side, 3);
  const double areaRatio = 1.0 - (0.5 * products.sum() - 0.5 * products.norm()) / (6.0 * side * side);
  const double expected = std::pow(volumeRatio, 2.0 / 3.0) / areaRatio;
  const double before = s.cube->descriptors().circularity;
  const double after = rest.descriptors().circularity;
  std::printf("[ chip ] sphericity of the cube %.4f, of the remainder %.4f (ratio %.4f, analytic %.4f)\n", before,
              after, after / before, expected);
  EXPECT_GT(after, before);
  EXPECT_NEAR(after / before, expected, 0.003);
  // Mass: the store and the removed particles still hold the cube's mass.
  EXPECT_NEAR(w.particleMass() + w.removedMass(), s.initialMass, 1e-14 * s.initialMass);

  // The rebound: no other chip (the cut face meets the chip face to face).
  for (int k = 0; k < 3000; ++k) w.step();
  EXPECT_EQ(b.breakages(), 1u);
  for (const BreakageEvent<3>& e : b.events()) {
    std::printf("[ chip ] event at step time %.4g: parent %llu chip %d p %.4g strength %.4g depth %.4g normal %.3f %.3f %.3f\n",
                e.time, (unsigned long long)e.parent, int(e.chip), e.criterionValue, e.strength, e.chipDepth,
                e.planeNormal[0], e.planeNormal[1], e.planeNormal[2]);
  }
  EXPECT_NEAR(w.particleMass() + w.removedMass(), s.initialMass, 1e-13 * s.initialMass);
}

// 2D: a square dropped corner first loses a triangle of the prescribed
// depth; its area is d^2 / (2 n1 n2) within 3 %, and circularity rises.
TEST(Chipping, SquarePressedOnACornerLosesThatCorner2D) {
  const double a = 0.01;
  geometry::ShapeDef<2> sd;
  sd.kind = geometry::ShapeKind::Box;
  sd.halfExtents = Vec<2>::Constant(a);
  sd.cellsAcross = 40;
  sd.options.nodesPerCell = 1.0;
  const auto square = geometry::buildShape(sd);
  const Vec<2> corner = square->bodyToGrid().applyInverse(Vec<2>::Constant(a));
  WorldDef<2> def;
  def.contact.kn = 2e5;
  def.contact.ks = 1.6e5;
  World<2> w(def);
  addPlane<2>(w, Vec<2>::Zero(), Vec<2>::UnitY());
  ParticleDef<2> p;
  p.shape = square;
  p.density = 2650.0;
  // The corner straight down: turn its direction onto -y.
  p.orientation = std::atan2(-1.0, 0.0) - std::atan2(corner[1], corner[0]);
  p.position = Vec<2>(0.0, corner.norm() + 0.02 * a);
  p.velocity = Vec<2>(0.0, -0.5);
  w.addParticle(p);
  BreakageDef<2> bdef;
  bdef.weibull.referenceStrength = 1e15;
  bdef.weibull.referenceDiameter = 2.0 * a;
  bdef.minBreakableVolume = 0.05 * square->volume();
  ChippingDef c;
  c.weibull = {2e5, 2e-3, 3.0};
  c.depthFraction = 0.2;
  bdef.chipping = c;
  auto effect = std::make_unique<Breakage<2>>(bdef);
  const Breakage<2>& b = *effect;
  w.addEffect(std::move(effect));
  const double mass = w.particleMass();
  Mat<2> rotation = Mat<2>::Identity();
  Vec<2> position = Vec<2>::Zero();
  while (b.breakages() == 0 && w.steps() < 20000) {
    rotation = w.particles().rotation(0);
    position = w.particles().position[0] + w.particles().velocity[0] * w.dt();
    w.step();
  }
  ASSERT_EQ(b.chips(), 1u);
  const BreakageEvent<2>& ev = b.events()[0];
  ASSERT_EQ(ev.childVolumes.size(), 2u);
  EXPECT_NEAR(ev.fragmentMass, ev.parentMass, 1e-14 * ev.parentMass);
  EXPECT_NEAR(w.particleMass() + w.removedMass(), mass, 1e-14 * mass);
  // The plane in the square's own axes; the triangle it cuts off the corner.
  const Vec<2> nBody = rotation.transpose() * ev.planeNormal;
  const Vec<2> nGrid = square->bodyToGrid().rotation * nBody;
  const double d = nBody.dot(corner) - (ev.planeOffset - ev.planeNormal.dot(position));
  const double h = square->grid().spacing();
  EXPECT_NEAR(ev.chipDepth, 0.2 * corner.norm(), 0.25 * h);
  EXPECT_NEAR(d, ev.chipDepth, 0.5 * h);
  const double triangle = d * d / (2.0 * nGrid[0] * nGrid[1]);
  const double chip = std::min(ev.childVolumes[0], ev.childVolumes[1]);
  std::printf("[ chip 2D ] depth %.2f cells, chip %.5g m^2, corner triangle %.5g m^2 (%+.2f %%)\n", ev.chipDepth / h,
              chip, triangle, 100.0 * (chip / triangle - 1.0));
  EXPECT_NEAR(chip, triangle, 0.03 * triangle);
  // Circularity 4 pi A / P^2 rises: legs L_k = d / n_k off a side of 2a.
  const double l0 = d / nGrid[0], l1 = d / nGrid[1];
  const double area = 4.0 * a * a - 0.5 * l0 * l1;
  const double perimeter = 8.0 * a - l0 - l1 + std::hypot(l0, l1);
  const double expected = (area / (perimeter * perimeter)) / (4.0 * a * a / (64.0 * a * a));
  const std::uint64_t bigger = ev.childVolumes[0] > ev.childVolumes[1] ? ev.children[0] : ev.children[1];
  const auto& rest = *w.particles().shape[indexOf(w.particles(), bigger)];
  const double ratio = rest.descriptors().circularity / square->descriptors().circularity;
  std::printf("[ chip 2D ] circularity %.4f -> %.4f (ratio %.4f, analytic %.4f)\n", square->descriptors().circularity,
              rest.descriptors().circularity, ratio, expected);
  EXPECT_NEAR(ratio, expected, 0.003);
}

// A chipping declaration that never chips leaves the run bitwise the run
// without it (the criterion only reads), and a checkpoint of a run without
// chipping has the section of the release before chips ("breakage 3").
TEST(Chipping, NeverReachedLeavesTheRunBitwiseUnchanged) {
  CornerDrop off = dropCube(Chips::Off);
  CornerDrop never = dropCube(Chips::OutOfReach);
  for (int k = 0; k < 4000; ++k) {
    off.world->step();
    never.world->step();
  }
  EXPECT_EQ(never.breakage->breakages(), 0u);
  const auto& a = off.world->particles();
  const auto& b = never.world->particles();
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(std::memcmp(a.position[i].data(), b.position[i].data(), sizeof(double) * 3), 0);
    EXPECT_EQ(std::memcmp(a.velocity[i].data(), b.velocity[i].data(), sizeof(double) * 3), 0);
    EXPECT_EQ(std::memcmp(a.angularVelocity[i].data(), b.angularVelocity[i].data(), sizeof(double) * 3), 0);
  }
  EXPECT_LT(a.position[0][1], 0.02);  // it did reach the floor
  const auto tagOf = [](const Breakage<3>& brk) {
    dynamics::StateWriter out;
    brk.saveState(out);
    dynamics::StateReader in(out.bytes().data(), out.bytes().size());
    return in.getString();
  };
  EXPECT_EQ(tagOf(*off.breakage), "breakage 3");
  EXPECT_EQ(tagOf(*never.breakage), "breakage 4");
}

// Checkpoints: the chip's event, its mode and depth and the counters come back.
TEST(Chipping, StateRoundTrip) {
  CornerDrop s = dropCube(Chips::On);
  while (s.breakage->breakages() == 0 && s.world->steps() < 20000) s.world->step();
  ASSERT_EQ(s.breakage->chips(), 1u);
  dynamics::StateWriter out;
  s.breakage->saveState(out);
  Breakage<3> copy(s.breakage->def());
  dynamics::StateReader in(out.bytes().data(), out.bytes().size());
  copy.loadState(in);
  EXPECT_TRUE(in.atEnd());
  ASSERT_EQ(copy.breakages(), 1u);
  EXPECT_EQ(copy.chips(), 1u);
  EXPECT_TRUE(copy.events()[0].chip);
  EXPECT_EQ(copy.events()[0].chipDepth, s.breakage->events()[0].chipDepth);
  EXPECT_EQ(copy.events()[0].children, s.breakage->events()[0].children);
}
