#include "support/Shapes.h"
#include "lsdem/dynamics/World.h"
#include "lsdem/geometry/ShapeDef.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <memory>
#include <new>
#include <optional>
#include <tuple>
#include <random>
#include <stdexcept>

#ifdef LSDEM_HAVE_OPENMP
#include <omp.h>
#endif

using namespace lsdem;
using namespace lsdem::dynamics;

namespace {

template <int D>
std::shared_ptr<const geometry::Shape<D>> grain(std::uint64_t seed, double d) {
  geometry::ShapeDef<D> def;
  def.kind = geometry::ShapeKind::RandomGrain;
  def.grain.equivalentDiameter = d;
  def.grain.elongation = 1.3;
  def.grain.roughness = 0.1;
  def.grain.seed = seed;
  def.cellsAcross = 10;
  def.options.nodesPerCell = 1.0;
  return geometry::buildShape(def);
}

// A 2D box of planes: floor at y = 0, walls at x = 0 and x = width.
template <int D>
void addBox(World<D>& w, double width) {
  PlaneDef<D> floor;
  floor.name = "floor";
  floor.plane.point = Vec<D>::Zero();
  floor.plane.normal = Vec<D>::Unit(1);
  w.addPlane(floor);
  for (int a : {0, 2}) {
    if (a >= D) continue;
    PlaneDef<D> lo, hi;
    lo.plane.point = Vec<D>::Zero();
    lo.plane.normal = Vec<D>::Unit(a);
    hi.plane.point = Vec<D>::Unit(a) * width;
    hi.plane.normal = -Vec<D>::Unit(a);
    w.addPlane(lo);
    w.addPlane(hi);
  }
}

// FNV-1a over the bytes of the particle state, in id order.
template <int D>
std::uint64_t stateHash(const Particles<D>& p) {
  std::vector<std::size_t> order(p.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return p.id[a] < p.id[b]; });
  std::uint64_t h = 1469598103934665603ull;
  auto mix = [&](const void* data, std::size_t n) {
    const auto* b = static_cast<const unsigned char*>(data);
    for (std::size_t k = 0; k < n; ++k) h = (h ^ b[k]) * 1099511628211ull;
  };
  for (std::size_t i : order) {
    mix(p.position[i].data(), sizeof(double) * D);
    mix(p.velocity[i].data(), sizeof(double) * D);
    if constexpr (D == 2) {
      mix(&p.orientation[i], sizeof(double));
    } else {
      mix(p.orientation[i].coeffs().data(), sizeof(double) * 4);
    }
  }
  return h;
}

}  // namespace

// A column of grains settles under gravity; at rest the floor carries the
// total weight within 0.5 %.
TEST(World, SettledColumnFloorCarriesTheWeight) {
  WorldDef<2> def;
  def.gravity = Vec<2>(0.0, -9.81);
  def.localDamping = 0.3;
  def.contact.kn = 1e5;
  def.contact.ks = 0.8e5;
  def.contact.friction = 0.5;
  World<2> w(def);
  addBox(w, 0.12);
  const auto s = test::sphereShape<2>(0.05);
  for (int k = 0; k < 4; ++k) {
    ParticleDef<2> p;
    p.shape = s;
    p.density = 2650;
    p.position = Vec<2>(0.06 + 0.004 * (k % 2), 0.06 + 0.105 * k);
    w.addParticle(p);
  }
  double weight = 0.0;
  for (double m : w.particles().mass) weight += m * 9.81;
  const int steps = int(std::ceil(1.5 / w.dt()));
  w.run(std::uint64_t(steps));
  // The floor and the side walls (through friction) together carry the weight.
  double carried = 0.0;
  for (const Vec<2>& f : w.boundaryLoads().planeForce) carried -= f[1];
  EXPECT_NEAR(carried, weight, 0.005 * weight) << "after " << steps << " steps of " << w.dt() << " s";
  EXPECT_GT(-w.boundaryLoads().planeForce[0][1], 0.5 * weight);
  EXPECT_LT(w.energy().kineticTranslational, 1e-6 * weight * 0.1);
  ASSERT_EQ(w.effectNames(), (std::vector<std::string>{"gravity", "local_damping"}));
}

