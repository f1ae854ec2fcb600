/// @file bench_world.cpp
/// @brief Whole-world benchmarks of the dynamics layer: World::step() on dense
/// packings settled under gravity, timed one step per iteration (wall clock,
/// all OpenMP threads; set OMP_NUM_THREADS to compare 1 and 2 threads).
///
/// Benchmarks
/// - BM_WorldPacking3D: 1000 blocky superellipsoids (semi-axes about
///   (1.2, 1.0, 0.8) cm, exponents 3.5-4), 20 grid cells across the smallest
///   axis, ~2100 surface nodes each; 3 shapes shared by all particles;
///   10 layers of 10 x 10.
/// - BM_WorldPacking2D: 10,000 discs (radius 0.47-0.5 cm), 20 cells across the
///   smallest, ~95 nodes each; 3 shapes shared by all particles; a square box.
/// - BM_WorldScaling2D: the 2D set-up at 1k, 10k and 100k discs (fewer
///   settling steps); the time per particle-step should stay flat as N grows.
///
/// Packings. Both start as stable, touching packings built geometrically
/// (no overlaps beyond a set fraction of a grid cell), so gravity only has to
/// load the contacts, not rearrange the particles:
/// - 3D (brickLattice): particles with random tilts on a brick-bond lattice,
///   each lowered until its first node touches the layer below.
/// - 2D (depositedDiscs): discs deposited one by one; each rolls over the
///   discs it lands on until it rests on two of them, a wall or the floor.
/// A box of planes (floor and side walls, open top) holds the packing; gravity
/// and local (Cundall) damping then settle it for a number of steps before the
/// timed loop.
///
/// Contact law: the paper's (linear per node, Coulomb friction mu = 0.6 with
/// shear history, ks = 0.8 kn, C_res = 0.4), with kn chosen so that the weight
/// of a full column of particles, pressed on a particle's stiffest contact
/// patch (TimeStep.h stiffestContact), compresses it by `loadOverlap` of the
/// smallest particle dimension; the automatic time step follows from kn. That
/// ties the stiffness to gravity so the packing settles in a few hundred
/// steps. The cost of a step does not depend on kn, only on the number of
/// candidate pairs and node contacts, which the counters report.
///
/// Counters (per benchmark run)
/// - "node checks/s": ContactSolver::nodeChecks() summed over the timed steps
///   (nodes tested against a level set or plane), per second of wall time.
/// - "particle-steps/s" and "s/particle-step" (particles x steps per second of
///   wall time, and its inverse).
/// - "contacts/p": particle-particle contacts counted at both particles plus
///   particle-wall contacts, per particle, at the end of the timed loop;
///   "node contacts/p", "pairs/p" (broad-phase candidates per particle),
///   "rebuilds/step" (broad-phase rebuilds per timed step),
///   "nodes/p" (mean surface nodes per particle), "overlap/h" (mean overlap of
///   the node contacts in grid cells; the shapes of a set share one spacing).
/// - "sh.<stage>": share of the timed wall time spent in each stage of
///   World::stageSeconds() (broad phase, narrow phase, accumulate, effects,
///   integrate); "sh.other" is the rest (kinematics, after-step, energy
///   refresh, loop overhead).
/// - Memory per particle: "store B/p" is the particle store's per-particle
///   arrays (sum of the element sizes of every Particles vector, i.e. the
///   record size; vectors grown by push_back may hold up to 2x that in
///   capacity); "shapes B/p" is the bytes of the distinct shared shapes
///   (Shape::bytes(): grid values and nodes) divided by N; "contacts B/p" is
///   the capacity of the contact solver's public output (node contacts, shear,
///   pair records) plus the broad-phase pair list, divided by N. Internal
///   scratch (thread buffers, history index, broad-phase cells) is not visible
///   through the API and is not counted.
/// - "threads": OpenMP threads; "setup s": wall time of building and settling
///   (outside the timed loop).

#include "Packings.h"

#include "lsdem/dynamics/TimeStep.h"
#include "lsdem/dynamics/World.h"
#include "lsdem/geometry/ShapeDef.h"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <numbers>
#include <random>
#include <tuple>
#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

using namespace lsdem;
using namespace lsdem::dynamics;

