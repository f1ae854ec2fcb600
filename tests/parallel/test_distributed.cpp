// A world spread over 1, 2 or 4 ranks equals the same world on one process,
// bit for bit: grains with friction (shear history that must move with a
// particle to its new rank) fall under gravity through the cuts between the
// subdomains into a box of planes, collide and pile up.
#include "lsdem/parallel/DistributedWorld.h"

#include "lsdem/geometry/ShapeDef.h"
#include "support/Mpi.h"

#include <gtest/gtest.h>
#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <numeric>
#include <random>
#include <span>
#include <string>
#include <thread>
#include <type_traits>
#include <variant>
#include <vector>

namespace lsdem {
namespace {

using dynamics::ParticleDef;
using dynamics::PlaneDef;
using dynamics::World;
using dynamics::WorldDef;
using parallel::DistributedWorld;
using geometry::Vec;

using test::rankOf;

// Three grain shapes: a sphere, an ellipsoid and a random grain, 10 cells across.
template <int D>
std::vector<std::shared_ptr<const geometry::Shape<D>>> shapes(double d) {
  std::vector<std::shared_ptr<const geometry::Shape<D>>> out;
  geometry::ShapeDef<D> sphere;
  sphere.kind = geometry::ShapeKind::Sphere;
  sphere.radius = 0.5 * d;
  sphere.cellsAcross = 10;
  out.push_back(geometry::buildShape(sphere));
  geometry::ShapeDef<D> ellipsoid;
  ellipsoid.kind = geometry::ShapeKind::Ellipsoid;
  ellipsoid.semiAxes = Vec<D>::Constant(0.4 * d);
  ellipsoid.semiAxes[0] = 0.6 * d;
  ellipsoid.cellsAcross = 10;
  out.push_back(geometry::buildShape(ellipsoid));
  geometry::ShapeDef<D> grain;
  grain.kind = geometry::ShapeKind::RandomGrain;
  grain.grain.equivalentDiameter = d;
  grain.grain.elongation = 1.3;
  grain.grain.roughness = 0.1;
  grain.grain.seed = 7;
  grain.cellsAcross = 10;
  out.push_back(geometry::buildShape(grain));
  return out;
}

// What a run adds to the pile.
enum class Extra {
  None,
  Servo,  // a plate above the bed, as wide as the box, pressed down by a servo to a force it reaches within the run
  Flow,   // no wall at x = 0: grains that pass it by a diameter leave (outflow); a feed drops grains at the far end
  Lift,   // a user's own effect (Lift, declared distributable)
  SlowRank0,  // rank 0 is several times slower per node (Delay), and the run balances by time
};

// A user's own effect: an upward pull on each particle above a height,
// from the particle's own state (its work booked like gravity's). Declared
// distributable, it runs on N ranks; not declared, it is refused, whatever
// its name.
template <int D>
class Lift final : public dynamics::Effect<D> {
 public:
  Lift(bool distributable, std::string name) : distributable_(distributable), name_(std::move(name)) {}
  std::string name() const override { return name_; }
  bool distributable() const override { return distributable_; }
  void applyForces(World<D>& world, double dt) override {
    const dynamics::Particles<D>& p = world.particles();
    const std::span<Vec<D>> force = world.forces();
    double power = 0.0;
    for (std::size_t i = 0; i < p.size(); ++i) {
      if (world.isGhost(i) || p.position[i][1] < 0.03) continue;
      const Vec<D> f = 3.0 * p.mass[i] * Vec<D>::Unit(1);
      force[i] += f;
      power += f.dot(p.velocity[i]);
    }
    world.addGravityWork(power * dt);
  }

 private:
  bool distributable_;
  std::string name_;
};

// An effect that only takes time where `sleeps` (the distributed world on
// rank 0): 0.3 us per surface node of the particles it owns in every step,
// about 6x what a node's contacts cost, as on a core several times slower.
// Nothing to the motion.
template <int D>
class Delay final : public dynamics::Effect<D> {
 public:
  explicit Delay(bool sleeps) : sleeps_(sleeps) {}
  std::string name() const override { return "delay"; }
  bool distributable() const override { return true; }
  void applyForces(World<D>& world, double) override {
    if (!sleeps_) return;
    std::size_t nodes = 0;
    for (std::size_t i = 0; i < world.particles().size(); ++i) {
      if (!world.isGhost(i)) nodes += world.particles().shape[i]->nodes().size();
    }
    std::this_thread::sleep_for(std::chrono::nanoseconds(300 * nodes));
  }