// Undamped and frictionless, rough grains bouncing off each other and a box
// under gravity keep their energy budget over 10^5 steps. The forces are
// conservative (F = k delta grad phi); what remains is the integrator's error
// where a node enters a contact or crosses a cell face of the other grid (the
// multilinear gradient jumps there), which falls as dt^1.8: at 0.005 of the
// critical step (~250 steps per grain-grain contact) it stays below 0.2 %.
// (A single grain on walls stays within 3e-5: test_impact.)
TEST(World, UndampedRunConservesEnergy) {
  WorldDef<2> def;
  def.gravity = Vec<2>(0.0, -9.81);
  def.dtSafety = 0.005;
  def.contact.kn = 1e6;
  def.contact.hasFriction = false;
  def.contact.hasDamping = false;
  World<2> w(def);
  addBox(w, 0.4);
  for (int k = 0; k < 3; ++k) {
    ParticleDef<2> p;
    p.shape = grain<2>(std::uint64_t(k + 1), 0.1);
    p.position = Vec<2>(0.075 + 0.125 * k, 0.1 + 0.07 * k);
    p.velocity = Vec<2>(0.5 - 0.3 * k, 0.2 * k);
    p.angularVelocity = 3.0 * (k - 1);
    w.addParticle(p);
  }
  double worst = 0.0;
  std::uint64_t looked = 0;
  for (int s = 0; s < 100000; ++s) {
    w.step();
    worst = std::max(worst, std::abs(w.energy().relativeBalanceError()));
    looked += w.contacts().nodeChecks() + w.contacts().certifiedWalks();
  }
  EXPECT_LT(worst, 2e-3);
  // The narrow phase ran: nodes tested, or walks its certificates spared.
  EXPECT_GT(looked, 0u);
  RecordProperty("worst_relative_energy_error", std::to_string(worst));
}

// The same 3D scene with 1 and 2 threads ends in bitwise the same state.
TEST(World, DeterministicAcrossThreads) {
  auto runScene = [](int threads) {
#ifdef LSDEM_HAVE_OPENMP
    omp_set_num_threads(threads);
#else
    (void)threads;
#endif
    WorldDef<3> def;
    def.gravity = Vec<3>(0.0, -9.81, 0.0);
    def.contact.kn = 1e5;
    def.contact.ks = 0.8e5;
    World<3> w(def);
    addBox(w, 0.3);
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int k = 0; k < 8; ++k) {
      ParticleDef<3> p;
      p.shape = grain<3>(std::uint64_t(k % 3 + 1), 0.08);
      p.position = Vec<3>(0.06 + 0.18 * u(rng), 0.05 + 0.09 * k, 0.06 + 0.18 * u(rng));
      p.velocity = Vec<3>(u(rng) - 0.5, -u(rng), u(rng) - 0.5);
      w.addParticle(p);
    }
    std::size_t touching = 0;  // steps with contacts: the threads had pairs to share
    for (int s = 0; s < 400; ++s) {
      w.step();
      touching += !w.contacts().pairContacts().empty();
    }
    EXPECT_GT(touching, 50u);
    return stateHash(w.particles());
  };
  const std::uint64_t one = runScene(1);
  const std::uint64_t two = runScene(2);
  EXPECT_EQ(one, two);
#ifdef LSDEM_HAVE_OPENMP
  omp_set_num_threads(2);
#endif
}

