// The energy ledger books what the integrator does: through impacts with
// contact damping and friction, of bodies of very different mass and of a
// slender spinning body (whose effective mass at a contact is a fraction of its
// mass), kinetic + elastic energy + losses - work stays at the initial energy
// step by step, within 1 % of it (the integrator's own error as node
// contacts open and close; booking the dashpot's sampled power c v_n^2 dt
// instead put the impact case of the stability suite 3.4 % over).

#include "lsdem/dynamics/World.h"
#include "lsdem/geometry/ShapeDef.h"
#include "support/Shapes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

using namespace lsdem;
using dynamics::ParticleDef;
using dynamics::PlaneDef;
using dynamics::World;
using dynamics::WorldDef;
using geometry::Vec;

namespace {

// Largest |balance error| / initial energy over `steps` steps, and the
// dissipated fraction at the end (so a test can require a real loss).
template <int D>
std::pair<double, double> worstBalance(World<D>& w, int steps) {
  double worst = 0.0;
  w.step();
  const double initial = w.energy().initial;
  for (int s = 0; s < steps; ++s) {
    w.step();
    worst = std::max(worst, std::abs(w.energy().balanceError()) / initial);
  }
  return {worst, (w.energy().contactLoss + w.energy().dampingLoss) / initial};
}

template <int D>
void addFloor(World<D>& w) {
  PlaneDef<D> floor;
  floor.plane.point = Vec<D>::Zero();
  floor.plane.normal = Vec<D>::Unit(1);
  w.addPlane(floor);
}

}  // namespace

// A light disc thrown fast at a heavy one (mass ratio 100) and a spinning
// disc hitting the floor at an angle: damping 0.4 and friction on.
TEST(EnergyLedger, ImpactsWithDampingBalance2D) {
  WorldDef<2> def;
  def.contact.kn = 1e6;
  def.contact.ks = 0.8e6;
  World<2> w(def);
  addFloor(w);
  const auto disc = test::sphereShape<2>(0.01, 12);
  ParticleDef<2> heavy;
  heavy.shape = disc;
  heavy.density = 2650.0 * 100.0;
  heavy.position = Vec<2>(0.0, 0.05);
  w.addParticle(heavy);
  ParticleDef<2> light = heavy;
  light.density = 2650.0;
  light.position = Vec<2>(-0.0205, 0.0505);
  light.velocity = Vec<2>(5.0, 0.0);
  w.addParticle(light);
  ParticleDef<2> spinner = light;
  spinner.position = Vec<2>(0.1, 0.0105);
  spinner.velocity = Vec<2>(1.0, -3.0);
  spinner.angularVelocity = 80.0;
  w.addParticle(spinner);
  const auto [worst, lost] = worstBalance(w, 3000);
  EXPECT_GT(lost, 0.05);      // the impacts dissipate a real share of the energy
  EXPECT_LT(worst, 1e-2);     // and the ledger follows it step by step (measured 0.6 %)
}

// A needle (aspect 10) tumbling onto the floor: at its tips the effective
// mass is a fifth of its mass, so the dashpot takes a large share of the
// relative velocity within a step.
TEST(EnergyLedger, SlenderBodyOnFloorBalance3D) {
  WorldDef<3> def;
  def.contact.kn = 1e6;
  def.contact.ks = 0.8e6;
  World<3> w(def);
  addFloor(w);
  geometry::ShapeDef<3> needle;
  needle.kind = geometry::ShapeKind::Ellipsoid;
  needle.semiAxes = Vec<3>(0.02, 0.002, 0.002);
  needle.cellsAcross = 4;
  needle.options.nodesPerCell = 1.0;
  ParticleDef<3> p;
  p.shape = geometry::buildShape(needle);
  p.position = Vec<3>(0.0, 0.0205, 0.0);
  p.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.9, Vec<3>::UnitZ()));
  p.velocity = Vec<3>(0.5, -2.0, 0.0);
  p.angularVelocity = Vec<3>(20.0, -35.0, 10.0);
  w.addParticle(p);
  const auto [worst, lost] = worstBalance(w, 6000);
  EXPECT_GT(lost, 0.05);
  EXPECT_LT(worst, 1e-2);  // measured 0.3 %
}