 private:
  bool sleeps_;
};

// A box of planes (floor at height 0, walls at 0 and `boxWidth`, default
// the lattice's width, across every other axis) and a lattice of grains above the floor with random offsets,
// orientations and velocities (the same on every rank: a fixed seed), with
// `extra`. Returns the feed (Extra::Flow), else null.
template <int D>
const dynamics::Feed<D>* build(World<D>& w, int perSide, int layers, Extra extra = Extra::None, double boxWidth = 0.0) {
  const double d = 0.01;
  const double pitch = 1.1 * d;
  const double width = boxWidth > 0.0 ? boxWidth : perSide * pitch;
  const int up = 1;  // the vertical axis
  PlaneDef<D> floor;
  floor.name = "floor";
  floor.plane.normal = Vec<D>::Unit(up);
  w.addPlane(floor);
  for (int a = 0; a < D; ++a) {
    if (a == up) continue;
    PlaneDef<D> lo, hi;
    lo.plane.normal = Vec<D>::Unit(a);
    hi.plane.point = Vec<D>::Unit(a) * width;
    hi.plane.normal = -Vec<D>::Unit(a);
    if (a != 0 || extra != Extra::Flow) w.addPlane(lo);
    w.addPlane(hi);
  }
  const auto pool = shapes<D>(d);
  const dynamics::Feed<D>* fed = nullptr;
  if (extra == Extra::Flow) {
    // Grains whose centroid passes x = 0 by a diameter leave (in 3D, whose
    // run is 30 times shorter, those that come within 0.3 d of it); those
    // low over the floor are recorded as discharged.
    Vec<D> lo = Vec<D>::Constant(-1.0), hi = Vec<D>::Constant(1.0);
    lo[0] = D == 2 ? -d : 0.3 * d;
    Vec<D> dlo = Vec<D>::Constant(-1.0), dhi = Vec<D>::Constant(1.0);
    dhi[up] = D == 2 ? 0.5 * d : pitch;
    w.addEffect(std::make_unique<dynamics::Outflow<D>>(geometry::Box<D>{lo, hi}, geometry::Box<D>{dlo, dhi}));
    // A grain every 2 ms (3D: 0.4 ms) at the far end, above the bed, thrown
    // towards the gap, once the last one has cleared the point.
    dynamics::FeedDef<D> feed;
    feed.shapes = {pool[0], pool[2]};
    feed.point = Vec<D>::Constant(0.5 * width);
    feed.point[0] = width - 0.6 * d;
    feed.point[up] = (layers + 1.5) * pitch;
    feed.velocity[0] = D == 2 ? -1.5 : -8.0;  // (clear of the point within the short 3D run)
    feed.interval = D == 2 ? 2e-3 : 4e-4;
    auto effect = std::make_unique<dynamics::Feed<D>>(feed);
    fed = effect.get();
    w.addEffect(std::move(effect));
  }
  if (extra == Extra::Lift) w.addEffect(std::make_unique<Lift<D>>(true, "lift"));
  if (extra == Extra::Servo) {
    geometry::ShapeDef<D> plate;
    plate.kind = geometry::ShapeKind::Box;
    plate.halfExtents = Vec<D>::Constant(0.5 * width);
    plate.halfExtents[up] = 0.5 * d;
    plate.spacing = 0.25 * d;
    dynamics::ServoPlatenDef<D> s;
    s.position = Vec<D>::Constant(0.5 * width);
    s.position[up] = (layers - 0.3) * pitch + 0.9 * d;  // on the top layer
    s.targetForce = D == 2 ? 300.0 : 3.0;
    s.gain = 1e-3;
    s.maxSpeed = 0.3;
    dynamics::ToolDef<D> tool;
    tool.name = "servo";
    tool.shape = geometry::buildShape(plate);
    tool.motion = dynamics::ServoPlaten<D>(s);
    w.addTool(tool);
  }
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int across = D == 3 ? perSide * perSide : perSide;
  for (int layer = 0; layer < layers; ++layer) {
    for (int k = 0; k < across; ++k) {
      ParticleDef<D> p;
      p.shape = pool[std::size_t(layer + k) % pool.size()];
      p.density = 2650.0;
      Vec<D> x;
      x[0] = (k % perSide + 0.5) * pitch + 0.1 * d * u(rng);
      x[up] = (layer + 0.7) * pitch + 0.1 * d * u(rng);
      if constexpr (D == 3) x[2] = (k / perSide + 0.5) * pitch + 0.1 * d * u(rng);
      p.position = x;
      for (int a = 0; a < D; ++a) p.velocity[a] = 0.3 * u(rng);
      p.velocity[0] -= 1.5;  // the whole bed moves across the cuts into the wall at x = 0
      if constexpr (D == 2) {
        p.orientation = 3.0 * u(rng);
        p.angularVelocity = 20.0 * u(rng);
      } else {
        p.orientation = Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized();
        p.angularVelocity = 20.0 * Vec<3>(u(rng), u(rng), u(rng));
      }
      w.addParticle(p);
    }
  }
  return fed;
}

// The damping effects (their losses are booked per owned particle): local
// damping on the pile, global damping under the servo.
template <int D>
WorldDef<D> worldDef(Extra extra = Extra::Flow) {
  WorldDef<D> def;
  Vec<D> g = Vec<D>::Zero();
  g[1] = -9.81;
  def.gravity = g;
  def.contact.kn = 2e5;
  def.contact.ks = 1.6e5;
  def.contact.friction = 0.5;
  def.contact.dampingRatio = 0.3;
  if (extra == Extra::None || extra == Extra::Lift || extra == Extra::SlowRank0) def.localDamping = 0.05;
  if (extra == Extra::Servo) def.globalDamping = 0.5;
  return def;
}

// Runs `steps` steps serially and distributed; every rank checks that the
// gathered state equals the serial one bit for bit; `stats` (if given) gets
// this rank's exchange counts.
template <int D>
void expectEqualToSerial(int perSide, int layers, std::uint64_t steps, Extra extra = Extra::None,
                         parallel::ExchangeStats* stats = nullptr, double boxWidth = 0.0) {
  MPI_Comm comm = MPI_COMM_WORLD;
  World<D> serial(worldDef<D>(extra));
  const dynamics::Feed<D>* serialFeed = build(serial, perSide, layers, extra, boxWidth);
  World<D> local(worldDef<D>(extra));
  const dynamics::Feed<D>* localFeed = build(local, perSide, layers, extra, boxWidth);
  parallel::DistributedDef def;
  def.rebalanceEvery = 100;
  def.rebalanceImbalance = 1.05;
  if (extra == Extra::SlowRank0) {
    local.addEffect(std::make_unique<Delay<D>>(rankOf(comm) == 0));
    def.balance = parallel::DistributedDef::Balance::Time;
  }
  DistributedWorld<D> dist(comm, local, def);
  ASSERT_EQ(dist.globalCount(), serial.particles().size());

  serial.run(steps);
  dist.run(steps);
  if (stats) *stats = dist.stats();
  EXPECT_EQ(local.dt(), serial.dt());
  EXPECT_EQ(local.time(), serial.time());
  // The energy budget, summed over the ranks (each books its own particles
  // and the pairs whose lower id is its own), is the serial one.
  const dynamics::EnergyLedger& budget = serial.energy();
  test::expectSameLedger(dist.energy(), budget);
  EXPECT_NE(budget.gravityWork, 0.0);
  EXPECT_GT(budget.contactLoss, 0.0);
  if (extra != Extra::Flow) {
    EXPECT_GT(budget.dampingLoss, 0.0);
  }
  if (extra == Extra::Servo) {
    EXPECT_NE(budget.boundaryWork, 0.0);
  }
  if (extra == Extra::Flow) {
    EXPECT_GT(budget.removedEnergy, 0.0);
    EXPECT_GT(budget.addedEnergy, 0.0);
  }

  const auto states = dist.gather(0);
  const auto removed = dist.gatherRemoved(0);
  const dynamics::Particles<D>& p = serial.particles();
  if (rankOf(comm) == 0) {
    ASSERT_EQ(states.size(), p.size());
    // The serial particles by id (gather's order).
    std::vector<std::size_t> byId(p.size());
    std::iota(byId.begin(), byId.end(), std::size_t(0));
    std::sort(byId.begin(), byId.end(), [&](std::size_t x, std::size_t y) { return p.id[x] < p.id[y]; });
    std::size_t moved = 0, spun = 0;
    for (std::size_t k = 0; k < states.size(); ++k) {
      const std::size_t i = byId[k];
      ASSERT_EQ(p.id[i], states[k].id);
      for (int a = 0; a < D; ++a) {
        EXPECT_EQ(states[k].position[a], p.position[i][a]) << "particle " << i << " axis " << a;
        EXPECT_EQ(states[k].velocity[a], p.velocity[i][a]) << "particle " << i << " axis " << a;
      }
      if constexpr (D == 2) {
        EXPECT_EQ(states[k].orientation, p.orientation[i]);
        EXPECT_EQ(states[k].angularVelocity, p.angularVelocity[i]);
        spun += std::abs(p.angularVelocity[i]) > 0.0;
      } else {
        EXPECT_EQ(states[k].orientation.coeffs(), p.orientation[i].coeffs());
        EXPECT_EQ(states[k].angularVelocity, p.angularVelocity[i]);
        spun += p.angularVelocity[i].norm() > 0.0;
      }
      moved += p.velocity[i].norm() > 0.0;
    }
    EXPECT_GT(moved, 0u);
    EXPECT_GT(spun, 0u);
    // The removal records, in the serial order.
    const auto& ref = serial.removed();
    ASSERT_EQ(removed.size(), ref.size());
    for (std::size_t k = 0; k < ref.size(); ++k) {
      EXPECT_EQ(removed[k].id, ref[k].id) << "record " << k;
      EXPECT_EQ(removed[k].time, ref[k].time) << "record " << k;
      EXPECT_EQ(removed[k].mass, ref[k].mass) << "record " << k;
      EXPECT_EQ(removed[k].reason, ref[k].reason) << "record " << k;
    }
  }
  if (extra == Extra::Flow) {
    // Grains left through the gap and through the discharge, and the feed
    // dropped grains (the same ones on every rank), some of them after a
    // removal: ids stay those of one world.
    const auto& ref = serial.removed();
    const auto reasons = [&](const std::string& reason) {
      return std::count_if(ref.begin(), ref.end(), [&](const dynamics::RemovedParticle& r) { return r.reason == reason; });
    };
    EXPECT_GT(reasons("outflow"), 0);
    EXPECT_GT(reasons("discharge"), 0);
    ASSERT_NE(serialFeed, nullptr);
    EXPECT_GE(serialFeed->dropped(), 2u);
    EXPECT_EQ(localFeed->dropped(), serialFeed->dropped());
    EXPECT_EQ(localFeed->droppedMass(), serialFeed->droppedMass());
    EXPECT_GT(p.nextId(), std::uint64_t(layers * (D == 3 ? perSide * perSide : perSide)));
  }
  // The run was busy: contacts with shear history, and (on several ranks)
  // particles that changed rank.
  EXPECT_GT(serial.contacts().historySize(), 0u);
  std::uint64_t migrations = dist.stats().migrations;
  MPI_Allreduce(MPI_IN_PLACE, &migrations, 1, MPI_UINT64_T, MPI_SUM, comm);
  // The bed piles up against the wall, so the load goes out of balance and
  // the cuts move (rebalance) while particles are in contact across them.
  std::uint64_t rebalances = dist.stats().rebalances;
  MPI_Allreduce(MPI_IN_PLACE, &rebalances, 1, MPI_UINT64_T, MPI_MAX, comm);
  if (dist.ranks() > 1) {
    EXPECT_GT(migrations, 0u);
    EXPECT_GT(rebalances, 0u);
  }
  if (extra == Extra::SlowRank0 && dist.ranks() > 1) {
    // Rank 0, the slow one, holds well under the others' nodes (by nodes
    // alone, each rank would hold about the mean).
    EXPECT_GT(dist.stats().workSeconds, 0.0);
    double nodes = 0.0;
    for (std::size_t i = 0; i < local.particles().size(); ++i) {
      if (!local.isGhost(i)) nodes += double(local.particles().shape[i]->nodes().size());
    }
    std::vector<double> all(static_cast<std::size_t>(dist.ranks()));
    MPI_Allgather(&nodes, 1, MPI_DOUBLE, all.data(), 1, MPI_DOUBLE, comm);
    const double others = std::accumulate(all.begin() + 1, all.end(), 0.0) / double(dist.ranks() - 1);
    EXPECT_LT(all[0], 0.6 * others) << "rank 0 holds " << all[0] << " nodes, the others " << others << " each";
  }

  // The boundary loads of the whole run, on every rank, are the serial ones
  // bit for bit while the serial particles are in id order (summed in the
  // serial order), and so is what the servo made of them. After a removal
  // the serial sum takes another order: equal to round-off.
  const auto loads = dist.boundaryLoads();
  const auto& ref = serial.boundaryLoads();
  const bool inIdOrder = serial.removed().empty();
  const auto expectSame = [&](const auto& got, const auto& want, const char* what, std::size_t j) {
    if (inIdOrder) {
      EXPECT_EQ(got, want) << what << " " << j;
    } else {
      const auto size = [](const auto& v) {
        if constexpr (std::is_arithmetic_v<std::decay_t<decltype(v)>>) {
          return std::abs(v);
        } else {
          return v.norm();
        }
      };
      EXPECT_LE(size(got - want), 1e-12 * size(want) + 1e-300) << what << " " << j;
    }
  };
  ASSERT_EQ(loads.planeForce.size(), ref.planeForce.size());
  for (std::size_t j = 0; j < ref.planeForce.size(); ++j) {
    expectSame(loads.planeForce[j], ref.planeForce[j], "plane", j);
    expectSame(loads.planeTorque[j], ref.planeTorque[j], "plane", j);
  }
  ASSERT_EQ(loads.toolForce.size(), ref.toolForce.size());
  for (std::size_t j = 0; j < ref.toolForce.size(); ++j) {
    expectSame(loads.toolForce[j], ref.toolForce[j], "tool", j);
    expectSame(loads.toolTorque[j], ref.toolTorque[j], "tool", j);
    expectSame(local.boundaryLoads().toolForce[j], ref.toolForce[j], "tool", j);
  }
  if (extra == Extra::Servo) {
    const auto& platen = std::get<dynamics::ServoPlaten<D>>(serial.tools()[0].motion);
    const auto& mine = std::get<dynamics::ServoPlaten<D>>(local.tools()[0].motion);
    EXPECT_EQ(mine.displacement(), platen.displacement());
    EXPECT_EQ(mine.speed(), platen.speed());
    // The servo pressed on the bed (its measured force, as it reads it) and
    // was slowed by it.
    const double measured = -ref.toolForce[0].dot(platen.def().direction);
    EXPECT_GT(measured, 0.2 * platen.def().targetForce);
    EXPECT_GT(platen.displacement(), 0.0);
    EXPECT_LT(std::abs(platen.speed()), platen.def().maxSpeed);
  }
}

TEST(DistributedWorld, TwoDimensionalPileEqualsSerialBitForBit) { expectEqualToSerial<2>(12, 8, 2000); }

// A long, low bed (40 grains by 3 layers): on 3 or more ranks the cuts are
// slabs across it, and a rank exchanges with the subdomains near it only (no
// message to the others, and no all-to-all but after a rebalance); the run
// equals one world bit for bit.
TEST(DistributedWorld, LongBedExchangesWithNeighboursOnly) {
  parallel::ExchangeStats stats;
  expectEqualToSerial<2>(40, 3, 2000, Extra::None, &stats);
  MPI_Comm comm = MPI_COMM_WORLD;
  int ranks = 1;
  MPI_Comm_size(comm, &ranks);
  if (ranks == 1) return;
  EXPECT_GT(stats.neighbourExchanges, 0u);
  EXPECT_GE(stats.neighbours, 1u);
  std::uint64_t neighbours = stats.neighbours, global = stats.globalExchanges, rebalances = stats.rebalances;
  MPI_Allreduce(MPI_IN_PLACE, &neighbours, 1, MPI_UINT64_T, MPI_SUM, comm);
  MPI_Allreduce(MPI_IN_PLACE, &global, 1, MPI_UINT64_T, MPI_MAX, comm);
  MPI_Allreduce(MPI_IN_PLACE, &rebalances, 1, MPI_UINT64_T, MPI_MAX, comm);
  // Slabs across the bed (as the cuts are after the rebalances): some ranks
  // are not neighbours.
  if (ranks >= 3) {
    EXPECT_LT(neighbours, std::uint64_t(ranks * (ranks - 1)));
  }
  // An all-to-all only after a rebalance (the cuts moved past some
  // particles): here no particle drifts beyond its neighbours in a step, and
  // no fragment is born.
  EXPECT_LE(global, rebalances);
  if (rankOf(comm) == 0) {
    std::printf("[ %d ranks ] %llu neighbours in all, %llu exchanges with neighbours, %llu all-to-all, %llu rebalances\n",
                ranks, (unsigned long long)neighbours, (unsigned long long)stats.neighbourExchanges,
                (unsigned long long)global, (unsigned long long)rebalances);
  }
}

// A tall column (3 grains by 24) thrown into the wall of a wide box
// collapses across it: the cuts, first across the column's height, come to
// cut across its run-out at a rebalance, and on 4 ranks some particles then
// go to owners that are not neighbours of their old ones (that exchange is
// an all-to-all). The run equals one world bit for bit.
TEST(DistributedWorld, CollapsingColumnEqualsSerialThroughFarRebalances) {
  parallel::ExchangeStats stats;
  expectEqualToSerial<2>(3, 24, 3000, Extra::None, &stats, 0.44);
  MPI_Comm comm = MPI_COMM_WORLD;
  int ranks = 1;
  MPI_Comm_size(comm, &ranks);
  std::uint64_t global = stats.globalExchanges;
  MPI_Allreduce(MPI_IN_PLACE, &global, 1, MPI_UINT64_T, MPI_MAX, comm);
  if (ranks == 4) {
    EXPECT_GE(global, 1u);
  }
}

TEST(DistributedWorld, ThreeDimensionalPileEqualsSerialBitForBit) { expectEqualToSerial<3>(5, 4, 2000); }

// A servo platen moves by the load of the whole run, the same on every rank.
TEST(DistributedWorld, PileUnderServoPlatenEqualsSerialBitForBit) { expectEqualToSerial<2>(12, 8, 2000, Extra::Servo); }

// Grains leave through an outflow and a feed drops new ones, on every rank
// alike: ids, states and removal records are those of one world.
TEST(DistributedWorld, OpenPileWithOutflowAndFeedEqualsSerialBitForBit) {
  expectEqualToSerial<2>(12, 8, 2000, Extra::Flow);
}
TEST(DistributedWorld, OpenPileWithOutflowAndFeedEqualsSerialBitForBit3D) {
  expectEqualToSerial<3>(5, 4, 2000, Extra::Flow);
}

// The RCB cuts give every part its share of the weight and the owner of a
// point is the part whose box holds it.
TEST(Decomposition, BalancesWeightAndOwnsByBox) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Vec<3>> points(3000);
  std::vector<double> weights(points.size());
  for (std::size_t k = 0; k < points.size(); ++k) {
    points[k] = Vec<3>(2.0 * u(rng), u(rng), 0.5 * u(rng));
    weights[k] = 1.0 + double(k % 3);
  }
  for (int parts : {1, 2, 3, 4, 7}) {
    const auto d = parallel::Decomposition<3>::build(points, weights, parts);
    std::vector<double> load(std::size_t(parts), 0.0);
    double total = 0.0;
    for (std::size_t k = 0; k < points.size(); ++k) {
      const int o = d.owner(points[k]);
      ASSERT_GE(o, 0);
      ASSERT_LT(o, parts);
      EXPECT_TRUE(d.box(o).contains(points[k]));
      EXPECT_EQ(d.distance(points[k], o), 0.0);
      load[std::size_t(o)] += weights[k];
      total += weights[k];
    }
    for (double l : load) EXPECT_NEAR(l, total / parts, 3.0 + 0.002 * total) << parts << " parts";
  }
}

// Parts with capacities (Balance::Time: the ranks' speeds) get the weight
// in proportion to them; a capacity that is not positive is refused.
TEST(Decomposition, SharesWeightByCapacity) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Vec<2>> points(4000);
  std::vector<double> weights(points.size());
  for (std::size_t k = 0; k < points.size(); ++k) {
    points[k] = Vec<2>(3.0 * u(rng), u(rng));
    weights[k] = 1.0 + double(k % 4);
  }
  const double total = std::accumulate(weights.begin(), weights.end(), 0.0);
  for (const std::vector<double>& capacities :
       {std::vector<double>{1.0, 3.0}, std::vector<double>{2.0, 1.0, 1.0}, std::vector<double>{0.5, 4.0, 1.0, 2.5}}) {
    const int parts = int(capacities.size());
    const auto d = parallel::Decomposition<2>::build(points, weights, parts, capacities);
    std::vector<double> load(capacities.size(), 0.0);
    for (std::size_t k = 0; k < points.size(); ++k) load[std::size_t(d.owner(points[k]))] += weights[k];
    const double all = std::accumulate(capacities.begin(), capacities.end(), 0.0);
    for (int q = 0; q < parts; ++q) {
      EXPECT_NEAR(load[std::size_t(q)], total * capacities[std::size_t(q)] / all, 4.0 + 0.002 * total)
          << parts << " parts, part " << q;
    }
  }
  const std::vector<double> bad{1.0, 0.0};
  EXPECT_THROW(parallel::Decomposition<2>::build(points, weights, 2, bad), std::invalid_argument);
  const std::vector<double> short_{1.0};
  EXPECT_THROW(parallel::Decomposition<2>::build(points, weights, 2, short_), std::invalid_argument);
}