TEST(World, OutflowRemovesAndRecords) {
  WorldDef<2> def;
  def.gravity = Vec<2>(0.0, -9.81);
  def.outflow = geometry::Box<2>{Vec<2>(-1.0, -0.5), Vec<2>(1.0, 1.0)};
  World<2> w(def);
  ParticleDef<2> p;
  p.shape = test::sphereShape<2>(0.05);
  p.position = Vec<2>(0.0, 0.0);
  w.addParticle(p);
  const double m = w.particles().mass[0];
  w.run(std::uint64_t(std::ceil(0.5 / w.dt())));
  ASSERT_EQ(w.particles().size(), 0u);
  ASSERT_EQ(w.removed().size(), 1u);
  EXPECT_EQ(w.removed()[0].reason, "outflow");
  EXPECT_DOUBLE_EQ(w.removed()[0].mass, m);
  EXPECT_NEAR(w.removed()[0].time, std::sqrt(2 * 0.5 / 9.81), 0.01);
  EXPECT_DOUBLE_EQ(w.removedMass(), m);
}

// World::replace, the one way particles are split: parents leave without a
// removal record, fines are recorded (ids taken before the children's), the
// children enter in order, and the ledger books exactly the kinetic energy
// the change brings, so the budget holds across it (free discs: no contact,
// no gravity, so the ledger's kinetic terms after a step are the discs' own).
TEST(World, ReplaceBooksTheSplitAndKeepsTheBudget) {
  World<2> w{WorldDef<2>{}};
  const auto big = test::sphereShape<2>(0.05);
  const auto small = test::sphereShape<2>(0.02);
  for (int k = 0; k < 3; ++k) {
    ParticleDef<2> p;
    p.shape = big;
    p.position = Vec<2>(0.5 * k, 0.0);
    p.velocity = Vec<2>(0.1 * (k + 1), -0.2);
    p.angularVelocity = 1.0 + k;
    w.addParticle(p);
  }
  w.step();
  const std::uint64_t idB = w.particles().id[1];
  const double before = w.energy().balanceError();
  const double added0 = w.energy().addedEnergy;
  const double kineticParents = w.particles().kineticEnergy(0) + w.particles().kineticEnergy(2);
  const std::uint64_t firstId = w.particles().nextId();

  const auto child = [&](double x, double vx) {
    ParticleDef<2> c;
    c.shape = small;
    c.position = Vec<2>(x, 0.01);
    c.velocity = Vec<2>(vx, 0.3);
    c.angularVelocity = -2.0;
    return c;
  };
  std::vector<Replacement<2>> splits(2);
  splits[0].parent = 2;
  splits[0].children = {child(1.0, 0.5), child(1.05, 0.7)};
  RemovedParticle fines;
  fines.mass = 1e-3;
  fines.reason = "fines";
  splits[0].fines.emplace_back(fines, 0.25);
  splits[1].parent = 0;
  splits[1].children = {child(0.0, -0.4)};
  const std::vector<std::size_t> added = w.replace(splits);

  const Particles<2>& p = w.particles();
  ASSERT_EQ(added.size(), 3u);
  ASSERT_EQ(p.size(), 4u);
  EXPECT_FALSE(w.contactsCurrent());
  // The untouched disc stays; the fines took the first new id, the children the next ones in order.
  EXPECT_EQ(std::count(p.id.begin(), p.id.end(), idB), 1);
  ASSERT_EQ(w.removed().size(), 1u);
  EXPECT_EQ(w.removed()[0].id, firstId);
  EXPECT_EQ(w.removed()[0].reason, "fines");
  EXPECT_EQ(w.removed()[0].time, w.time());
  double kineticChildren = 0.0;
  for (std::size_t k = 0; k < added.size(); ++k) {
    EXPECT_EQ(p.id[added[k]], firstId + 1 + k);
    kineticChildren += p.kineticEnergy(added[k]);
  }
  EXPECT_DOUBLE_EQ(p.position[added[1]].x(), 1.05);
  EXPECT_NEAR(w.energy().addedEnergy - added0, kineticChildren + 0.25 - kineticParents, 1e-15);
  EXPECT_EQ(w.energy().removedEnergy, 0.25);
  // The budget holds across the change once the step has measured the new set.
  w.step();
  EXPECT_NEAR(w.energy().balanceError(), before, 1e-12 * w.energy().scale());

  // A parent out of range or given twice is refused, and nothing changes.
  std::vector<Replacement<2>> bad(1);
  bad[0].parent = 4;
  EXPECT_THROW(w.replace(bad), std::out_of_range);
  bad.resize(2);
  bad[0].parent = 1;
  bad[1].parent = 1;
  EXPECT_THROW(w.replace(bad), std::out_of_range);
  EXPECT_EQ(w.particles().size(), 4u);
}

