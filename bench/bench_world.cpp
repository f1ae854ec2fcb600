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
template <int D>
using ShapePtr = std::shared_ptr<const geometry::Shape<D>>;

constexpr double kGravity = 9.81;    // m/s^2
constexpr double kDensity = 2650.0;  // kg/m^3 (kg/m^2 per unit thickness in 2D)

double secondsSince(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

int threadCount() {
#ifdef _OPENMP
  return omp_get_max_threads();
#else
  return 1;
#endif
}

// ------------------------------------------------------------------ shapes --

// Three blocky superellipsoids, ~2100 nodes at 20 cells across the smallest
// (1.6 cm) dimension; built once per process.
const std::vector<ShapePtr<3>>& blockShapes3D() {
  static const std::vector<ShapePtr<3>> shapes = [] {
    const double s = 0.01;  // m
    const std::array<Vec<3>, 3> semiAxes = {Vec<3>(1.2, 1.0, 0.8), Vec<3>(1.25, 0.95, 0.8), Vec<3>(1.15, 1.05, 0.8)};
    const std::array<std::vector<double>, 3> exponents = {std::vector<double>{4.0, 4.0}, std::vector<double>{3.5, 4.0},
                                                          std::vector<double>{4.0, 3.5}};
    std::vector<ShapePtr<3>> out;
    for (std::size_t k = 0; k < semiAxes.size(); ++k) {
      geometry::ShapeDef<3> def;
      def.kind = geometry::ShapeKind::Superellipsoid;
      def.semiAxes = s * semiAxes[k];
      def.exponents = exponents[k];
      def.cellsAcross = 20.0;
      def.options.nodesPerCell = 0.7;
      out.push_back(geometry::buildShape(def));
    }
    return out;
  }();
  return shapes;
}

// Three discs of radius 0.5, 0.485 and 0.47 cm on one grid spacing (20 cells
// across the smallest), ~95 nodes each; built once per process.
const std::vector<ShapePtr<2>>& discShapes2D() {
  static const std::vector<ShapePtr<2>> shapes = [] {
    const double h = 0.94e-2 / 20.0;  // m
    std::vector<ShapePtr<2>> out;
    for (const double radius : {0.5e-2, 0.485e-2, 0.47e-2}) {
      geometry::ShapeDef<2> def;
      def.kind = geometry::ShapeKind::Sphere;
      def.radius = radius;
      def.spacing = h;
      def.options.nodesPerCell = 1.5;
      out.push_back(geometry::buildShape(def));
    }
    return out;
  }();
  return shapes;
}

// ----------------------------------------------------------------- packing --

// How a benchmark packing is made (see the file comment). The last axis is vertical.
struct PackingDef {
  std::size_t particles = 1000;  ///< number of particles
  int perRow = 10;               ///< lattice sites (3D) / deposition targets (2D) along each horizontal axis of a layer
  double tilt = 0.0175;          ///< 3D: rad, largest random rotation away from the lattice orientation
  double jitter = 0.5;           ///< random horizontal offset, fraction of the lateral slack (3D) / of a site (2D)
  double preOverlap = 0.02;      ///< 2D: overlap of a disc with each of its supports, grid cells
  double loadOverlap = 0.002;    ///< stiffest patch's overlap under a column's weight, fraction of the smallest dimension
  double localDamping = 0.3;     ///< Cundall alpha
  int settleSteps = 300;         ///< steps run before timing
  std::uint64_t seed = 1;
};

// Particles placed in a box of planes: walls at 0 and box[a] across each
// horizontal axis a, floor at 0 on the last axis, open top.
template <int D>
struct Packing {
  std::vector<ParticleDef<D>> particles;
  Vec<D> box = Vec<D>::Zero();  ///< m
  double perColumn = 1.0;       ///< particles per bottom particle (N / bottom layer): the column a contact carries
};

// The world-aligned bounding box of a particle's nodes about its centroid, m.
template <int D>
std::pair<Vec<D>, Vec<D>> nodeBox(const geometry::Shape<D>& shape, const Orientation<D>& q) {
  const Mat<D> r = Rotation<D>::matrix(q);
  Vec<D> lo = Vec<D>::Constant(std::numeric_limits<double>::max()), hi = -lo;
  for (const Vec<D>& xb : shape.nodes().positions) {
    const Vec<D> x = r * xb;
    lo = lo.cwiseMin(x);
    hi = hi.cwiseMax(x);
  }
  return {lo, hi};
}

// The smallest extent of the shapes' nodes along a body axis, m.
template <int D>
double smallestDimension(const std::vector<ShapePtr<D>>& shapes) {
  double smallest = std::numeric_limits<double>::max();
  for (const ShapePtr<D>& s : shapes) {
    const auto [lo, hi] = nodeBox(*s, Rotation<D>::identity());
    smallest = std::min(smallest, (hi - lo).minCoeff());
  }
  return smallest;
}

// How far `mover` can move by `direction` (a unit vector, world frame) before
// one of its nodes enters `fixed`, m, searched up to `limit`: each node is
// marched along the line in steps of half a grid cell of `fixed` (lines that
// miss its bounding sphere are skipped), and the first crossing is bisected.
double travelUntilContact(const ParticleDef<3>& mover, const ParticleDef<3>& fixed, const Vec<3>& direction,
                          double limit) {
  const Mat<3> rm = Rotation<3>::matrix(mover.orientation), rf = Rotation<3>::matrix(fixed.orientation);
  const geometry::Shape<3>& shape = *fixed.shape;
  const double step = 0.5 * shape.grid().spacing(), radius = shape.boundingRadius();
  const Vec<3> u = rf.transpose() * direction;  // in the fixed body's frame
  double best = limit;
  for (const Vec<3>& xb : mover.shape->nodes().positions) {
    // The node in the fixed body's frame; skip lines that miss its bounding sphere.
    const Vec<3> x = rf.transpose() * (mover.position + rm * xb - fixed.position);
    const double along = x.dot(u);
    if ((x - along * u).squaredNorm() > radius * radius || along > radius) continue;
    // March, then bisect the first step that ends inside.
    if (shape.value(x) < 0.0) return 0.0;
    for (double d = step; d - step < best; d += step) {
      if (shape.value(x + d * u) >= 0.0) continue;
      double outside = d - step, inside = d;
      for (int k = 0; k < 20; ++k) {
        const double mid = 0.5 * (outside + inside);
        (shape.value(x + mid * u) < 0.0 ? inside : outside) = mid;
      }
      best = std::min(best, outside);
      break;
    }
  }
  return best;
}

// How far `top` can move down before touching `bottom`, m, up to `limit`.
double dropDistance(const ParticleDef<3>& top, const ParticleDef<3>& bottom, double limit) {
  const Vec<3> down(0.0, 0.0, -1.0);
  const double d = travelUntilContact(top, bottom, down, limit);
  return travelUntilContact(bottom, top, Vec<3>(-down), d);
}

// 3D: particles on a brick-bond lattice, each lowered onto the layer below.
//
// Particles get a random shape and a rotation of at most def.tilt about a
// random axis, and are placed layer by layer (def.perRow^2 sites per layer)
// on a lattice whose odd layers are shifted by half a site along x and y, so
// a particle rests on up to 4 below. Sites are as wide as the widest
// particle's node bounding box, and each particle is jittered within its own
// lateral slack, so particles of one layer do not overlap. A particle starts
// with its bounding box on the highest box below it (or the floor) and is
// lowered until its first node touches a particle below (or the floor).
Packing<3> brickLattice(const std::vector<ShapePtr<3>>& shapes, const PackingDef& def) {
  std::mt19937_64 rng(def.seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);

  // Shapes, orientations and node bounding boxes of every particle.
  const std::size_t n = def.particles;
  Packing<3> out;
  std::vector<ParticleDef<3>>& particles = out.particles;
  particles.resize(n);
  std::vector<Vec<3>> lo(n), hi(n);
  Vec<3> site = Vec<3>::Zero();  // m
  for (std::size_t i = 0; i < n; ++i) {
    ParticleDef<3>& p = particles[i];
    p.shape = shapes[rng() % shapes.size()];
    Vec<3> axis;
    do {
      axis = Vec<3>(u(rng), u(rng), u(rng));
    } while (axis.squaredNorm() > 1.0 || axis.squaredNorm() < 1e-6);
    p.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(std::abs(u(rng)) * def.tilt, axis.normalized()));
    p.density = kDensity;
    std::tie(lo[i], hi[i]) = nodeBox(*p.shape, p.orientation);
    site = site.cwiseMax(hi[i] - lo[i]);
  }

  // Horizontal positions: site centre (odd layers shifted by half a site) plus jitter within the slack.
  const std::size_t perRow = std::size_t(def.perRow), perLayer = perRow * perRow;
  for (std::size_t i = 0; i < n; ++i) {
    const double shift = (i / perLayer) % 2 == 1 ? 1.0 : 0.5;
    const std::array<std::size_t, 2> index = {i % perRow, (i % perLayer) / perRow};
    for (int a = 0; a < 2; ++a) {
      const double slack = 0.5 * (site[a] - (hi[i][a] - lo[i][a]));
      particles[i].position[a] =
          (double(index[a]) + shift) * site[a] - 0.5 * (lo[i][a] + hi[i][a]) + def.jitter * slack * u(rng);
    }
  }

  // Vertical positions, layer by layer.
  const double reach = 0.25 * smallestDimension(shapes);
  std::vector<double> top(n, 0.0);
  std::vector<std::size_t> below;
  for (std::size_t i = 0; i < n; ++i) {
    ParticleDef<3>& p = particles[i];
    // The particles below whose boxes overlap this one's horizontally, and the highest box top.
    below.clear();
    double start = 0.0;
    if (i >= perLayer) {
      const std::size_t layerStart = (i / perLayer - 1) * perLayer;
      for (std::size_t j = layerStart; j < layerStart + perLayer; ++j) {
        bool overlaps = true;
        for (int a = 0; a < 2; ++a) {
          overlaps = overlaps && particles[j].position[a] + lo[j][a] < p.position[a] + hi[i][a] &&
                     p.position[a] + lo[i][a] < particles[j].position[a] + hi[j][a];
        }
        if (overlaps) {
          below.push_back(j);
          start = std::max(start, top[j]);
        }
      }
    }
    // Lower the particle until a node touches (searching `reach` at a time).
    p.position[2] = start - lo[i][2];
    for (;;) {
      double drop = std::min(reach, p.position[2] + lo[i][2]);  // the floor
      for (std::size_t j : below) drop = std::min(drop, dropDistance(p, particles[j], drop));
      p.position[2] -= drop;
      if (drop < reach) break;
    }
    top[i] = p.position[2] + hi[i][2];
  }
  out.box = Vec<3>((def.perRow + 0.5) * site[0], (def.perRow + 0.5) * site[1], 0.0);
  out.perColumn = double(n) / double(std::min(n, perLayer));
  return out;
}

