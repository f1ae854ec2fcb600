#pragma once
/// @file Packings.h
/// @brief The benchmark packings (bench_world.cpp's file comment): shapes, a
/// brick lattice of superellipsoids (3D) and deposited discs (2D), and the
/// world that holds one in a box of planes under gravity. Shared by
/// bench_world.cpp and the distributed bed (mpi/bench_distributed.cpp).

#include "lsdem/dynamics/TimeStep.h"
#include "lsdem/dynamics/World.h"
#include "lsdem/geometry/ShapeDef.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <numbers>
#include <random>
#include <tuple>
#include <utility>
#include <vector>

namespace lsdem::bench {

using namespace lsdem::dynamics;

template <int D>
using ShapePtr = std::shared_ptr<const geometry::Shape<D>>;

constexpr double kGravity = 9.81;    // m/s^2
constexpr double kDensity = 2650.0;  // kg/m^3 (kg/m^2 per unit thickness in 2D)

// ------------------------------------------------------------------ shapes --

// Three blocky superellipsoids, ~2100 nodes at 20 cells across the smallest
// (1.6 cm) dimension; built once per process.
inline const std::vector<ShapePtr<3>>& blockShapes3D() {
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
inline const std::vector<ShapePtr<2>>& discShapes2D() {
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
inline double travelUntilContact(const ParticleDef<3>& mover, const ParticleDef<3>& fixed, const Vec<3>& direction,
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
inline double dropDistance(const ParticleDef<3>& top, const ParticleDef<3>& bottom, double limit) {
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
inline Packing<3> brickLattice(const std::vector<ShapePtr<3>>& shapes, const PackingDef& def) {
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
inline Packing<2> depositedDiscs(const std::vector<ShapePtr<2>>& shapes, const PackingDef& def) {
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

}  // namespace lsdem::bench