// Effects need no declaration order: an effect that removes a particle
// runs before one that reads the contacts in the same afterStep, and the
// reader gets the records of the particles as they are (World refreshes
// them for an effect that readsContacts()). Three discs pressed in a row;
// the first is removed after step 1: the reader then sees the one contact
// left, between the two discs that remain, at their current indices.
namespace {
struct RemoveFirstAfter final : Effect<2> {
  std::uint64_t id = 0;
  std::string name() const override { return "remove"; }
  void afterStep(World<2>& w) override {
    if (w.steps() != 1) return;
    const auto& ids = w.particles().id;
    w.removeParticle(std::size_t(std::find(ids.begin(), ids.end(), id) - ids.begin()), "test");
  }
};
struct ContactReader final : Effect<2> {
  std::vector<std::array<std::uint64_t, 2>> seen;  // ids of the touching pairs, last step
  bool current = false;
  std::string name() const override { return "reader"; }
  bool readsContacts() const override { return true; }
  void afterStep(World<2>& w) override {
    current = w.contactsCurrent();
    seen.clear();
    const auto& p = w.particles();
    for (const PairContact<2>& c : w.contacts().particleContacts()) {
      ASSERT_LT(std::max(c.a, c.b), p.size());
      seen.push_back({std::min(p.id[c.a], p.id[c.b]), std::max(p.id[c.a], p.id[c.b])});
    }
  }
};


}  // namespace

TEST(World, AnEffectThatReadsContactsGetsThemForTheParticlesAsTheyAre) {
  const auto disc = test::sphereShape<2>(0.05);
  const auto run = [&](bool removeFirst) {
    World<2> w{WorldDef<2>{}};
    for (int k = 0; k < 3; ++k) {
      ParticleDef<2> p;
      p.shape = disc;
      p.position = Vec<2>(0.098 * k, 0.0);
      w.addParticle(p);
    }
    if (removeFirst) {
      auto remove = std::make_unique<RemoveFirstAfter>();
      remove->id = w.particles().id[0];
      w.addEffect(std::move(remove));
    }
    auto reader = std::make_unique<ContactReader>();
    ContactReader* r = reader.get();
    w.addEffect(std::move(reader));
    w.step();  // the removal, then the reading, after step 1
    EXPECT_TRUE(r->current);
    return std::make_tuple(r->seen, std::vector<std::uint64_t>(w.particles().id.begin(), w.particles().id.end()));
  };
  const auto all = std::get<0>(run(false));
  ASSERT_EQ(all.size(), 2u);  // first-second, second-third
  const auto [left, ids] = run(true);
  ASSERT_EQ(ids.size(), 2u);
  ASSERT_EQ(left.size(), 1u);
  EXPECT_EQ(left[0], all[1]);
  EXPECT_EQ(left[0], (std::array<std::uint64_t, 2>{std::min(ids[0], ids[1]), std::max(ids[0], ids[1])}));
}

