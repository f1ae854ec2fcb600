// Chung & Ooi (2011) tests 1 and 2 through the run (io::runScene), against the
// closed-form Hertz impact: the validation scenes of apps/scenes/validation
// as shipped (10 cells across, nodes on the exact surface, tricubic look-up)
// and the same at 20 cells. Peak force, contact duration and the maximum
// geometric overlap come from the run's tracks.csv. docs/accuracy.md "Chung &
// Ooi impacts through lsdem run" has the figures of every setting.

#include "support/Files.h"
#include "lsdem/io/Run.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <numbers>
#include <regex>
#include <sstream>

using namespace lsdem;
namespace fs = std::filesystem;

namespace {

// One impact: a ball on a ball of its kind (test 1) or on a rigid plane (test 2).
struct Impact {
  const char* scene;  // under apps/scenes/validation
  int dimension;
  double radius, youngsModulus, poissonRatio, density, speed;  // m, Pa, -, kg/m^3, m/s (each body's)
  bool onPlane;
};

// Peak overlap (m), peak force (N; N/m in 2D), contact duration (s).
struct Figures {
  double overlap = 0.0, force = 0.0, duration = 0.0;
};

// The Hertz impact m* d2(delta)/dt2 = -4/3 E* sqrt(R*) delta^(3/2) from the
// speed of approach v: delta_max = (15 m* v^2 / (16 E* sqrt(R*)))^(2/5),
// F_max = 4/3 E* sqrt(R*) delta_max^(3/2), t_c = 2.9432 delta_max / v. In
// 2D lsdem's law is this formula per metre with masses per metre
// (ContactLaw.h hertzForce), so the same closed form holds.
Figures hertz(const Impact& c) {
  const double pi = std::numbers::pi;
  const double mass = c.density * (c.dimension == 3 ? 4.0 / 3.0 * pi * std::pow(c.radius, 3) : pi * c.radius * c.radius);
  const double e = c.youngsModulus / (1.0 - c.poissonRatio * c.poissonRatio);  // one body's E / (1 - nu^2)
  const double m = c.onPlane ? mass : mass / 2.0;
  const double eStar = c.onPlane ? e : e / 2.0;
  const double rStar = c.onPlane ? c.radius : c.radius / 2.0;
  const double v = c.onPlane ? c.speed : 2.0 * c.speed;
  Figures f;
  f.overlap = std::pow(15.0 * m * v * v / (16.0 * eStar * std::sqrt(rStar)), 0.4);
  f.force = 4.0 / 3.0 * eStar * std::sqrt(rStar) * std::pow(f.overlap, 1.5);
  // 2 int_0^1 (1 - x^(5/2))^(-1/2) dx = 2 B(2/5, 1/2) / (5/2)
  const double factor = 0.8 * std::tgamma(0.4) * std::tgamma(0.5) / std::tgamma(0.9);
  f.duration = factor * f.overlap / v;
  return f;
}

std::vector<double> fields(const std::string& line) {
  std::vector<double> out;
  std::stringstream s(line);
  for (std::string c; std::getline(s, c, ',');) out.push_back(std::stod(c));
  return out;
}

// Runs the scene at `cells` across with the given node placement and look-up,
// and measures the impact in its tracks.csv.
Figures run(const Impact& c, int cells, const std::string& nodesOn = "exact_surface",
            const std::string& interpolation = "tricubic") {
  std::string text = test::readFile(fs::path(LSDEM_SOURCE_DIR) / "apps/scenes/validation" / c.scene);
  text = std::regex_replace(text, std::regex("cells_across = \\d+"), "cells_across = " + std::to_string(cells));
  text = std::regex_replace(text, std::regex("nodes_on = \"\\w+\""), "nodes_on = \"" + nodesOn + "\"");
  text = std::regex_replace(text, std::regex("interpolation = \"\\w+\""), "interpolation = \"" + interpolation + "\"");
  std::smatch dtMatch;
  EXPECT_TRUE(std::regex_search(text, dtMatch, std::regex("\ndt = ([0-9.e-]+)")));
  const double dt = std::stod(dtMatch[1]);
  const fs::path dir = test::tempPath(std::string("chung_ooi_") + c.scene + "_" + std::to_string(cells));
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir / "scene.toml") << text;
  io::RunOptions o;
  o.scene = (dir / "scene.toml").string();
  o.outDir = (dir / "out").string();
  o.threads = 1;
  io::runScene(o);