namespace {

using Clock = std::chrono::steady_clock;
using namespace lsdem::bench;


double secondsSince(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

int threadCount() {
#ifdef _OPENMP
  return omp_get_max_threads();
#else
  return 1;
#endif
}

// ---------------------------------------------------------------- counters --

template <class T>
std::size_t bytesOf(const std::vector<T>& v) {
  return v.size() * sizeof(T);
}
template <class T>
std::size_t capacityBytesOf(const std::vector<T>& v) {
  return v.capacity() * sizeof(T);
}

// Per-particle bytes of the particle store's arrays (element sizes, see the file comment).
template <int D>
double storeBytesPerParticle(const Particles<D>& p) {
  const std::size_t bytes = bytesOf(p.position) + bytesOf(p.orientation) + bytesOf(p.velocity) +
                            bytesOf(p.angularVelocity) + bytesOf(p.force) + bytesOf(p.torque) + bytesOf(p.mass) +
                            bytesOf(p.invMass) + bytesOf(p.inertia) + bytesOf(p.invInertia) + bytesOf(p.shape) +
                            bytesOf(p.material) + bytesOf(p.strength) + bytesOf(p.id) + bytesOf(p.parentId) +
                            bytesOf(p.generation) + bytesOf(p.birthTime);
  return double(bytes) / double(p.size());
}

// Times world.step() once per iteration and reports the counters of the file comment.
template <int D>
void timeSteps(benchmark::State& state, World<D>& world, const std::vector<ShapePtr<D>>& shapes, double setupSeconds) {
  const auto stagesBefore = world.stageSeconds();
  const std::size_t rebuildsBefore = world.broadPhase().rebuilds();
  std::uint64_t nodeChecks = 0;
  const auto t0 = Clock::now();
  for (auto _ : state) {
    world.step();
    nodeChecks += world.contacts().nodeChecks();
  }
  const double wall = secondsSince(t0);
  const double n = double(world.particles().size());
  const double steps = double(state.iterations());

  // Throughput.
  state.counters["node checks/s"] = benchmark::Counter(double(nodeChecks), benchmark::Counter::kIsRate);
  state.counters["particle-steps/s"] = benchmark::Counter(n * steps, benchmark::Counter::kIsRate);
  state.counters["s/particle-step"] =
      benchmark::Counter(n * steps, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);

  // The packing at the end of the loop.
  const ContactSolver<D>& c = world.contacts();
  std::size_t touching = 0;
  for (const PairContact<D>& pc : c.particleContacts()) touching += pc.nodeCount > 0 ? 1 : 0;
  std::size_t wallContacts = 0;
  for (const PairContact<D>& pc : c.planeContacts()) wallContacts += pc.nodeCount > 0 ? 1 : 0;
  double nodes = 0.0;
  for (const ShapePtr<D>& s : world.particles().shape) nodes += double(s->nodes().size());
  double overlap = 0.0;
  for (const NodeContact<D>& nc : c.nodeContacts()) overlap += nc.overlap;
  state.counters["particles"] = n;
  state.counters["contacts/p"] = (2.0 * double(touching) + double(wallContacts)) / n;
  state.counters["node contacts/p"] = double(c.nodeContacts().size()) / n;
  state.counters["pairs/p"] = double(world.broadPhase().pairs().size()) / n;
  state.counters["nodes/p"] = nodes / n;
  state.counters["rebuilds/step"] = double(world.broadPhase().rebuilds() - rebuildsBefore) / steps;
  state.counters["overlap/h"] =
      c.nodeContacts().empty() ? 0.0 : overlap / double(c.nodeContacts().size()) / shapes.front()->grid().spacing();

  // Where the time goes.
  const auto& stages = world.stageSeconds();
  auto share = [&](Stage s) { return (stages[std::size_t(s)] - stagesBefore[std::size_t(s)]) / wall; };
  state.counters["sh.broad"] = share(Stage::BroadPhase);
  state.counters["sh.narrow"] = share(Stage::NarrowPhase);
  state.counters["sh.accum"] = share(Stage::Accumulate);
  state.counters["sh.effects"] = share(Stage::Effects);
  state.counters["sh.integr"] = share(Stage::Integrate);
  state.counters["sh.other"] = 1.0 - share(Stage::BroadPhase) - share(Stage::NarrowPhase) - share(Stage::Accumulate) -
                               share(Stage::Effects) - share(Stage::Integrate);

  // Memory per particle.
  double shapeBytes = 0.0;
  for (const ShapePtr<D>& s : shapes) shapeBytes += double(s->bytes());
  state.counters["store B/p"] = storeBytesPerParticle(world.particles());
  state.counters["shapes B/p"] = shapeBytes / n;
  state.counters["contacts B/p"] =
      double(c.recordBytes() + capacityBytesOf(world.broadPhase().pairs())) /
      n;
  state.counters["threads"] = threadCount();
  state.counters["setup s"] = setupSeconds;
}

// ------------------------------------------------------------- benchmarks --

// 1000 superellipsoids, ~2100 nodes each: 10 layers of 10 x 10.
void BM_WorldPacking3D(benchmark::State& state) {
  const auto t0 = Clock::now();
  const auto& shapes = blockShapes3D();
  PackingDef def;
  def.particles = 1000;
  def.perRow = 10;
  def.settleSteps = int(state.range(0));
  const auto world = settledWorld<3>(shapes, brickLattice(shapes, def), def);
  timeSteps<3>(state, *world, shapes, secondsSince(t0));
}
BENCHMARK(BM_WorldPacking3D)->ArgName("settle")->Arg(500)->Iterations(20)->Unit(benchmark::kMillisecond)->UseRealTime();

// N = range(0) discs, ~95 nodes each, in a square box (sqrt(N) deposition targets per row).
void BM_WorldPacking2D(benchmark::State& state) {
  const auto t0 = Clock::now();
  const auto& shapes = discShapes2D();
  PackingDef def;
  def.particles = std::size_t(state.range(0));
  def.perRow = int(std::lround(std::sqrt(double(def.particles))));
  def.settleSteps = int(state.range(1));
  const auto world = settledWorld<2>(shapes, depositedDiscs(shapes, def), def);
  timeSteps<2>(state, *world, shapes, secondsSince(t0));
}
// The 2D packing, settled longer.
BENCHMARK(BM_WorldPacking2D)
    ->ArgNames({"N", "settle"})
    ->Args({10000, 1000})
    ->Iterations(50)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
// Linear scaling: the same set-up at 1k, 10k and 100k discs.
BENCHMARK(BM_WorldPacking2D)
    ->Name("BM_WorldScaling2D")
    ->ArgNames({"N", "settle"})
    ->Args({1000, 300})
    ->Iterations(200)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_WorldPacking2D)
    ->Name("BM_WorldScaling2D")
    ->ArgNames({"N", "settle"})
    ->Args({10000, 300})
    ->Iterations(50)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_WorldPacking2D)
    ->Name("BM_WorldScaling2D")
    ->ArgNames({"N", "settle"})
    ->Args({100000, 300})
    ->Iterations(10)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// World::particlesChanged (run after every batch of splits) with N particles