// The distance between two subdomains (the neighbours' test): symmetric, 0
// for a part and itself and for parts that share a cut, finite with the
// outer boxes' infinite sides, and never more than a point of one part is
// from the other (a lower bound, exact for parts that touch).
TEST(Decomposition, DistanceBetweenPartsBoundsThatOfTheirPoints) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Vec<3>> points(4000);
  std::vector<double> weights(points.size(), 1.0);
  for (Vec<3>& x : points) x = Vec<3>(4.0 * u(rng), u(rng), u(rng));
  for (int parts : {2, 4, 7, 16}) {
    const auto d = parallel::Decomposition<3>::build(points, weights, parts);
    std::size_t touching = 0, apart = 0;
    for (int a = 0; a < parts; ++a) {
      EXPECT_EQ(d.distance(a, a), 0.0);
      for (int b = 0; b < parts; ++b) {
        const double ab = d.distance(a, b);
        ASSERT_TRUE(std::isfinite(ab)) << a << " " << b;
        EXPECT_EQ(ab, d.distance(b, a));
        if (a == b) continue;
        double nearest = std::numeric_limits<double>::infinity();
        for (const Vec<3>& x : points) {
          if (d.owner(x) == a) nearest = std::min(nearest, d.distance(x, b));
        }
        EXPECT_LE(ab, nearest) << parts << " parts: " << a << " " << b;
        (ab == 0.0 ? touching : apart) += 1;
      }
    }
    // Two parts share the first cut; along a bed 4 long, 7 and 16 parts are
    // slabs and blocks, some of them apart.
    EXPECT_GE(touching, 2u);
    if (parts >= 7) {
      EXPECT_GT(apart, 0u) << parts << " parts";
    }
    if (parts == 2) {
      EXPECT_EQ(d.distance(0, 1), 0.0);
    }
  }
}