// With a discharge box, what leaves the outflow box inside it is the
// discharge (a crusher's product) and what leaves elsewhere stays "outflow":
// one grain falls through the discharge, one is thrown sideways out of the box.
TEST(World, DischargeSeparatesProductFromEjectedGrains) {
  WorldDef<2> def;
  def.gravity = Vec<2>(0.0, -9.81);
  def.outflow = geometry::Box<2>{Vec<2>(-1.0, -0.5), Vec<2>(1.0, 1.0)};
  def.discharge = geometry::Box<2>{Vec<2>(-0.2, -0.7), Vec<2>(0.2, -0.4)};
  World<2> w(def);
  ParticleDef<2> p;
  p.shape = test::sphereShape<2>(0.05);
  p.position = Vec<2>(0.0, 0.0);
  w.addParticle(p);
  p.position = Vec<2>(0.5, 0.0);
  p.velocity = Vec<2>(3.0, 0.0);
  w.addParticle(p);
  w.run(std::uint64_t(std::ceil(0.5 / w.dt())));
  ASSERT_EQ(w.particles().size(), 0u);
  ASSERT_EQ(w.removed().size(), 2u);
  const auto& first = w.removed()[0].time < w.removed()[1].time ? w.removed()[0] : w.removed()[1];
  const auto& second = &first == &w.removed()[0] ? w.removed()[1] : w.removed()[0];
  EXPECT_EQ(first.reason, "outflow");     // the thrown grain leaves through the side at t = 0.5 / 3
  EXPECT_NEAR(first.time, 0.5 / 3.0, 0.01);
  EXPECT_EQ(second.reason, "discharge");  // the other falls through the discharge
}

TEST(World, UserTimeStepIsCheckedAgainstTheCriticalOne) {
  WorldDef<2> def;
  def.dt = 1.0;
  World<2> w(def);
  ParticleDef<2> p;
  p.shape = test::sphereShape<2>(0.05);
  EXPECT_THROW(w.addParticle(p), std::invalid_argument);
  def.forceDt = true;
  World<2> forced(def);
  forced.addParticle(p);
  EXPECT_DOUBLE_EQ(forced.dt(), 1.0);
  WorldDef<2> bad;
  bad.dt = -1.0;
  EXPECT_THROW(World<2>{bad}, std::invalid_argument);
}

TEST(World, NoDeclaredEffectsMeansNone) {
  World<3> w(WorldDef<3>{});
  EXPECT_TRUE(w.effectNames().empty());
}

// The time step of a shape that reuses the address of a freed one. Breakage
// and removal free fragment shapes, and the allocator may hand their memory to
// the next shape made (which memory it reuses depended on which thread freed
// what, so the 3D crushing run took a different number of steps from run to
// run). The stiffness cached for the freed shape must not be taken for the new
// one: the step must be the one a fresh world gives the new shape.
TEST(World, TimeStepIgnoresTheStiffnessOfAFreedShapeAtTheSameAddress) {
  using Shape2 = geometry::Shape<2>;
  // Declared first so it outlives every shape built in it.
  alignas(Shape2) unsigned char storage[sizeof(Shape2)];
  const auto soft = test::sphereShape<2>(0.05, 6);
  const auto stiff = test::sphereShape<2>(0.05, 24);
  ParticleDef<2> p;
  p.position = Vec<2>(0.5, 0.5);
  // Automatic steps of a world holding one particle of each shape alone.
  const auto freshDt = [&](const std::shared_ptr<const Shape2>& shape) {
    World<2> w(WorldDef<2>{});
    ParticleDef<2> q = p;
    q.shape = shape;
    w.addParticle(q);
    return w.dt();
  };
  const double softDt = freshDt(soft), stiffDt = freshDt(stiff);
  ASSERT_LT(stiffDt, softDt) << "the scene needs the second shape to lower the step";

  // Both shapes are built in turn in one buffer, so they share an address.
  const auto inStorage = [&](const Shape2& from) {
    return std::shared_ptr<const Shape2>(new (storage) Shape2(from), [](const Shape2* s) { s->~Shape2(); });
  };
  World<2> w(WorldDef<2>{});
  p.shape = inStorage(*soft);
  w.addParticle(p);
  EXPECT_EQ(w.dt(), softDt);
  w.removeParticle(0, "test");
  p.shape.reset();  // the soft copy is destroyed; its memory is free
  p.shape = inStorage(*stiff);
  ASSERT_EQ(static_cast<const void*>(p.shape.get()), static_cast<const void*>(storage));
  w.addParticle(p);
  EXPECT_EQ(w.dt(), stiffDt);
  w.removeParticle(0, "test");
  p.shape.reset();
}

