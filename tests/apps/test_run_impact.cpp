// A Hertz scene with friction and no `ks`, run as a user runs it: an
// aluminium sphere (1 cm radius) strikes a rigid floor (`material = { rigid =
// true }`) at 80 degrees from the normal. Mindlin's spring, from E and nu,
// carries the friction: under gross sliding the contact point's tangential
// restitution is 1 - mu (1 + e) (1 + m R^2 / I) v_n / v_t = 0.630 and the
// sphere leaves spinning at -mu (1 + e) m v_n R / I = -150 rad/s (Maw,
// Barber & Fawcett; Chung & Ooi's oblique impacts). With the old default
// tangential stiffness (0.8 N/m) the sphere would leave as it came: 1 and 0.

#include "support/Files.h"
#include "support/Process.h"
#include "support/VtpReader.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using lsdem::test::runToExit;

namespace {

const char* kObliqueScene = R"([simulation]
dimension = 3
duration = 1.2e-4
dt = 2.5e-7

[contact]
model = "hertz"
youngs_modulus = 7.0e10
poisson_ratio = 0.3
friction = 0.3

[shapes.ball]
kind = "sphere"
radius = 0.01
cells_across = 20
node_density = 1.0

[[particles]]
shape = "ball"
density = 2700.0
placement = "list"
positions = [[0.0, 0.01002, 0.0]]
velocity = [5.6712818, -1.0, 0.0]  # 80 degrees from the normal, v_n = 1 m/s

[[planes]]
name = "floor"
point = [0.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
material = { rigid = true }

[output]
frames = 1
vtk = ["particles"]
)";

}  // namespace

TEST(RunImpact, HertzWithFrictionAndNoKsGrips) {
  const fs::path dir = lsdem::test::tempPath("lsdem_test_run_impact");
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir / "oblique.toml") << kObliqueScene;
  ASSERT_EQ(runToExit({LSDEM_BINARY, "run", (dir / "oblique.toml").string(), "--out", (dir / "out").string(), "--quiet"}), 0);

  // The sphere after the impact (the last frame), clear of the floor.
  const lsdem::test::VtpFile frame = lsdem::test::readVtp((dir / "out" / "frames" / "particles_000001.vtp").string());
  ASSERT_EQ(frame.points, 1u);
  const auto& v = frame.pointArray("velocity").f64;
  const auto& w = frame.pointArray("angular_velocity").f64;
  ASSERT_EQ(v.size(), 3u);
  ASSERT_EQ(w.size(), 3u);
  const double vn = 1.0, vt = 5.6712818, radius = 0.01, mu = 0.3;
  const double lever = 1.0 + 2.5;  // 1 + m R^2 / I for a solid sphere
  // It left the floor: rising at the end, its lowest surface node (45 um
  // inside the exact sphere at 20 cells across) clear of it.
  EXPECT_GT(frame.coordinates[1], 0.00996);
  EXPECT_NEAR(v[1], vn, 0.02 * vn);  // undamped: e_n = 1
  const double contactPoint = v[0] + w[2] * radius;
  const double expected = 1.0 - mu * 2.0 * lever * vn / vt;
  EXPECT_NEAR(contactPoint / vt, expected, 0.05 * expected);
  const double spin = -mu * 2.0 * 2.5 * vn / radius;
  // The spin (measured -140 rad/s) and the small roll about x (9.6 rad/s)
  // follow the one node that touches: it sits just off the pole (45 um
  // inside the exact sphere) and off the plane of motion, so its lever is
  // not the sphere's radius.
  EXPECT_NEAR(w[2], spin, 0.10 * std::abs(spin));
  EXPECT_LT(std::abs(w[0]), 0.10 * std::abs(spin));
  fs::remove_all(dir);
}
