// A manual break along a curved fracture surface given as a level set (a
// shape placed in the world): the pieces are the parent's parts inside and
// outside it, with the analytic areas of a circle-circle lens.

#include "support/Shapes.h"
#include "lsdem/breakage/Breakage.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace lsdem;

namespace {

// Area of the intersection of two circles of radii r and R whose centres are d apart.
double lensArea(double r, double R, double d) {
  const double a = r * r * std::acos((d * d + r * r - R * R) / (2 * d * r));
  const double b = R * R * std::acos((d * d + R * R - r * r) / (2 * d * R));
  const double c = 0.5 * std::sqrt((-d + r + R) * (d + r - R) * (d - r + R) * (d + r + R));
  return a + b - c;
}

}  // namespace

TEST(CurvedBreak, DiscCutByACircularSurfaceGivesTheLensAreas) {
  const double r = 0.01, R = 0.008, d = 0.012;
  dynamics::WorldDef<2> def;
  def.contact.kn = 1e5;
  dynamics::World<2> world(def);
  dynamics::ParticleDef<2> p;
  p.shape = test::sphereShape<2>(r, 80);
  p.position = {0.3, 0.2};
  p.orientation = 0.7;  // the cut must not depend on the particle's pose
  p.velocity = {1.0, -2.0};
  p.angularVelocity = 3.0;
  world.addParticle(p);
  const double mass = world.particles().mass[0];

  breakage::BreakageDef<2> bd;
  breakage::ManualBreak<2> cut;
  cut.particle = 0;
  cut.time = 0.0;
  cut.surface = test::sphereShape<2>(R, 80);
  cut.surfaceToWorld.translation = p.position + geometry::Vec<2>(d, 0.0);
  bd.manual.push_back(cut);
  auto effect = std::make_unique<breakage::Breakage<2>>(bd);
  const auto* b = effect.get();
  world.addEffect(std::move(effect));
  world.step();

  ASSERT_EQ(b->breakages(), 1u);
  ASSERT_EQ(world.particles().size(), 2u);
  const double lens = lensArea(r, R, d), disc = std::acos(-1.0) * r * r;
  std::vector<double> areas;
  double total = 0.0;
  for (std::size_t i = 0; i < 2; ++i) {
    areas.push_back(world.particles().mass[i] / mass * disc);
    total += world.particles().mass[i];
  }
  std::sort(areas.begin(), areas.end());
  EXPECT_NEAR(areas[0], lens, 0.01 * lens);
  EXPECT_NEAR(areas[1], disc - lens, 0.01 * lens);
  EXPECT_NEAR(total, mass, 1e-14 * mass);  // exact mass
  EXPECT_EQ(b->events()[0].planeNormal, geometry::Vec<2>::Zero());  // curved: no plane
  EXPECT_TRUE(b->events()[0].manual);
}