  // Rows: step, time, id, position (D), velocity (D), spin, force (D), torque.
  const int d = c.dimension, spin = d == 2 ? 1 : 3;
  const std::size_t force0 = 3 + 2 * std::size_t(d) + std::size_t(spin);
  std::map<long, std::map<int, std::vector<double>>> steps;
  std::istringstream in(test::readFile(dir / "out/tracks.csv"));
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    const std::vector<double> r = fields(line);
    steps[long(r[0])][int(r[2])] = r;
  }
  Figures f;
  double first = -1.0, last = -1.0;
  for (const auto& [step, rows] : steps) {
    const std::vector<double>& a = rows.at(0);
    double gap = 0.0;
    if (c.onPlane) {
      gap = a[4] - c.radius;  // the plane is y = 0
    } else {
      const std::vector<double>& b = rows.at(1);
      double s = 0.0;
      for (int k = 0; k < d; ++k) s += (b[3 + k] - a[3 + k]) * (b[3 + k] - a[3 + k]);
      gap = std::sqrt(s) - 2.0 * c.radius;
    }
    double force = 0.0;
    for (int k = 0; k < d; ++k) force += a[force0 + k] * a[force0 + k];
    force = std::sqrt(force);
    f.overlap = std::max(f.overlap, -gap);
    f.force = std::max(f.force, force);
    if (force > 0.0) {
      if (first < 0.0) first = a[1];
      last = a[1];
    }
  }
  // The force is sampled at the end of each step: the contact lasts from
  // within the step before the first sample to within the step after the last.
  f.duration = first >= 0.0 ? last - first + dt : 0.0;
  fs::remove_all(dir);
  return f;
}

struct Errors {
  double overlap, force, duration;
};

Errors errors(const Figures& got, const Figures& ref) {
  return {std::abs(got.overlap - ref.overlap) / ref.overlap, std::abs(got.force - ref.force) / ref.force,
          std::abs(got.duration - ref.duration) / ref.duration};
}

const Impact kTest1In3D{"chung_ooi_1_3d.toml", 3, 0.010, 48e9, 0.20, 2800.0, 10.0, false};
const Impact kTest2In3D{"chung_ooi_2_3d.toml", 3, 0.10, 70e9, 0.33, 2699.0, 20.475848502901393, true};
const Impact kTest1In2D{"chung_ooi_1_2d.toml", 2, 0.010, 48e9, 0.20, 2800.0, 10.0, false};
const Impact kTest2In2D{"chung_ooi_2_2d.toml", 2, 0.10, 70e9, 0.33, 2699.0, 7.476722739398317, true};

void report(const char* what, int cells, const Errors& e) {
  std::printf("%s, %d cells: overlap %.3e, force %.3e, duration %.3e\n", what, cells, e.overlap, e.force, e.duration);
}

}  // namespace