// The automatic step and what sets it. A plane of its own, stiffer material
// is a stiffer contact than two grains: the linear law's wall of 10 kn
// (stiffest patch without the pair factor 2: 5x a pair's), the Hertz law's
// rigid wall (E* doubled at twice R*: 2x a pair's tangent stiffness). The
// world names the particle and the contact that limit the step, and logs
// each change of the step.
TEST(World, TimeStepCountsWallMaterialsAndNamesItsLimit) {
  const auto disc = test::sphereShape<2>(0.01, 12);
  const auto criticalOf = [&](const dynamics::ContactLawDef& law, const std::optional<dynamics::BoundaryMaterial>& m) {
    WorldDef<2> def;
    def.contact = law;
    World<2> w(def);
    PlaneDef<2> floor;
    floor.name = "floor";
    floor.plane.normal = Vec<2>::UnitY();
    floor.material = m;
    ParticleDef<2> p;
    p.shape = disc;
    p.position = Vec<2>(0.0, 0.05);
    w.addParticle(p);
    w.addPlane(floor);  // after the particle: the step is re-checked
    p.position = Vec<2>(0.0, 0.08);
    w.addParticle(p);
    return std::tuple{w.criticalDt(), w.timeStepLimit(), w.timeStepChanges()};
  };
  dynamics::ContactLawDef linear;
  linear.kn = 1e5;
  linear.ks = 0.8e5;
  dynamics::BoundaryMaterial stiff;
  stiff.kn = 1e6;
  const auto [grains, grainLimit, grainChanges] = criticalOf(linear, std::nullopt);
  const auto [walled, wallLimit, wallChanges] = criticalOf(linear, stiff);
  EXPECT_EQ(grainLimit.boundary, -1);
  EXPECT_EQ(wallLimit.boundary, 0);
  EXPECT_NEAR(wallLimit.stiffness / grainLimit.stiffness, 5.0, 1e-9);
  EXPECT_NEAR(walled, grains / std::sqrt(5.0), 1e-12 * grains);
  EXPECT_EQ(wallLimit.id, 0u);
  EXPECT_EQ(wallLimit.nodes, disc->nodes().size());
  EXPECT_EQ(wallLimit.diameter, disc->descriptors().equivalentDiameter);
  EXPECT_EQ(wallLimit.criticalDt, walled);
  ASSERT_EQ(wallChanges.size(), 2u);  // the first particle, then the wall
  EXPECT_GT(wallChanges[0].dt, wallChanges[1].dt);
  EXPECT_EQ(wallChanges[1].limit.boundary, 0);

  dynamics::ContactLawDef hertz;
  hertz.normal = dynamics::NormalModel::Hertz;
  hertz.youngsModulus = 1e7;
  hertz.hasFriction = false;
  dynamics::BoundaryMaterial rigid;
  rigid.rigid = true;
  const auto [soft, softLimit, softChanges] = criticalOf(hertz, std::nullopt);
  const auto [hard, hardLimit, hardChanges] = criticalOf(hertz, rigid);
  EXPECT_NEAR(hardLimit.stiffness / softLimit.stiffness, 2.0, 1e-12);
  EXPECT_NEAR(hard, soft / std::sqrt(2.0), 1e-12 * soft);
}