// of N distinct shapes, as a breakage-heavy run has (every fragment is a shape
// of its own): the per-shape stiffness cache must keep it linear in N.
void BM_ParticlesChanged(benchmark::State& state) {
  const std::size_t n = std::size_t(state.range(0));
  geometry::ShapeDef<2> def;
  def.kind = geometry::ShapeKind::Sphere;
  def.radius = 0.01;
  def.cellsAcross = 8;
  def.options.nodesPerCell = 1.0;
  const auto base = geometry::buildShape(def);
  WorldDef<2> wdef;
  wdef.contact.kn = 1e5;
  World<2> world(wdef);
  const int perRow = int(std::ceil(std::sqrt(double(n))));
  for (std::size_t i = 0; i < n; ++i) {
    ParticleDef<2> p;
    p.shape = geometry::Shape<2>::fromParts(base->parts());  // a distinct shape, equal to the base
    p.position = Vec<2>(0.03 * double(int(i) % perRow), 0.03 * double(int(i) / perRow));
    world.addParticle(p);
  }
  for (auto _ : state) world.particlesChanged();
  state.counters["shapes"] = double(n);
  state.counters["s/shape"] =
      benchmark::Counter(double(n) * double(state.iterations()), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_ParticlesChanged)->Arg(2000)->Arg(4000)->Arg(8000)->Arg(16000)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
