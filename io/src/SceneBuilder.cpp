/// @file SceneBuilder.cpp
/// @brief SceneDef -> World: particle placement and the declared effects.

#include "lsdem/io/InputError.h"
#include "lsdem/io/Scene.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <numbers>
#include <random>
#include <sstream>
#include <unordered_map>

namespace lsdem::io {
namespace {

using geometry::Vec;
using geometry::Mat;

// The most particles a grid group may place by filling its region (the limit
// of `count` too).
constexpr std::uint64_t kMaxGridParticles = 10000000;

// Uniform doubles in [0, 1) from 53 random bits (the same on every platform,
// unlike std::uniform_real_distribution).
struct Random {
  explicit Random(std::uint64_t seed) : engine(seed) {}
  double uniform() { return double(engine() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  double normal() {
    // Box-Muller, one value per call.
    const double u = 1.0 - uniform(), v = uniform();
    return std::sqrt(-2.0 * std::log(u)) * std::cos(2.0 * std::numbers::pi * v);
  }
  std::mt19937_64 engine;
};

template <int D>
dynamics::Orientation<D> randomOrientation(Random& rng) {
  if constexpr (D == 2) {
    return rng.uniform(-std::numbers::pi, std::numbers::pi);
  } else {
    // A normalised 4D Gaussian is uniform on the rotations.
    Eigen::Quaterniond q(rng.normal(), rng.normal(), rng.normal(), rng.normal());
    return q.normalized();
  }
}

// True when a node of `a` (posed Ra, xa) lies in `b` (posed Rb, xb) or closer
// to its surface than `clearance`.
template <int D>
bool nodesReach(const geometry::Shape<D>& a, const Mat<D>& Ra, const Vec<D>& xa, const geometry::Shape<D>& b,
                const Mat<D>& Rb, const Vec<D>& xb, double clearance) {
  const Mat<D> map = Rb.transpose() * Ra;
  const Vec<D> shift = Rb.transpose() * (xa - xb);
  const double reach2 = (b.boundingRadius() + clearance) * (b.boundingRadius() + clearance);
  for (const Vec<D>& n : a.nodes().positions) {
    const Vec<D> y = map * n + shift;
    if (y.squaredNorm() > reach2) continue;
    if (b.value(y) < clearance) return true;
  }
  return false;
}

// Whether a body of `shape` posed (R, centre) holds the point x: its level
// set is negative there (the bounding sphere first).
template <int D>
bool bodyHolds(const geometry::Shape<D>& shape, const Mat<D>& R, const Vec<D>& centre, const Vec<D>& x) {
  const Vec<D> arm = x - centre;
  return arm.norm() < shape.boundingRadius() && shape.value(R.transpose() * arm) < 0.0;
}

// Particles placed so far, in cells of a hash grid, for overlap tests: the
// bounding spheres first, then the shapes themselves (nodes against level
// sets both ways, with half a cell of clearance), so grains can be placed as
// densely as their shapes allow.
template <int D>
class PlacementIndex {
 public:
  explicit PlacementIndex(double cell) : cell_(cell) {}
  void add(const Vec<D>& x, const std::shared_ptr<const geometry::Shape<D>>& shape, const Mat<D>& R) {
    centres_.push_back(x);
    shapes_.push_back(shape);
    rotations_.push_back(R);
    cells_[key(x)].push_back(centres_.size() - 1);
    maxRadius_ = std::max(maxRadius_, shape->boundingRadius());
  }
  bool overlaps(const Vec<D>& x, const geometry::Shape<D>& shape, const Mat<D>& R) const {
    return near(x, shape, [&](std::size_t k) {
      const geometry::Shape<D>& other = *shapes_[k];
      const double clearance = 0.5 * std::max(shape.grid().spacing(), other.grid().spacing());
      return nodesReach(shape, R, x, other, rotations_[k], centres_[k], clearance) ||
             nodesReach(other, rotations_[k], centres_[k], shape, R, x, clearance);
    }) >= 0;
  }
  /// The placed particle whose body holds the centroid `x` of a particle of
  /// `shape` posed R, or whose own centroid that particle's body would hold
  /// (a deep overlap: no contact law pushes such grains apart in proportion);
  /// its index in the order of add(), or -1.
  std::ptrdiff_t holdingCentroid(const Vec<D>& x, const geometry::Shape<D>& shape, const Mat<D>& R) const {
    return near(x, shape, [&](std::size_t k) {
      return bodyHolds(*shapes_[k], rotations_[k], centres_[k], x) || bodyHolds(shape, R, x, centres_[k]);
    });
  }

 private:
  // The first placed particle whose bounding sphere meets that of `shape`
  // at x and for which test(k) holds, or -1.
  template <class Test>
  std::ptrdiff_t near(const Vec<D>& x, const geometry::Shape<D>& shape, const Test& test) const {
    const double r = shape.boundingRadius();
    const int reach = int(std::ceil((r + maxRadius_) / cell_));
    Eigen::Array<std::int64_t, D, 1> c = cellOf(x);
    Eigen::Array<std::int64_t, D, 1> o = Eigen::Array<std::int64_t, D, 1>::Constant(-reach);
    // Visit the (2 reach + 1)^D cells around x.
    while (true) {
      const auto it = cells_.find(hash(c + o));
      if (it != cells_.end()) {
        for (std::size_t k : it->second) {
          if ((centres_[k] - x).norm() >= shapes_[k]->boundingRadius() + r) continue;
          if (test(k)) return std::ptrdiff_t(k);
        }
      }
      int a = 0;
      while (a < D && ++o[a] > reach) o[a++] = -reach;
      if (a == D) break;
    }
    return -1;
  }
  Eigen::Array<std::int64_t, D, 1> cellOf(const Vec<D>& x) const {
    return (x.array() / cell_).floor().template cast<std::int64_t>();
  }
  static std::uint64_t hash(const Eigen::Array<std::int64_t, D, 1>& c) {
    std::uint64_t h = 1469598103934665603ull;
    for (int a = 0; a < D; ++a) h = (h ^ std::uint64_t(c[a])) * 1099511628211ull;
    return h;
  }
  std::uint64_t key(const Vec<D>& x) const { return hash(cellOf(x)); }

  double cell_;
  double maxRadius_ = 0.0;
  std::vector<Vec<D>> centres_;
  std::vector<std::shared_ptr<const geometry::Shape<D>>> shapes_;
  std::vector<Mat<D>> rotations_;
  std::unordered_map<std::uint64_t, std::vector<std::size_t>> cells_;
};

template <int D>
class Builder {
 public:
  explicit Builder(const SceneDef<D>& scene) : scene_(scene) {}

  SceneWorld<D> build() {
    SceneWorld<D> out;
    // Outflow runs after breakage (breakage must read contacts that describe
    // the particles as they are), so it is added by hand below.
    dynamics::WorldDef<D> def = scene_.world;
    def.outflow.reset();
    try {
      out.world = std::make_unique<dynamics::World<D>>(def);
    } catch (const std::invalid_argument& e) {
      throw worldError(e.what(), 0, "");
    }
    world_ = out.world.get();
    for (const auto& p : scene_.planes) world_->addPlane(p);
    for (const auto& t : scene_.tools) world_->addTool(t);

    // Particles, group by group (ids count from 0 in this order).
    double cell = 0.0;
    for (const auto& s : scene_.shapes) cell = std::max(cell, 2.0 * s->boundingRadius());
    if (scene_.groups.size() > 0) {
      for (const auto& g : scene_.groups) cell = std::max(cell, g.diameterMax);
    }
    index_ = std::make_unique<PlacementIndex<D>>(cell > 0.0 ? cell : 1.0);
    std::vector<dynamics::FeedDef<D>> feeds;
    std::vector<int> feedLines;  // each feed's group line, for messages
    for (const ParticleGroupDef<D>& g : scene_.groups) {
      Random rng(g.seed);
      switch (g.placement) {
        case Placement::List: placeList(g, rng); break;
        case Placement::Cloud: placeCloud(g, rng); break;
        case Placement::Grid: placeGrid(g, rng); break;
        case Placement::Feed: {
          // (At the feed's start: planes and tools may have moved by then.)
          if (const std::string inside = insideBoundary(g.feedPoint, g.feedStart); !inside.empty()) {
            fail(g, "the feed point " + pointText(g.feedPoint) + " lies " + inside +
                        (g.feedStart > 0.0 ? " when the feed starts" : ""));
          }
          dynamics::FeedDef<D> f;
          for (std::size_t s : g.shapes) f.shapes.push_back(scene_.shapes[s]);
          f.point = g.feedPoint;
          f.velocity = g.velocity;
          f.density = g.density;
          f.material = g.material;
          f.interval = g.feedInterval;
          f.clearance = g.feedClearance;
          f.count = g.count;
          f.startTime = g.feedStart;
          feeds.push_back(std::move(f));
          feedLines.push_back(g.line);
          break;
        }
      }
    }
    out.initialMass = world_->particleMass();

    // Effects after the world's own (gravity, damping): breakage, outflow, feeds.
    if (scene_.breakage) {
      try {
        auto b = std::make_unique<breakage::Breakage<D>>(*scene_.breakage);
        out.breakage = b.get();
        world_->addEffect(std::move(b));
      } catch (const std::invalid_argument& e) {
        throw InputError(scene_.file, 0, "effects.breakage", e.what());
      }
    }
    if (scene_.world.outflow) {
      world_->addEffect(std::make_unique<dynamics::Outflow<D>>(*scene_.world.outflow, scene_.world.discharge));
    }
    for (std::size_t k = 0; k < feeds.size(); ++k) {
      auto& f = feeds[k];
      // The feed's grains count for the automatic time step from the start
      // (a scene may begin with no particle at all).
      for (const auto& shape : f.shapes) {
        dynamics::ParticleDef<D> p;
        p.shape = shape;
        p.density = f.density;
        try {
          world_->anticipateParticle(p);
        } catch (const std::invalid_argument& e) {
          throw worldError(e.what(), feedLines[k], "particles");
        }
      }
      auto feed = std::make_unique<dynamics::Feed<D>>(std::move(f));
      out.feeds.push_back(feed.get());
      world_->addEffect(std::move(feed));
    }
    return out;
  }

 private:
  // What the world refused, as an input error at the key that causes it: a
  // user time step above the critical one (simulation.dt), a contact law
  // whose stiffness or time step overflows for these grains ([contact]), else
  // the particles (`line`, `key`).
  InputError worldError(const std::string& what, int line, const std::string& key) const {
    const auto lineOf = [&](const std::string& k) {
      const auto it = scene_.keyLines.find(k);
      return it != scene_.keyLines.end() ? it->second : 0;
    };
    if (what.rfind("dt = ", 0) == 0) return InputError(scene_.file, lineOf("simulation.dt"), "simulation.dt", what);
    if (key.empty() || what.find("stiffness") != std::string::npos || what.find("time step") != std::string::npos) {
      return InputError(scene_.file, lineOf("contact"), "contact", what);
    }
    return InputError(scene_.file, line, key, what);
  }

  [[noreturn]] void fail(const ParticleGroupDef<D>& g, const std::string& what) const {
    throw InputError(scene_.file, g.line, "particles", what);
  }

  // The shape of the k-th particle of a group: cycled, and scaled to a random
  // equivalent diameter when the group asks for a size range.
  std::shared_ptr<const geometry::Shape<D>> shapeFor(const ParticleGroupDef<D>& g, std::size_t k, Random& rng) {
    const auto& base = scene_.shapes[g.shapes[k % g.shapes.size()]];
    if (!(g.diameterMax > 0.0)) return base;
    const double d = rng.uniform(g.diameterMin, g.diameterMax);
    return scaledShape(*base, d / base->descriptors().equivalentDiameter);
  }

  void add(const ParticleGroupDef<D>& g, const std::shared_ptr<const geometry::Shape<D>>& shape, const Vec<D>& x,
           const dynamics::Orientation<D>& q) {
    dynamics::ParticleDef<D> p;
    p.shape = shape;
    p.density = g.density;
    p.material = g.material;
    p.position = x;
    p.orientation = q;
    p.velocity = g.velocity;
    try {
      world_->addParticle(p);
    } catch (const std::invalid_argument& e) {
      throw worldError(e.what(), g.line, "particles");
    }
    index_->add(x, shape, dynamics::Rotation<D>::matrix(q));
  }

  void placeList(const ParticleGroupDef<D>& g, Random& rng) {
    for (std::size_t k = 0; k < g.positions.size(); ++k) {
      dynamics::Orientation<D> q = dynamics::Rotation<D>::identity();
      if constexpr (D == 2) {
        if (!g.angles.empty()) q = g.angles[k];
      } else {
        if (!g.rotations.empty()) q = Eigen::Quaterniond(g.rotations[k]).normalized();
      }
      const auto shape = shapeFor(g, k, rng);
      checkListed(g, k, *shape, q);
      add(g, shape, g.positions[k], q);
    }
  }

  // A listed position that cannot be meant: behind a plane or inside a tool
  // (insideBoundary), or with its centroid inside a particle placed before
  // it, or that particle's inside it. Either makes
  // forces no time step resolves, and silent garbage (grains flung apart,
  // breakage of everything they touch).
  void checkListed(const ParticleGroupDef<D>& g, std::size_t k, const geometry::Shape<D>& shape,
                   const dynamics::Orientation<D>& q) const {
    const Vec<D>& x = g.positions[k];
    const auto where = [&] { return "positions[" + std::to_string(k) + "] = " + pointText(x); };
    if (const std::string inside = insideBoundary(x); !inside.empty()) fail(g, where() + " lies " + inside);
    const std::ptrdiff_t other = index_->holdingCentroid(x, shape, dynamics::Rotation<D>::matrix(q));
    if (other >= 0) {
      fail(g, where() + " overlaps particle " + std::to_string(other) +
                  " (ids count from 0 in the order placed) so deeply that one holds the other's centroid");
    }
  }

  // Where x lies inside a boundary at `time` (s): "behind plane 'NAME' (...)"
  // for the first plane whose back side (the side its normal points away
  // from) holds it, else "inside tool 'NAME'" for the first tool whose level
  // set is negative there (tools only at the start, whose poses the world
  // has); empty for neither. A centroid there is never meant: the contact
  // would fling the grain out at once.
  std::string insideBoundary(const Vec<D>& x, double time = 0.0) const {
    for (const auto& p : scene_.planes) {
      if (p.plane.normal.dot(x - (p.plane.point + time * p.plane.velocity)) < 0.0) {
        return "behind plane '" + p.name + "' (on the side its normal points away from)";
      }
    }
    if (time > 0.0) return {};
    const auto& poses = world_->toolPoses();
    for (std::size_t k = 0; k < poses.size(); ++k) {
      if (bodyHolds(*poses[k].shape, dynamics::Rotation<D>::matrix(poses[k].orientation), poses[k].position, x)) {
        return "inside tool '" + scene_.tools[k].name + "'";
      }
    }
    return {};
  }
  static std::string pointText(const Vec<D>& x) {
    std::ostringstream s;
    s << "(";
    for (int a = 0; a < D; ++a) s << (a ? ", " : "") << x[a];
    return s.str() + ")";
  }

  void placeCloud(const ParticleGroupDef<D>& g, Random& rng) {
    const std::uint64_t attemptsPerParticle = 20000;
    for (std::uint64_t k = 0; k < g.count; ++k) {
      const auto shape = shapeFor(g, std::size_t(k), rng);
      // The region must hold every surface node (a sphere through the farthest node).
      double r = 0.0;
      for (const Vec<D>& n : shape->nodes().positions) r = std::max(r, n.norm());
      const Vec<D> lo = g.region.lower.array() + r, hi = g.region.upper.array() - r;
      if (!((hi.array() >= lo.array()).all())) {
        fail(g, "the cloud region is smaller than a particle (radius " + std::to_string(r) + " m)");
      }
      bool placed = false;
      for (std::uint64_t attempt = 0; attempt < attemptsPerParticle && !placed; ++attempt) {
        Vec<D> x;
        for (int a = 0; a < D; ++a) x[a] = rng.uniform(lo[a], hi[a]);
        const dynamics::Orientation<D> q =
            g.randomOrientation ? randomOrientation<D>(rng) : dynamics::Rotation<D>::identity();
        // (A centroid behind a plane or inside a tool is drawn again, as an overlap is.)
        if (!insideBoundary(x).empty() || index_->overlaps(x, *shape, dynamics::Rotation<D>::matrix(q))) continue;
        add(g, shape, x, q);
        placed = true;
      }
      if (!placed) {
        fail(g, "could place only " + std::to_string(k) + " of " + std::to_string(g.count) +
                    " particles without overlap, clear of the planes and tools, in the cloud region; enlarge it or "
                    "lower the count");
      }
    }
  }

  void placeGrid(const ParticleGroupDef<D>& g, Random& rng) {
    // Lattice spacing: the largest bounding diameter of the group's shapes.
    double spacing = g.gridSpacing;
    if (!(spacing > 0.0)) {
      for (std::size_t s : g.shapes) spacing = std::max(spacing, 2.0 * scene_.shapes[s]->boundingRadius());
      if (g.diameterMax > 0.0) {
        double ratio = 0.0;
        for (std::size_t s : g.shapes) {
          ratio = std::max(ratio, scene_.shapes[s]->boundingRadius() / scene_.shapes[s]->descriptors().equivalentDiameter);
        }
        spacing = 2.0 * ratio * g.diameterMax;
      }
      spacing *= 1.0001;
    }
    // Nodes of the lattice inside the region (a half spacing from its faces).
    Eigen::Array<std::int64_t, D, 1> n;
    for (int a = 0; a < D; ++a) n[a] = std::int64_t(std::min(std::floor(g.region.size()[a] / spacing), 1e18));
    if ((n <= 0).any()) fail(g, "the grid region is smaller than one lattice spacing (" + std::to_string(spacing) + " m)");
    // (counted in doubles: a spacing far below the region's size must not overflow)
    double lattice = 1.0;
    for (int a = 0; a < D; ++a) lattice *= double(n[a]);
    if (g.count == 0 && lattice > double(kMaxGridParticles)) {
      char text[160];
      std::snprintf(text, sizeof(text), "the grid region holds %.3g particles at spacing %.3g m, over the limit of 1e7", lattice,
                    spacing);
      fail(g, std::string(text) + " (give `count`, a larger spacing or a smaller region)");
    }
    const std::uint64_t capacity = lattice > 1e18 ? std::uint64_t(1e18) : std::uint64_t(n.prod());
    const std::uint64_t count = g.count > 0 ? g.count : capacity;
    if (count > capacity) {
      fail(g, "the grid region holds " + std::to_string(capacity) + " particles at spacing " + std::to_string(spacing) +
                  " m, asked for " + std::to_string(count));
    }
    for (std::uint64_t k = 0; k < count; ++k) {
      Vec<D> x;
      std::uint64_t rest = k;
      for (int a = 0; a < D; ++a) {
        x[a] = g.region.lower[a] + (double(rest % std::uint64_t(n[a])) + 0.5) * spacing;
        rest /= std::uint64_t(n[a]);
      }
      if (const std::string inside = insideBoundary(x); !inside.empty()) {
        fail(g, "the grid's particle " + std::to_string(k) + " at " + pointText(x) + " lies " + inside +
                    "; keep the region clear of the boundaries");
      }
      add(g, shapeFor(g, std::size_t(k), rng), x,
          g.randomOrientation ? randomOrientation<D>(rng) : dynamics::Rotation<D>::identity());
    }
  }

  const SceneDef<D>& scene_;
  dynamics::World<D>* world_ = nullptr;
  std::unique_ptr<PlacementIndex<D>> index_;
};

}  // namespace

template <int D>
SceneWorld<D> buildWorld(const SceneDef<D>& scene) {
  return Builder<D>(scene).build();
}

template <int D>
std::shared_ptr<const geometry::Shape<D>> scaledShape(const geometry::Shape<D>& shape, double f) {
  if (!(f > 0.0) || !std::isfinite(f)) throw std::invalid_argument("shape scale factor must be positive, got " + std::to_string(f));
  typename geometry::Shape<D>::Parts p = shape.parts();
  // Grid: same nodes, origin and spacing scaled, distances scaled.
  geometry::Grid<D> grid(p.grid.dims(), p.grid.origin() * f, p.grid.spacing() * f);
  for (std::size_t n = 0; n < grid.size(); ++n) grid[n] = float(double(p.grid[n]) * f);
  p.grid = std::move(grid);
  p.bodyToGrid.translation *= f;
  for (auto& x : p.nodes.positions) x *= f;
  for (double& w : p.nodes.weights) w *= std::pow(f, D - 1);
  // Mass properties per unit density: volume ~ f^D, second moments ~ f^(D+2).
  p.mass.volume *= std::pow(f, D);
  p.mass.centroid *= f;
  p.mass.secondMoment *= std::pow(f, D + 2);
  // Descriptors: lengths ~ f, areas ~ f^(D-1), volume ~ f^D, ratios unchanged.
  p.descriptors.volume *= std::pow(f, D);
  p.descriptors.surfaceArea *= std::pow(f, D - 1);
  p.descriptors.bestFitSemiAxes *= f;
  p.descriptors.equivalentDiameter *= f;
  p.descriptors.sieveSize *= f;
  p.descriptors.intermediateAxis *= f;
  p.boundingRadius *= f;
  return geometry::Shape<D>::fromParts(std::move(p));
}

template SceneWorld<2> buildWorld<2>(const SceneDef<2>&);
template SceneWorld<3> buildWorld<3>(const SceneDef<3>&);
template std::shared_ptr<const geometry::Shape<2>> scaledShape<2>(const geometry::Shape<2>&, double);
template std::shared_ptr<const geometry::Shape<3>> scaledShape<3>(const geometry::Shape<3>&, double);

}  // namespace lsdem::io