// Ghosts (a distributed run's mirrors): a pair of two ghosts is not
// computed, a pair with one ghost is, and the flags follow the particles
// through removals; a world without ghosts keeps none.
TEST(World, PairsOfTwoGhostsAreNotComputed) {
  WorldDef<2> def;
  def.contact.kn = 1e5;
  def.contact.hasFriction = false;
  World<2> w(def);
  const auto s = test::sphereShape<2>(0.05);
  for (int k = 0; k < 3; ++k) {
    ParticleDef<2> p;
    p.shape = s;
    p.position = Vec<2>(0.098 * k, 0.0);  // each touches the next
    w.addParticle(p);
  }
  EXPECT_FALSE(w.isGhost(0));
  w.refreshContacts();
  ASSERT_EQ(w.contacts().particleContacts().size(), 2u);
  const auto touching = [&] {
    int n = 0;
    for (const auto& c : w.contacts().particleContacts()) n += c.nodeCount > 0;
    return n;
  };
  EXPECT_EQ(touching(), 2);
  w.setGhost(0, true);
  w.setGhost(1, true);
  EXPECT_FALSE(w.contactsCurrent());
  w.refreshContacts();
  // (0, 1) is left out; (1, 2) has one ghost and stays.
  ASSERT_EQ(w.contacts().particleContacts().size(), 1u);
  EXPECT_EQ(touching(), 1);
  EXPECT_EQ(w.particles().id[w.contacts().particleContacts()[0].b], 2u);
  // Detaching particle 0 moves particle 2 into its place, with its flag.
  w.detachParticle(0);
  ASSERT_EQ(w.particles().size(), 2u);
  EXPECT_FALSE(w.isGhost(0));  // particle 2, not a ghost
  EXPECT_TRUE(w.isGhost(1));
  EXPECT_TRUE(w.removed().empty());  // detached, not removed
  // A given id and mass are kept as given.
  ParticleDef<2> p;
  p.shape = s;
  p.id = 17;
  p.mass = 1.25;
  p.inertia = 0.5;
  p.position = Vec<2>(1.0, 0.0);
  const std::size_t i = w.addParticle(p);
  EXPECT_EQ(w.particles().id[i], 17u);
  EXPECT_EQ(w.particles().mass[i], 1.25);
  EXPECT_EQ(w.particles().inertia[i], 0.5);
  EXPECT_FALSE(w.isGhost(i));
}