// 2D: discs deposited one by one, each rolling to a stable rest (the
// Visscher-Bolsterli construction).
//
// Disc i gets a random shape and orientation and a target x that sweeps the
// box row by row (def.perRow targets per row, jittered by def.jitter of a
// site). It falls vertically onto the highest disc (or the floor) below its
// target, then rolls over that disc, downhill, until it meets another disc, a
// wall or the floor; between two discs it rests when its centre lies between
// theirs, otherwise it rolls on over the outer one; when it rolls past the
// side of a disc it falls again. Contact distances are shortened by
// def.preOverlap grid cells, so every disc overlaps its supports that much
// and the contacts act from the first step. The discs a new disc can meet are
// among the last 3 rows placed (the surface of the packing).
Packing<2> depositedDiscs(const std::vector<ShapePtr<2>>& shapes, const PackingDef& def) {
  constexpr std::size_t kFloor = std::numeric_limits<std::size_t>::max(), kWall = kFloor - 1, kNone = kFloor - 2;
  std::mt19937_64 rng(def.seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0), turn(-std::numbers::pi, std::numbers::pi);
  double largest = 0.0;
  for (const ShapePtr<2>& s : shapes) largest = std::max(largest, s->boundingRadius());
  const double site = 2.0 * largest, width = def.perRow * site;          // m
  const double eps = def.preOverlap * shapes.front()->grid().spacing();  // m
  const std::size_t window = 3 * std::size_t(def.perRow);

  Packing<2> out;
  std::vector<ParticleDef<2>>& discs = out.particles;
  std::vector<double> radius;  // contact radius: disc radius - eps / 2
  for (std::size_t i = 0; i < def.particles; ++i) {
    ParticleDef<2> p;
    p.shape = shapes[rng() % shapes.size()];
    p.orientation = turn(rng);
    p.density = kDensity;
    const double r = p.shape->boundingRadius() - 0.5 * eps;
    const std::size_t first = discs.size() > window ? discs.size() - window : 0;

    // Height at which the disc, falling at x from below `ceiling`, lands; `on` gets what it lands on.
    auto land = [&](double x, double ceiling, std::size_t& on) {
      double y = r;
      on = kFloor;
      for (std::size_t j = first; j < discs.size(); ++j) {
        const double dx = x - discs[j].position.x(), d = r + radius[j];
        if (std::abs(dx) >= d) continue;
        const double yj = discs[j].position.y() + std::sqrt(d * d - dx * dx);
        if (yj > y && yj <= ceiling + 1e-12) {  // a disc touched at the start counts
          y = yj;
          on = j;
        }
      }
      return y;
    };

    // Fall at the target x, then roll until at rest.
    const double x0 =
        std::clamp((double(i % std::size_t(def.perRow)) + 0.5 + 0.5 * def.jitter * u(rng)) * site, r, width - r);
    std::size_t pivot = kNone;
    Vec<2> c(x0, land(x0, std::numeric_limits<double>::max(), pivot));
    for (int iteration = 0; pivot != kFloor && iteration < 10000; ++iteration) {
      // Roll over the pivot, downhill, from the current angle towards its side
      // (angle 0 or pi), up to the first angle where the disc would enter
      // another disc, a wall or the floor (touching one now counts when rolling
      // on would enter it).
      const Vec<2> cp = discs[pivot].position;
      const double dp = r + radius[pivot], angle = std::atan2(c.y() - cp.y(), c.x() - cp.x());
      const bool right = c.x() >= cp.x();  // rolling clockwise, the angle decreasing towards 0
      double stop = right ? 0.0 : std::numbers::pi;
      std::size_t hit = kNone;
      auto meet = [&](double a, std::size_t what) {
        a = std::remainder(a, 2.0 * std::numbers::pi);
        const bool ahead = right ? (a <= angle + 1e-9 && a > stop) : (a >= angle - 1e-9 && a < stop);
        if (ahead) {
          stop = a;
          hit = what;
        }
      };
      // Discs: where the rolling disc, moving on, starts to overlap disc k.
      for (std::size_t k = first; k < discs.size(); ++k) {
        if (k == pivot) continue;
        const Vec<2> pk = discs[k].position - cp;
        const double dk = r + radius[k], l = pk.norm();
        if (l >= dp + dk || l <= std::abs(dp - dk)) continue;
        const double towards = std::atan2(pk.y(), pk.x());
        const double spread = std::acos(std::clamp((dp * dp + l * l - dk * dk) / (2.0 * dp * l), -1.0, 1.0));
        meet(right ? towards + spread : towards - spread, k);
      }
      // The wall ahead and the floor.
      const double cosine = ((right ? width - r : r) - cp.x()) / dp, sine = (r - cp.y()) / dp;
      if (std::abs(cosine) <= 1.0) meet(std::acos(cosine), kWall);
      if (std::abs(sine) <= 1.0) meet(right ? std::asin(sine) : std::numbers::pi - std::asin(sine), kFloor);
      c = cp + dp * Vec<2>(std::cos(stop), std::sin(stop));

      // Rolled off the side of the pivot: fall again.
      if (hit == kNone) {
        c.y() = land(c.x(), c.y(), pivot);
        continue;
      }
      // At rest against a wall or the floor, or between two discs.
      if (hit == kWall || hit == kFloor) break;
      if ((discs[hit].position.x() - c.x()) * (cp.x() - c.x()) <= 0.0) break;
      // Both supports on one side: roll on over the outer one.
      if ((discs[hit].position.x() > cp.x()) == right) pivot = hit;
    }
    p.position = c;
    discs.push_back(p);
    radius.push_back(r);
  }
  out.box = Vec<2>(width, 0.0);
  out.perColumn = double(discs.size()) / double(def.perRow);
  return out;
}

