// The example effect of docs/design.md ("Adding an effect"), compiled and
// checked here so that the document stays true: buoyancy in a still fluid.

#include "support/Shapes.h"
#include "lsdem/dynamics/World.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <span>
#include <string>

using namespace lsdem;
using namespace lsdem::dynamics;

namespace {

// --- docs/design.md example: begin ---
// Buoyancy: F = -rho_f V g on every particle whose centroid lies below the
// fluid's surface (height `surface` along the last axis). Its work is
// booked like gravity's, so the energy budget of a run still closes.
template <int D>
class Buoyancy final : public Effect<D> {
 public:
  Buoyancy(double fluidDensity, const Vec<D>& gravity, double surface)
      : rho_(fluidDensity), g_(gravity), surface_(surface) {}
  std::string name() const override { return "buoyancy"; }
  // Each particle's force from its own state: it runs on N ranks too.
  bool distributable() const override { return true; }
  void applyForces(World<D>& world, double dt) override {
    const Particles<D>& p = world.particles();  // read-only
    const std::span<Vec<D>> force = world.forces();  // effects add to these
    double power = 0.0;
    for (std::size_t i = 0; i < p.size(); ++i) {
      if (world.isGhost(i)) continue;  // another rank's particle (mpirun)
      if (p.position[i][D - 1] > surface_) continue;
      const Vec<D> f = -rho_ * p.shape[i]->volume() * g_;
      force[i] += f;
      power += f.dot(p.velocity[i]);  // velocities are the half-step ones
    }
    world.addGravityWork(power * dt);  // exact over the closing step
  }

 private:
  double rho_;
  Vec<D> g_;
  double surface_;
};
// --- docs/design.md example: end ---

// A grain of density rho released at rest in a fluid of density rho / 4
// sinks with g (1 - 1/4), and the ledger balances (the buoyancy's work is
// booked); above the surface it falls with g.
template <int D>
void checkBuoyancy() {
  const Vec<D> g = -9.81 * Vec<D>::Unit(D - 1);
  const auto run = [&](double start) {
    WorldDef<D> def;
    def.gravity = g;
    World<D> w(def);
    ParticleDef<D> p;
    p.shape = test::sphereShape<D>(0.05);
    p.density = 2000.0;
    p.position = Vec<D>::Unit(D - 1) * start;
    w.addParticle(p);
    w.addEffect(std::make_unique<Buoyancy<D>>(500.0, g, 0.0));
    const std::uint64_t steps = std::uint64_t(std::ceil(0.05 / w.dt()));
    w.run(steps);
    return std::make_pair(w.particles().velocity[0][D - 1] / w.time(), w.energy().relativeBalanceError());
  };
  const auto [under, underError] = run(-1.0);
  const auto [above, aboveError] = run(+1.0);
  EXPECT_NEAR(under, -9.81 * 0.75, 1e-9);
  EXPECT_NEAR(above, -9.81, 1e-9);
  EXPECT_LT(std::abs(underError), 1e-12);
  EXPECT_LT(std::abs(aboveError), 1e-12);
}

TEST(EffectExample, BuoyancyLightensAGrainBelowTheSurfaceAndKeepsTheBudget2D) { checkBuoyancy<2>(); }
TEST(EffectExample, BuoyancyLightensAGrainBelowTheSurfaceAndKeepsTheBudget3D) { checkBuoyancy<3>(); }

}  // namespace