// The reference itself, against the equation of motion integrated step by
// step (RK4, 20000 steps over the contact): the closed form's overlap, force
// and duration, and Chung & Ooi's test 2 speed giving delta_max = 1 % of
// the diameter.
TEST(ChungOoi, HertzReferenceMatchesTheEquationOfMotion) {
  EXPECT_NEAR(hertz(kTest2In3D).overlap, 0.002, 1e-12);
  EXPECT_NEAR(hertz(kTest2In2D).overlap, 0.002, 1e-12);
  for (const Impact& c : {kTest1In3D, kTest2In3D, kTest1In2D, kTest2In2D}) {
    const Figures ref = hertz(c);
    // m* and K = 4/3 E* sqrt(R*) from the closed form's own figures: F_max = K delta_max^(3/2)
    // and the energy 1/2 m* v^2 = 2/5 K delta_max^(5/2).
    const double k = ref.force / std::pow(ref.overlap, 1.5);
    const double v0 = c.onPlane ? c.speed : 2.0 * c.speed;
    const double m = 0.8 * k * std::pow(ref.overlap, 2.5) / (v0 * v0);
    const double pi = std::numbers::pi;
    const double mass = c.density * (c.dimension == 3 ? 4.0 / 3.0 * pi * std::pow(c.radius, 3) : pi * c.radius * c.radius);
    EXPECT_NEAR(m, c.onPlane ? mass : mass / 2.0, 1e-12 * mass) << c.scene;
    const auto accel = [&](double delta) { return delta > 0.0 ? -k * std::pow(delta, 1.5) / m : 0.0; };
    const double h = ref.duration / 20000.0;
    double delta = 0.0, v = v0, t = 0.0, deepest = 0.0;
    while (true) {
      const double k1x = v, k1v = accel(delta);
      const double k2x = v + 0.5 * h * k1v, k2v = accel(delta + 0.5 * h * k1x);
      const double k3x = v + 0.5 * h * k2v, k3v = accel(delta + 0.5 * h * k2x);
      const double k4x = v + h * k3v, k4v = accel(delta + h * k3x);
      const double next = delta + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
      v += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
      if (next <= 0.0) {
        t += h * delta / (delta - next);  // the crossing, linearly within the step
        break;
      }
      delta = next;
      t += h;
      deepest = std::max(deepest, delta);
    }
    EXPECT_NEAR(deepest / ref.overlap, 1.0, 1e-6) << c.scene;
    EXPECT_NEAR(k * std::pow(deepest, 1.5) / ref.force, 1.0, 2e-6) << c.scene;
    EXPECT_NEAR(t / ref.duration, 1.0, 1e-4) << c.scene;
  }
}

// Test 2: the sphere (disc) on a rigid plane. The plane is exact and the
// nodes lie on the exact surface, so the law sees the overlap of the deepest
// node, a fixed offset d^2 / (2R) below the geometric overlap (d the
// distance of the first contact point from the nearest node, set by where
// the node pattern falls): the motion is Hertz's in the node overlap. Peak
// force and duration are then Hertz's to the mass properties, the time step
// and the slight turn the uneven node pattern gives the ball, and the
// geometric overlap is deeper by the offset (1.2 % of delta_max at 10 cells,
// 2 nodes per cell; it follows the node pattern, not the cells: 1.8 % at 20,
// 0.06 % at 40, so no order is asserted for it). The duration is counted in
// whole steps (dt / t_c = 5e-4 in 3D, 5e-4 in 2D).
TEST(ChungOoi, SphereOnARigidPlaneIsHertzAtTenCells) {
  const Figures ref = hertz(kTest2In3D);
  const Errors e10 = errors(run(kTest2In3D, 10), ref);
  const Errors e20 = errors(run(kTest2In3D, 20), ref);
  report("test 2, 3D", 10, e10);
  report("test 2, 3D", 20, e20);
  for (const Errors& e : {e10, e20}) {
    EXPECT_LT(e.overlap, 0.05);
    EXPECT_LT(e.force, 0.05);
    EXPECT_LT(e.duration, 0.05);
    EXPECT_LT(e.duration, 1.5e-7 / ref.duration);  // within one step
  }
  EXPECT_LT(e10.overlap, 0.015);  // measured 1.24 %
  EXPECT_LT(e10.force, 1e-4);     // measured 8.2e-5
  // Observed order of the force error, 10 -> 20 cells: 3.46 (2.3e-6 at 40: 3.1).
  EXPECT_GE(std::log2(e10.force / e20.force), 3.0);
}

