// The dynamic cases of the stability suite (Stability.h) and the list of all
// cases. Each builds a world in code, runs it under a StabilityMonitor and
// checks the invariants.

#include "lsdem/study/Stability.h"

#include "lsdem/breakage/Breakage.h"
#include "lsdem/dynamics/World.h"
#include "lsdem/geometry/ShapeDef.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <memory>
#include <random>

namespace lsdem::study {

using breakage::Breakage;
using breakage::BreakageDef;
using dynamics::ParticleDef;
using dynamics::PlaneDef;
using dynamics::World;
using dynamics::WorldDef;
using geometry::Box;
using geometry::Shape;
using geometry::Vec;

namespace {

using Clock = std::chrono::steady_clock;

template <int D>
std::shared_ptr<const Shape<D>> sphere(double radius, double cells) {
  geometry::ShapeDef<D> def;
  def.kind = geometry::ShapeKind::Sphere;
  def.radius = radius;
  def.cellsAcross = cells;
  def.options.nodesPerCell = 1.0;
  return geometry::buildShape(def);
}

template <int D>
std::shared_ptr<const Shape<D>> ellipsoid(const Vec<D>& semiAxes, double cells) {
  geometry::ShapeDef<D> def;
  def.kind = geometry::ShapeKind::Ellipsoid;
  def.semiAxes = semiAxes;
  def.cellsAcross = cells;
  def.options.nodesPerCell = 1.0;
  return geometry::buildShape(def);
}

template <int D>
void addPlane(World<D>& w, const Vec<D>& point, const Vec<D>& normal, const Vec<D>& velocity = Vec<D>::Zero()) {
  PlaneDef<D> p;
  p.plane.point = point;
  p.plane.normal = normal;
  p.plane.velocity = velocity;
  w.addPlane(p);
}

/// Closes `box` with six (four) planes; the top one (+y side) moves at `topVelocity` along y.
template <int D>
void closeBox(World<D>& w, const Box<D>& box, double topVelocity = 0.0) {
  for (int a = 0; a < D; ++a) {
    addPlane<D>(w, box.lower, Vec<D>::Unit(a));
    addPlane<D>(w, box.upper, -Vec<D>::Unit(a), a == 1 ? Vec<D>(topVelocity * Vec<D>::Unit(1)) : Vec<D>::Zero());
  }
}

/// Grains of `shape` on a lattice of pitch `gap` from `first`, counts per
/// axis (z ignored in 2D), jittered by `jitter` (m) deterministically.
template <int D>
void addLattice(World<D>& w, const std::shared_ptr<const Shape<D>>& shape, const Vec<D>& first, double gap,
                const std::array<int, 3>& counts, double jitter, double density = 2650.0) {
  const int nz = D == 3 ? counts[2] : 1;
  for (int k = 0; k < nz; ++k) {
    for (int j = 0; j < counts[1]; ++j) {
      for (int i = 0; i < counts[0]; ++i) {
        ParticleDef<D> p;
        p.shape = shape;
        p.density = density;
        p.position = first;
        p.position[0] += i * gap + jitter * ((i + j) % 3 - 1);
        p.position[1] += j * gap;
        if constexpr (D == 3) p.position[2] += k * gap + jitter * ((i + k) % 2);
        w.addParticle(p);
      }
    }
  }
}

/// Weibull breakage with fines below `minCells` cells of volume.
template <int D>
BreakageDef<D> breakageDef(double sigma0, double diameter, double h, double minCells = 2.5) {
  BreakageDef<D> b;
  b.criterion.kind = breakage::CriterionKind::VonMises;
  b.weibull.referenceStrength = sigma0;
  b.weibull.referenceDiameter = diameter;
  b.weibull.modulus = 3.0;
  b.minVolume = std::pow(minCells * h, D);
  b.minNodes = 4;
  return b;
}

/// Runs the world under a monitor until `steps` steps, or `done()`; a thrown
/// exception or a non-finite state ends the run as a violation.
template <int D, class Done>
void runMonitored(World<D>& w, StabilityMonitor<D>& monitor, std::uint64_t steps, StabilityResult& out, Done done) {
  for (std::uint64_t s = 0; s < steps; ++s) {
    try {
      w.step();
    } catch (const std::exception& e) {
      out.violations.push_back(std::string("step threw: ") + e.what());
      break;
    }
    monitor.observe();
    if (monitor.sawNonFinite() || done()) break;
  }
}

template <int D>
Breakage<D>* addBreakage(World<D>& w, const BreakageDef<D>& def) {
  auto effect = std::make_unique<Breakage<D>>(def);
  Breakage<D>* raw = effect.get();
  w.addEffect(std::move(effect));
  return raw;
}

/// Finishes a case: copies the monitor's maxima, times it and checks it.
template <int D>
StabilityResult finishCase(StabilityMonitor<D>& monitor, StabilityResult& out, Clock::time_point t0) {
  out.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  monitor.finish(out);
  checkInvariants(out);
  return out;
}

template <int D>
Box<D> boxOf(double x, double y, double z) {
  Box<D> b;
  b.lower.setZero();
  b.upper = Vec<D>::Constant(z);
  b.upper[0] = x;
  b.upper[1] = y;
  return b;
}

}  // namespace

// ------------------------------------------------------------------ cascade --

template <int D>
StabilityResult cascadeCase(CaseLength length) {
  const auto t0 = Clock::now();
  const bool isLong = length == CaseLength::Long;
  StabilityResult out;
  out.name = "cascade";
  out.minBreakages = isLong ? 1000 : (D == 2 ? 100 : 40);
  out.note = "grains crushed in a closed box by a platen, lineages split down to fines";
  out.overlapLimit = 0.3;

  // Grains on a lattice in a closed box; the lid moves down.
  const double r = 0.01, gap = 2.2 * r;
  const int perRow = D == 2 ? (isLong ? 12 : 8) : (isLong ? 4 : 3);
  const int rows = D == 2 ? (isLong ? 12 : 5) : (isLong ? 4 : 2);
  const double cells = D == 2 ? 10 : 8;
  const double speed = 0.5;
  WorldDef<D> def;
  // Springs stiff enough for the fragments: by eq. 13 a fragment of a third
  // of the parent's diameter is 3 x as strong (m = 3), and with kn = 2e5 N/m
  // the late generations were pressed up to 0.9 of a cell (0.31 of their
  // diameter) into each other before they failed.
  def.contact.kn = 1e6;
  def.contact.ks = 0.8e6;
  def.localDamping = 0.3;
  World<D> w(def);
  const Box<D> box = boxOf<D>(perRow * gap, rows * gap + 0.2 * r, perRow * gap);
  closeBox<D>(w, box, -speed);
  const auto s = sphere<D>(r, cells);
  addLattice<D>(w, s, Vec<D>::Constant(0.5 * gap), gap, {perRow, rows, perRow}, 0.05 * r);
  Breakage<D>* brk = addBreakage(w, breakageDef<D>(2e4, 2.0 * r, s->grid().spacing()));

  // Crush until enough breakages or the lid has travelled 70 % of the height.
  StabilityMonitor<D> monitor(w, brk, box);
  const double travel = 0.7 * box.upper[1];
  runMonitored(w, monitor, std::uint64_t(1) << 40, out,
               [&] { return brk->breakages() >= out.minBreakages || speed * w.time() > travel; });
  return finishCase(monitor, out, t0);
}

// ---------------------------------------------------------- split in contact --

template <int D>
StabilityResult splitInContactCase(CaseLength length) {
  const auto t0 = Clock::now();
  const bool isLong = length == CaseLength::Long;
  StabilityResult out;
  out.name = "split_in_contact";
  out.note = "grains pressed 1 % into walls and neighbours split by manual planes; fragments start in contact";

  // A lattice squeezed into a box 1 % of a diameter smaller per contact.
  const double r = 0.01;
  const double gap = 2.0 * r * 0.99;
  const int n = D == 2 ? 4 : 3;
  WorldDef<D> def;
  def.contact.kn = 1e6;
  def.contact.ks = 0.8e6;
  World<D> w(def);
  const Box<D> box = boxOf<D>(n * gap + 0.02 * r, n * gap + 0.02 * r, n * gap + 0.02 * r);
  closeBox<D>(w, box);
  const auto s = sphere<D>(r, D == 2 ? 16 : 10);
  addLattice<D>(w, s, Vec<D>::Constant(0.5 * gap + 0.01 * r), gap, {n, n, n}, 0.0);

  // Manual breaks of every grain at a few steps in, by planes through (and
  // near) their contact points: vertical, horizontal and diagonal.
  BreakageDef<D> bdef = breakageDef<D>(1e12, 2.0 * r, s->grid().spacing(), 1.5);
  const std::size_t count = w.particles().size();
  for (std::size_t i = 0; i < count; ++i) {
    breakage::ManualBreak<D> mb;
    mb.particle = w.particles().id[i];
    mb.time = 5e-6 * double(1 + i % 3);
    const Vec<D> x = w.particles().position[i];
    Vec<D> normal = Vec<D>::Unit(i % D);
    if (i % 3 == 2) normal = Vec<D>::Ones().normalized();
    const double shift = (i % 2 == 0 ? 0.0 : 0.3 * r);
    mb.plane.normal = normal;
    mb.plane.offset = normal.dot(x) + shift;
    bdef.manual.push_back(mb);
  }
  Breakage<D>* brk = addBreakage(w, bdef);
  out.minBreakages = count;

  StabilityMonitor<D> monitor(w, brk, box);
  runMonitored(w, monitor, isLong ? 20000 : (D == 2 ? 3000 : 1500), out, [] { return false; });
  return finishCase(monitor, out, t0);
}

// --------------------------------------------------------------- mass ratio --

template <int D>
StabilityResult massRatioCase(CaseLength length) {
  const auto t0 = Clock::now();
  const bool isLong = length == CaseLength::Long;
  StabilityResult out;
  out.name = "mass_ratio";
  out.note = "a grain of 1e4 x the density resting on light grains under gravity";

  const double r = 0.005, gap = 2.02 * r;
  const int n = D == 2 ? 6 : 3;
  WorldDef<D> def;
  def.contact.kn = 1e7;
  def.contact.ks = 0.8e7;
  def.gravity = Vec<D>(-9.81 * Vec<D>::Unit(1));
  World<D> w(def);
  const Box<D> box = boxOf<D>(n * gap, 8 * gap, n * gap);
  closeBox<D>(w, box);
  const auto s = sphere<D>(r, 10);
  addLattice<D>(w, s, Vec<D>::Constant(0.5 * gap), gap, {n, 1, n}, 0.0);

  // The heavy grain is released touching the grains of the hollow above the
  // middle of the layer (centres 2 r apart, no gap, no overlap), so it comes
  // to rest on them.
  ParticleDef<D> heavy;
  heavy.shape = s;
  heavy.density = 2650.0 * 1e4;
  heavy.position = Vec<D>::Constant(gap * double(n / 2));  // between two (2D) or four (3D) grains
  const double offAxis = 0.5 * gap * std::sqrt(double(D - 1));  // horizontal distance to a supporting centre
  heavy.position[1] = 0.5 * gap + std::sqrt(4.0 * r * r - offAxis * offAxis);
  w.addParticle(heavy);

  StabilityMonitor<D> monitor(w, nullptr, box);
  // Short: long enough for the heavy grain to load its supports (in 3D the
  // light grains' step is 25 x smaller than in 2D).
  runMonitored(w, monitor, isLong ? 200000 : (D == 2 ? 6000 : 20000), out, [] { return false; });
  return finishCase(monitor, out, t0);
}

// --------------------------------------------------------------- tool crush --

template <int D>
StabilityResult toolCrushCase(CaseLength length) {
  const auto t0 = Clock::now();
  const bool isLong = length == CaseLength::Long;
  StabilityResult out;
  out.name = "tool_crush";
  out.minBreakages = isLong ? 100 : 10;
  out.note = "a kinematic box tool crushing a dense bed of breakable grains";
  out.overlapLimit = 0.3;

  const double r = 0.01, gap = 2.05 * r;
  const int n = D == 2 ? 6 : 3;
  const int rows = D == 2 ? 4 : 2;
  WorldDef<D> def;
  def.contact.kn = 1e6;  // stiff enough for the stronger late fragments (see cascadeCase)
  def.contact.ks = 0.8e6;
  def.localDamping = 0.3;
  World<D> w(def);
  const double width = n * gap;
  const Box<D> box = boxOf<D>(width, rows * gap + 6.0 * r, width);
  closeBox<D>(w, box);
  // The bed starts without overlaps (a jitter of 0.02 r against gaps of 0.05 r;
  // 0.05 r put neighbours 0.05 r into each other, and in 3D the grains broke
  // on their initial springs within a few steps, before the tool touched them).
  const auto s = sphere<D>(r, D == 2 ? 10 : 8);
  addLattice<D>(w, s, Vec<D>::Constant(0.5 * gap), gap, {n, rows, n}, 0.02 * r);

  // The tool: a box slightly narrower than the container, above the bed, moving down.
  geometry::ShapeDef<D> toolDef;
  toolDef.kind = geometry::ShapeKind::Box;
  toolDef.halfExtents = Vec<D>::Constant(0.5 * width - 0.5 * r);
  toolDef.halfExtents[1] = 2.0 * r;
  toolDef.spacing = s->grid().spacing();
  toolDef.options.nodesPerCell = 1.0;
  dynamics::ToolDef<D> tool;
  tool.name = "ram";
  tool.shape = geometry::buildShape(toolDef);
  dynamics::ConstantVelocity<D> motion;
  // A tool's pose is that of its body frame, the principal frame of the box
  // (in 3D its thin axis is the third principal axis, not y): turn the body
  // so the box's own axes are the world's.
  const geometry::Mat<D> boxAxes = tool.shape->bodyToGrid().rotation;
  if constexpr (D == 2) {
    motion.orientation = std::atan2(boxAxes(1, 0), boxAxes(0, 0));
  } else {
    motion.orientation = Eigen::Quaterniond(boxAxes).normalized();
  }
  motion.position = Vec<D>::Constant(0.5 * width);
  motion.position[1] = rows * gap + 2.1 * r;
  motion.velocity = -0.5 * Vec<D>::Unit(1);
  tool.motion = motion;
  w.addTool(tool);
  Breakage<D>* brk = addBreakage(w, breakageDef<D>(2e4, 2.0 * r, s->grid().spacing()));

  StabilityMonitor<D> monitor(w, brk, box);
  const double travel = 0.5 * rows * gap;
  runMonitored(w, monitor, std::uint64_t(1) << 40, out,
               [&] { return 0.5 * w.time() > travel || brk->breakages() >= 4 * out.minBreakages; });
  return finishCase(monitor, out, t0);
}

// ------------------------------------------------------------------- impact --

template <int D>
StabilityResult impactCase(CaseLength length) {
  const auto t0 = Clock::now();
  const bool isLong = length == CaseLength::Long;
  StabilityResult out;
  out.name = "impact";
  out.minBreakages = 1;
  out.note = "a breakable grain at 10 m/s (10 x the usual 1 m/s) into a bed in a closed box";

  const double r = 0.01, gap = 2.05 * r;
  const int n = D == 2 ? 5 : 3;
  WorldDef<D> def;
  def.contact.kn = 3e7;
  def.contact.ks = 2.4e7;
  World<D> w(def);
  const Box<D> box = boxOf<D>(n * gap, 8 * gap, n * gap);
  closeBox<D>(w, box);
  const auto s = sphere<D>(r, D == 2 ? 12 : 8);
  addLattice<D>(w, s, Vec<D>::Constant(0.5 * gap), gap, {n, 2, n}, 0.05 * r);
  ParticleDef<D> bullet;
  bullet.shape = s;
  bullet.position = Vec<D>::Constant(0.5 * n * gap + 0.2 * r);
  bullet.position[1] = 2.0 * gap + 1.5 * r;
  bullet.velocity = -10.0 * Vec<D>::Unit(1);
  w.addParticle(bullet);
  Breakage<D>* brk = addBreakage(w, breakageDef<D>(2e6, 2.0 * r, s->grid().spacing()));

  StabilityMonitor<D> monitor(w, brk, box);
  runMonitored(w, monitor, isLong ? 40000 : (D == 2 ? 3000 : 1500), out, [] { return false; });
  return finishCase(monitor, out, t0);
}

// ---------------------------------------------------------------- grid edge --

template <int D>
StabilityResult gridEdgeCase(CaseLength length) {
  const auto t0 = Clock::now();
  const bool isLong = length == CaseLength::Long;
  StabilityResult out;
  out.name = "grid_edge";
  out.note = "small grains sliding off a large grain's grid, nodes on grid boundaries, needles and discs";

  WorldDef<D> def;
  def.contact.kn = 1e6;
  def.contact.ks = 0.8e6;
  def.gravity = Vec<D>(-9.81 * Vec<D>::Unit(1));
  World<D> w(def);
  const double R = 0.02;
  const Box<D> box = boxOf<D>(0.2, 0.2, 0.2);
  closeBox<D>(w, box);

  // A large grain resting on the floor.
  const auto big = sphere<D>(R, 12);
  ParticleDef<D> b;
  b.shape = big;
  b.position = Vec<D>::Constant(0.1);
  b.position[1] = R;
  w.addParticle(b);

  // A small grain placed so that one of its nodes lies exactly on the large
  // grain's grid boundary (the grid's upper x face), sliding sideways out of it.
  const auto small = sphere<D>(0.003, 8);
  {
    const geometry::Grid<D>& g = big->grid();
    Vec<D> corner = g.nodePosition(g.dims() - 1);  // grid frame, upper corner
    Vec<D> onFace = g.nodePosition(geometry::Index<D>::Zero());
    onFace[0] = corner[0];
    onFace = big->bodyToGrid().applyInverse(onFace);  // body frame of the large grain
    onFace[1] = 0.5 * R;
    ParticleDef<D> p;
    p.shape = small;
    const Vec<D> node = small->nodes().positions.front();
    p.position = b.position + onFace - node;
    p.velocity = Vec<D>::Unit(0) * 0.5;
    w.addParticle(p);
    // A second one entering the large grain's grid near its corner and
    // grazing its surface: on a straight path its centre would pass 1.1 R from
    // the large grain's centre (0.05 R inside the sum of the radii), starting
    // 1.5 R before that point, clear of the large grain.
    ParticleDef<D> q = p;
    Vec<D> along = Vec<D>::Zero(), across = Vec<D>::Zero();
    along[0] = 1.0;
    along[1] = -0.3;
    along.normalize();
    across[0] = -along[1];
    across[1] = along[0];
    q.position = b.position - 1.5 * R * along + 1.1 * R * across;
    q.velocity = along * std::sqrt(1.0 + 0.3 * 0.3);
    w.addParticle(q);
  }

  // Needles (aspect 10) and, in 3D, discs, thrown spinning at the walls.
  {
    Vec<D> needleAxes = Vec<D>::Constant(0.002);
    needleAxes[0] = 0.02;
    const auto needle = ellipsoid<D>(needleAxes, 4);
    std::vector<std::shared_ptr<const Shape<D>>> shapes{needle};
    if constexpr (D == 3) shapes.push_back(ellipsoid<D>(Vec<D>(0.02, 0.02, 0.002), 4));
    int k = 0;
    for (const auto& shape : shapes) {
      for (int c = 0; c < 2; ++c, ++k) {
        ParticleDef<D> p;
        p.shape = shape;
        p.position = Vec<D>::Constant(0.05 + 0.03 * k);
        p.position[1] = 0.12 + 0.03 * c;
        p.velocity = Vec<D>::Unit(0) * (c == 0 ? 1.0 : -1.0);
        if constexpr (D == 2) {
          p.angularVelocity = 30.0 * (c == 0 ? 1.0 : -1.0);
        } else {
          p.angularVelocity = Vec<3>(20.0, -35.0, 10.0 * (c + 1));
        }
        w.addParticle(p);
      }
    }
  }

  StabilityMonitor<D> monitor(w, nullptr, box);
  // Short: in 3D long enough for the grazing grain to reach the large one.
  runMonitored(w, monitor, isLong ? 200000 : (D == 2 ? 8000 : 16000), out, [] { return false; });
  return finishCase(monitor, out, t0);
}

// ------------------------------------------------------------------ settled --

template <int D>
StabilityResult settledCase(CaseLength length) {
  const auto t0 = Clock::now();
  const bool isLong = length == CaseLength::Long;
  StabilityResult out;
  out.name = "settled";
  out.note = "a settled packing under gravity with breakage enabled, run for a long time";

  const double r = 0.01, gap = 2.1 * r;
  const int n = D == 2 ? 6 : 3;
  const int rows = D == 2 ? 5 : 2;
  WorldDef<D> def;
  def.contact.kn = 2e5;
  def.contact.ks = 1.6e5;
  def.gravity = Vec<D>(-9.81 * Vec<D>::Unit(1));
  def.localDamping = 0.1;
  World<D> w(def);
  const Box<D> box = boxOf<D>(n * gap, (rows + 2) * gap, n * gap);
  closeBox<D>(w, box);
  const auto s = sphere<D>(r, D == 2 ? 10 : 8);
  addLattice<D>(w, s, Vec<D>::Constant(0.5 * gap), gap, {n, rows, n}, 0.1 * r);
  // Strong enough that the settled weight breaks nothing: breakage runs every
  // step (stresses, criterion) without splitting.
  Breakage<D>* brk = addBreakage(w, breakageDef<D>(1e7, 2.0 * r, s->grid().spacing()));

  StabilityMonitor<D> monitor(w, brk, box);
  const std::uint64_t steps = isLong ? 1000000 : 20000;
  runMonitored(w, monitor, steps, out, [] { return false; });
  return finishCase(monitor, out, t0);
}

// -------------------------------------------------------------------- cases --

std::vector<StabilityCase> stabilityCases() {
  std::vector<StabilityCase> cases;
  auto add = [&](const char* name, const char* description, auto run2, auto run3) {
    cases.push_back({name, 2, description, run2});
    cases.push_back({name, 3, description, run3});
  };
  add("split_limits", "splitter at the resolution limit, slivers, grazing and missing cuts, degenerate planes",
      splitLimitsCase<2>, splitLimitsCase<3>);
  add("cascade", "crushing cascade in a closed box down to fines", cascadeCase<2>, cascadeCase<3>);
  add("split_in_contact", "splits of grains in hard contact with walls and neighbours", splitInContactCase<2>,
      splitInContactCase<3>);
  add("mass_ratio", "1e4 mass ratio between touching grains", massRatioCase<2>, massRatioCase<3>);
  add("tool_crush", "kinematic tool crushing a dense breakable bed", toolCrushCase<2>, toolCrushCase<3>);
  add("impact", "impact at 10 x the usual speed", impactCase<2>, impactCase<3>);
  add("grid_edge", "grid boundaries, leaving a neighbour's grid, needles and discs", gridEdgeCase<2>,
      gridEdgeCase<3>);
  add("settled", "long run of a settled packing with breakage", settledCase<2>, settledCase<3>);
  return cases;
}

template StabilityResult cascadeCase<2>(CaseLength);
template StabilityResult cascadeCase<3>(CaseLength);
template StabilityResult splitInContactCase<2>(CaseLength);
template StabilityResult splitInContactCase<3>(CaseLength);
template StabilityResult massRatioCase<2>(CaseLength);
template StabilityResult massRatioCase<3>(CaseLength);
template StabilityResult toolCrushCase<2>(CaseLength);
template StabilityResult toolCrushCase<3>(CaseLength);
template StabilityResult impactCase<2>(CaseLength);
template StabilityResult impactCase<3>(CaseLength);
template StabilityResult gridEdgeCase<2>(CaseLength);
template StabilityResult gridEdgeCase<3>(CaseLength);
template StabilityResult settledCase<2>(CaseLength);
template StabilityResult settledCase<3>(CaseLength);

}  // namespace lsdem::study