// A world that shows another's run (World::showRunOf: a distributed run's
// view): given the run's particles, the velocities its last force evaluation
// saw, its forces and contact histories, it steps on exactly as the run does,
// which is what its checkpoint must do; histories that do not fit are
// refused. (Where a re-evaluation changes a spring in its last bits, as after
// splits, the owners' histories are what keeps it exact:
// tests/parallel/test_run.cpp fails without them.)
TEST(World, ShowRunOfStepsOnAsTheRunDoes) {
  WorldDef<2> def;
  def.gravity = Vec<2>(0.0, -9.81);
  def.contact.kn = 1e5;
  def.contact.ks = 0.8e5;
  def.contact.friction = 0.05;  // low: many node contacts slide, whose springs a re-evaluation caps again
  World<2> run(def), view(def);
  addBox(run, 0.3);
  addBox(view, 0.3);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int k = 0; k < 10; ++k) {
    ParticleDef<2> p;
    p.shape = grain<2>(std::uint64_t(k % 3 + 1), 0.08);
    p.position = Vec<2>(0.06 + 0.18 * u(rng), 0.05 + 0.08 * k);
    p.velocity = 4.0 * Vec<2>(u(rng) - 0.5, -u(rng));
    run.addParticle(p);
  }
  for (int s = 0; s < 1500; ++s) run.step();
  // The last step by halves, keeping the velocities its forces are evaluated with.
  run.beginStep();
  const Particles<2>& p = run.particles();
  const std::vector<Vec<2>> halfVelocity = p.velocity;
  const std::vector<Spin<2>> halfSpin = p.angularVelocity;
  run.finishStep();
  ASSERT_GT(run.contacts().nodeContacts().size(), 0u);

  std::vector<ContactSolver<2>::ParticleHistory> histories;
  std::vector<std::uint64_t> ids;
  for (std::size_t i = 0; i < p.size(); ++i) {
    view.addParticle(p.definition(i));
    histories.push_back(run.contacts().particleHistory(p.id[i]));
    ids.push_back(p.id[i]);
  }
  // In one pass, the same histories.
  const auto all = run.contacts().particleHistories(ids);
  ASSERT_EQ(all.size(), histories.size());
  std::size_t pairsHeld = 0;
  for (std::size_t k = 0; k < all.size(); ++k) {
    ASSERT_EQ(all[k].pairs.size(), histories[k].pairs.size()) << "particle " << ids[k];
    ASSERT_EQ(all[k].nodes.size(), histories[k].nodes.size()) << "particle " << ids[k];
    EXPECT_EQ(all[k].shear, histories[k].shear) << "particle " << ids[k];
    for (std::size_t q = 0; q < all[k].pairs.size(); ++q) {
      EXPECT_EQ(all[k].pairs[q].idA, histories[k].pairs[q].idA);
      EXPECT_EQ(all[k].pairs[q].other, histories[k].pairs[q].other);
      EXPECT_EQ(all[k].pairs[q].first, histories[k].pairs[q].first);
    }
    pairsHeld += all[k].pairs.size();
  }
  EXPECT_GT(pairsHeld, 0u);
  EXPECT_THROW(run.contacts().particleHistories(std::vector<std::uint64_t>{2, 1}), std::invalid_argument);
  std::vector<const ContactSolver<2>::ParticleHistory*> pointers;
  for (const auto& h : histories) pointers.push_back(&h);
  view.adoptHistories(ids, pointers);
  std::vector<World<2>::ShownParticle> shown(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    shown[i] = {halfVelocity[i], halfSpin[i], p.force[i], p.torque[i], &histories[i]};
  }
  // The pairs in contact, as the ranks of a distributed run send them.
  std::vector<std::array<ParticleId, 2>> touching;
  for (const auto& c : run.contacts().particleContacts()) {
    touching.push_back({std::min(p.id[c.a], p.id[c.b]), std::max(p.id[c.a], p.id[c.b])});
  }
  std::sort(touching.begin(), touching.end());
  ASSERT_GT(touching.size(), 2u);
  ASSERT_LT(touching.size(), run.broadPhase().pairs().size()) << "the view must be spared pairs that do not touch";
  view.showRunOf(run, shown, touching, {});
  EXPECT_TRUE(view.contactsCurrent());
  EXPECT_EQ(view.time(), run.time());
  EXPECT_EQ(view.steps(), run.steps());
  EXPECT_EQ(view.contacts().nodeContacts().size(), run.contacts().nodeContacts().size());
  EXPECT_EQ(stateHash(view.particles()), stateHash(run.particles()));
  // A pair left out is not evaluated: a view shown the same run without it
  // finds its histories do not fit.
  {
    World<2> partial(def);
    addBox(partial, 0.3);
    for (std::size_t i = 0; i < p.size(); ++i) partial.addParticle(p.definition(i));
    partial.adoptHistories(ids, pointers);
    const std::vector<std::array<ParticleId, 2>> without(touching.begin() + 1, touching.end());
    EXPECT_THROW(partial.showRunOf(run, shown, without, {}), std::logic_error);
  }
  for (int s = 0; s < 200; ++s) {
    run.step();
    view.step();
  }
  EXPECT_EQ(stateHash(view.particles()), stateHash(run.particles()));

  // Pairs out of order are refused.
  std::vector<std::array<ParticleId, 2>> reversed(touching.rbegin(), touching.rend());
  EXPECT_THROW(view.showRunOf(run, shown, reversed, {}), std::invalid_argument);
  // Histories of another state do not fit: refused, with the reason.
  shown[0].history = &histories[1];
  histories[1].pairs.push_back({999, 998, 0, 0});
  EXPECT_THROW(view.showRunOf(run, shown, touching, {}), std::logic_error);
  shown.pop_back();
  EXPECT_THROW(view.showRunOf(run, shown, touching, {}), std::invalid_argument);
}