TEST(ChungOoi, DiscOnARigidPlaneIsHertzAtTenCells) {
  const Figures ref = hertz(kTest2In2D);
  const Errors e10 = errors(run(kTest2In2D, 10), ref);
  const Errors e20 = errors(run(kTest2In2D, 20), ref);
  report("test 2, 2D", 10, e10);
  report("test 2, 2D", 20, e20);
  for (const Errors& e : {e10, e20}) {
    EXPECT_LT(e.overlap, 0.02);
    EXPECT_LT(e.force, 0.02);
    EXPECT_LT(e.duration, 0.02);
    EXPECT_LT(e.duration, 4e-7 / ref.duration);  // within one step
  }
  EXPECT_LT(e10.force, 2e-4);  // measured 1.0e-4
  // The overlap's excess is the deepest node's offset d^2 / (2R), d at most
  // half the nodes' spacing along the contour, h / 2 per node (2 per cell):
  // a bound that falls as h^2 (6.25 % of delta_max at 10 cells, 1.56 % at
  // 20), where the measured excess (1.51 %, 1.50 %) follows the pattern.
  for (const auto& [cells, e] : {std::pair{10, e10}, std::pair{20, e20}}) {
    const double spacing = 2.0 * kTest2In2D.radius / cells / 2.0;
    EXPECT_LE(e.overlap, 0.25 * spacing * spacing / (2.0 * kTest2In2D.radius) / ref.overlap) << cells << " cells";
  }
  // Observed order of the force error, 10 -> 20 cells: 2.52, below 3: the
  // disc's few contact nodes (2 per cell along the contour) straddle the
  // first contact point unevenly, the plane turns it a little (0.38 rad/s at
  // the rebound) and the deepest node's offset drifts during the contact;
  // that part falls more slowly than the mass properties' error (circle
  // area: order 3.4). 20 -> 40 cells: 1.4 (6.6e-6, near the time step's floor).
  EXPECT_GE(std::log2(e10.force / e20.force), 2.4);
}

// Test 1: two spheres (discs) head on. Hertz's magnitude is spread over the
// node contacts along their normals, which fan out over the contact patch,
// so the force along the line of centres is a little below the magnitude;
// the deficit grows with the patch's angle (the overlap over the radius),
// not with the cells: -0.30 % at 10 and -0.28 % at 20 cells in 3D (overlap
// 1.4 % of the diameter), -1.12 % and -1.13 % in 2D (7.7 %). The weaker push
// lets the bodies in deeper and keeps them in contact longer. The tricubic
// look-up is what makes the pair right at 10 cells: trilinear gives a
// geometric overlap 12 % (3D) too deep (docs/accuracy.md).
TEST(ChungOoi, TwoSpheresHeadOnAreHertzAtTenCells) {
  const Figures ref = hertz(kTest1In3D);
  const Errors e10 = errors(run(kTest1In3D, 10), ref);
  const Errors e20 = errors(run(kTest1In3D, 20), ref);
  report("test 1, 3D", 10, e10);
  report("test 1, 3D", 20, e20);
  for (const Errors& e : {e10, e20}) {
    EXPECT_LT(e.overlap, 0.05);
    EXPECT_LT(e.force, 0.05);
    EXPECT_LT(e.duration, 0.05);
  }
  EXPECT_LT(e10.overlap, 0.02);  // measured 1.79 %
  // Order ~0 of the force error: the same deficit at both resolutions.
  EXPECT_NEAR(e10.force, 0.0030, 0.0005);
  EXPECT_NEAR(e20.force, 0.0028, 0.0005);
}

TEST(ChungOoi, TwoDiscsHeadOnAreHertzAtTenCells) {
  const Figures ref = hertz(kTest1In2D);
  const Errors e10 = errors(run(kTest1In2D, 10), ref);
  const Errors e20 = errors(run(kTest1In2D, 20), ref);
  report("test 1, 2D", 10, e10);
  report("test 1, 2D", 20, e20);
  for (const Errors& e : {e10, e20}) {
    EXPECT_LT(e.overlap, 0.02);
    EXPECT_LT(e.force, 0.02);
    EXPECT_LT(e.duration, 0.02);
  }
  EXPECT_NEAR(e10.force, 0.0112, 0.0010);
  EXPECT_NEAR(e20.force, 0.0113, 0.0010);
}