// A world holding `packing` in its box of planes, with gravity and local
// damping, settled for def.settleSteps steps. kn: see the file comment.
template <int D>
std::unique_ptr<World<D>> settledWorld(const std::vector<ShapePtr<D>>& shapes, const Packing<D>& packing,
                                       const PackingDef& def) {
  constexpr int up = D - 1;
  // Contact stiffness from the column's weight on the softest shape's stiffest patch.
  double mass = 0.0, patch = std::numeric_limits<double>::max();
  for (const ShapePtr<D>& s : shapes) {
    mass = std::max(mass, kDensity * s->volume());
    patch = std::min(patch, stiffestContact(*s, NodeStiffness{1.0, 0.0, 0.8}).normalStiffness);
  }
  WorldDef<D> wd;
  wd.contact.kn = packing.perColumn * mass * kGravity / (def.loadOverlap * smallestDimension(shapes) * patch);
  wd.contact.ks = 0.8 * wd.contact.kn;
  wd.gravity = Vec<D>::Zero();
  (*wd.gravity)[up] = -kGravity;
  wd.localDamping = def.localDamping;
  auto world = std::make_unique<World<D>>(wd);
  for (const ParticleDef<D>& p : packing.particles) world->addParticle(p);

  // Floor and side walls, open top.
  PlaneDef<D> floorPlane;
  floorPlane.name = "floor";
  floorPlane.plane.normal = Vec<D>::Unit(up);
  world->addPlane(floorPlane);
  for (int a = 0; a < up; ++a) {
    PlaneDef<D> low, high;
    low.plane.normal = Vec<D>::Unit(a);
    high.plane.normal = -Vec<D>::Unit(a);
    high.plane.point[a] = packing.box[a];
    world->addPlane(low);
    world->addPlane(high);
  }

  // Settle under gravity and local damping.
  world->run(std::uint64_t(def.settleSteps));
  return world;
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