// Balance by time: rank 0 takes several times longer per node (Delay), so
// the rebalances give it fewer nodes than the others (by nodes it would
// hold the mean); the results stay those of one world, bit for bit.
TEST(DistributedWorld, BalanceByTimeMovesWorkOffASlowRank) { expectEqualToSerial<2>(12, 8, 2000, Extra::SlowRank0); }

TEST(DistributedWorld, RunsAUsersDistributableEffectAndRefusesOthers) {
  expectEqualToSerial<2>(12, 8, 2000, Extra::Lift);
  // Not declared distributable: refused on every rank, even named "gravity".
  World<2> other(worldDef<2>());
  build(other, 4, 1);
  other.addEffect(std::make_unique<Lift<2>>(false, "gravity"));
  EXPECT_THROW(DistributedWorld<2>(MPI_COMM_WORLD, other), std::invalid_argument);
}

// A world that is not the same on every rank, or a DistributedDef, is refused with the reason.
TEST(DistributedWorld, RefusesWorldsThatDifferBetweenRanks) {
  int ranks = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  if (ranks < 2) GTEST_SKIP() << "needs 2 ranks";
  World<2> w(worldDef<2>());
  build(w, 4, 1 + rankOf(MPI_COMM_WORLD));
  EXPECT_THROW(DistributedWorld<2>(MPI_COMM_WORLD, w), std::invalid_argument);
  // The same world, but rank 1 would balance by time: refused too (the
  // ranks would take different rebalances).
  World<2> same(worldDef<2>());
  build(same, 4, 1);
  parallel::DistributedDef def;
  if (rankOf(MPI_COMM_WORLD) == 1) def.balance = parallel::DistributedDef::Balance::Time;
  EXPECT_THROW(DistributedWorld<2>(MPI_COMM_WORLD, same, def), std::invalid_argument);
  World<2> alike(worldDef<2>());
  build(alike, 4, 1);
  EXPECT_NO_THROW(DistributedWorld<2>(MPI_COMM_WORLD, alike, parallel::DistributedDef{}));
}

}  // namespace
}  // namespace lsdem