// Re-evaluating the contacts between steps (what a change of the particle set
// triggers) at an unchanged state changes nothing: a disc bouncing on the
// floor under tilted gravity, re-evaluated while its friction spring is
// loaded, follows the same path bit for bit, and no spring energy is booked
// as released. Advancing the shear springs again at the re-evaluation (an
// extra v_t dt) shifted the path.
TEST(EnergyLedger, ReEvaluationBetweenStepsChangesNothing) {
  struct End {
    Vec<2> position, velocity;
    double angle = 0.0, spin = 0.0, released = 0.0, error = 0.0, tangential = 0.0;
  };
  const auto run = [](bool reEvaluate) {
    WorldDef<2> def;
    def.contact.kn = 1e6;
    def.contact.ks = 0.8e6;
    def.contact.hasDamping = false;
    def.gravity = Vec<2>(2.0, -9.81);
    World<2> w(def);
    addFloor(w);
    ParticleDef<2> disc;
    disc.shape = test::sphereShape<2>(0.01, 12);
    disc.position = Vec<2>(0.0, 0.0099);
    w.addParticle(disc);
    // Run until in contact with the friction spring loaded (the same step in both runs).
    int steps = 0;
    do {
      w.step();
      ++steps;
    } while (steps < 2000 && !(std::abs(w.boundaryLoads().planeForce[0].x()) > 1.0));
    const double tangential = w.boundaryLoads().planeForce[0].x();
    if (reEvaluate) w.particlesChanged();
    w.run(600 - steps);
    const auto& p = w.particles();
    return End{p.position[0], p.velocity[0], p.orientation[0], p.angularVelocity[0], w.energy().splitRelease,
               w.energy().balanceError(), tangential};
  };
  const End plain = run(false), again = run(true);
  EXPECT_GT(std::abs(plain.tangential), 1.0);  // N/m: the shear spring is loaded (measured 10)
  EXPECT_EQ(again.position, plain.position);
  EXPECT_EQ(again.velocity, plain.velocity);
  EXPECT_EQ(again.angle, plain.angle);
  EXPECT_EQ(again.spin, plain.spin);
  EXPECT_EQ(again.released, 0.0);
  EXPECT_EQ(again.error, plain.error);
}

// No tensile contact forces: a heavily damped disc (C_res = 0.7) thrown at the
// floor and at another disc. While they part, the dashpot would pull the
// surfaces together; the law clips every node's normal force at zero (and
// some nodes are clipped: their normal force is exactly 0 while they still
// overlap), and the ledger, which books the dashpot force actually applied,
// still closes step by step.
TEST(EnergyLedger, ClippedDashpotNeverPullsAndTheLedgerCloses) {
  WorldDef<2> def;
  def.contact.kn = 1e6;
  def.contact.ks = 0.8e6;
  def.contact.dampingRatio = 0.7;
  World<2> w(def);
  addFloor(w);
  const auto disc = test::sphereShape<2>(0.01, 12);
  ParticleDef<2> a;
  a.shape = disc;
  a.position = Vec<2>(0.0, 0.0105);
  a.velocity = Vec<2>(0.5, -2.0);
  a.angularVelocity = 30.0;
  w.addParticle(a);
  ParticleDef<2> b = a;
  b.position = Vec<2>(0.05, 0.03);
  b.velocity = Vec<2>(-1.5, 0.0);
  b.angularVelocity = -10.0;
  w.addParticle(b);
  w.step();
  const double initial = w.energy().initial;
  double worst = 0.0, smallest = 0.0;
  std::size_t clipped = 0;
  for (int s = 0; s < 4000; ++s) {
    w.step();
    worst = std::max(worst, std::abs(w.energy().balanceError()) / initial);
    for (const auto& c : w.contacts().nodeContacts()) {
      const double fn = c.force.dot(c.normal);
      smallest = std::min(smallest, fn);
      clipped += fn == 0.0 && c.overlap > 0.0;
    }
  }
  EXPECT_GE(smallest, 0.0);  // never attractive
  EXPECT_GT(clipped, 0u);    // and the clip did act
  EXPECT_GT(w.energy().contactLoss / initial, 0.1);
  EXPECT_LT(worst, 1e-2);
}
