// End-to-end checks of the `lsdem` command as a user runs it: exit codes,
// one-line errors, and the JSON of `lsdem shape`.

#include "support/Files.h"
#include "support/Json.h"
#include "support/Process.h"
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

namespace fs = std::filesystem;
using lsdem::test::jsonNumber;

namespace {

using Result = lsdem::test::ProcessResult;

// `lsdem ARGS`, stdout and stderr together.
Result run(const std::string& args) { return lsdem::test::runShell(std::string(LSDEM_BINARY) + " " + args); }

std::string example(const std::string& name) { return std::string(LSDEM_SOURCE_DIR) + "/examples/shapes/" + name; }

std::string writeFile(const std::string& name, const std::string& text) {
  const fs::path dir = lsdem::test::tempPath("lsdem_test_cli");
  fs::create_directories(dir);
  std::ofstream(dir / name) << text;
  return (dir / name).string();
}

}  // namespace

TEST(Cli, VersionAndHelp) {
  const Result v = run("--version");
  EXPECT_EQ(v.code, 0);
  EXPECT_NE(v.output.find("lsdem 0."), std::string::npos);
  const Result h = run("--help");
  EXPECT_EQ(h.code, 0);
  EXPECT_NE(h.output.find("shape"), std::string::npos);
  EXPECT_NE(run("").code, 0);  // a subcommand is required
}

TEST(Cli, ShapeJsonOfTheSphere) {
  const Result r = run("shape " + example("sphere.toml") + " --json");
  ASSERT_EQ(r.code, 0) << r.output;
  const double pi = 3.14159265358979323846;
  EXPECT_NEAR(jsonNumber(r.output, "volume"), 4.0 / 3.0 * pi * 0.125, 0.005 * 4.0 / 3.0 * pi * 0.125);
  EXPECT_NEAR(jsonNumber(r.output, "surface_area"), 4 * pi * 0.25, 0.01 * 4 * pi * 0.25);
  EXPECT_NEAR(jsonNumber(r.output, "sphericity"), 1.0, 0.01);
  EXPECT_NEAR(jsonNumber(r.output, "equivalent_diameter"), 1.0, 0.005);
  EXPECT_NEAR(jsonNumber(r.output, "sieve_size"), 1.0, 0.01);
  EXPECT_NEAR(jsonNumber(r.output, "aspect_ratio"), 1.0, 0.01);
  // The volume its surface (as the surfaces output draws it) encloses: the
  // polygonised sphere, a little inside the true one.
  const double enclosed = jsonNumber(r.output, "enclosed_volume");
  EXPECT_LT(enclosed, 4.0 / 3.0 * pi * 0.125);
  EXPECT_GT(enclosed, 0.99 * 4.0 / 3.0 * pi * 0.125);
  EXPECT_GT(jsonNumber(r.output, "nodes"), 100);
  EXPECT_GT(jsonNumber(r.output, "bytes"), 1000);
  for (const char* key : {"\"dimension\": 3", "\"centroid\"", "\"inertia_principal\"", "\"grid_cells\""}) {
    EXPECT_NE(r.output.find(key), std::string::npos) << key;
  }
}

TEST(Cli, ShapeJsonOfTheEllipse) {
  const Result r = run("shape " + example("ellipse.toml") + " --json");
  ASSERT_EQ(r.code, 0) << r.output;
  const double pi = 3.14159265358979323846;
  EXPECT_NEAR(jsonNumber(r.output, "volume"), pi * 0.18, 0.005 * pi * 0.18);
  EXPECT_NEAR(jsonNumber(r.output, "aspect_ratio"), 0.5, 0.01);
  EXPECT_NEAR(jsonNumber(r.output, "sieve_size"), 0.6, 0.01);
  // Polar moment of an ellipse: pi a b (a^2 + b^2) / 4.
  EXPECT_NEAR(jsonNumber(r.output, "inertia_principal"), pi * 0.18 * 0.45 / 4, 0.005 * pi * 0.18 * 0.45 / 4);
  EXPECT_NE(r.output.find("\"circularity\""), std::string::npos);
}

TEST(Cli, EveryShippedExampleBuilds) {
  for (const auto& entry : fs::directory_iterator(std::string(LSDEM_SOURCE_DIR) + "/examples/shapes")) {
    if (entry.path().extension() != ".toml") continue;
    const Result r = run("shape " + entry.path().string());
    EXPECT_EQ(r.code, 0) << entry.path() << "\n" << r.output;
  }
}

TEST(Cli, BadInputIsOneLineWithFileLineKeyAndExitCode2) {
  const std::string path = writeFile("neg.toml", "[shape]\ndimension = 3\nkind = \"sphere\"\nradius = -1\nspacing = 0.1\n");
  const Result r = run("shape " + path);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.output, "lsdem: " + path + ":4: shape.radius: must be positive, got -1\n");

  const Result missing = run("shape /nonexistent/shape.toml");
  EXPECT_EQ(missing.code, 2);
  EXPECT_NE(missing.output.find("/nonexistent/shape.toml"), std::string::npos);
  EXPECT_EQ(std::count(missing.output.begin(), missing.output.end(), '\n'), 1);

  const std::string mesh = writeFile("mesh.toml", "[shape]\ndimension = 3\nkind = \"mesh\"\nfile = \"nothere.stl\"\nspacing = 0.1\n");
  const Result m = run("shape " + mesh);
  EXPECT_EQ(m.code, 2) << m.output;
  EXPECT_NE(m.output.find("nothere.stl"), std::string::npos);
}

// `lsdem split` on the sphere of the docs: the spherical cap above z = 0.25 and
// the rest, within 1 % of the analytic volumes and centroids, and corrected
// volumes that add up to the parent's.
TEST(Cli, SplitSphereGivesSphericalCaps) {
  const Result r = run("split " + example("sphere.toml") + " --plane 0,0,1,0.25 --json");
  ASSERT_EQ(r.code, 0) << r.output;
  const double pi = 3.14159265358979323846, R = 0.5, h = 0.25;
  const double cap = pi * h * h * (3 * R - h) / 3, sphere = 4.0 / 3.0 * pi * R * R * R;
  const std::size_t second = r.output.find("\"side\": -1") + 10;  // the text after the first fragment
  EXPECT_NEAR(jsonNumber(r.output, "volume"), sphere - cap, 0.01 * (sphere - cap));
  EXPECT_NEAR(jsonNumber(r.output.substr(second), "volume"), cap, 0.01 * cap);
  EXPECT_GT(jsonNumber(r.output.substr(second), "nodes"), 100);
  const double parent = jsonNumber(r.output, "parent_volume");
  EXPECT_NEAR(jsonNumber(r.output, "volume_sum"), parent, 1e-12 * parent);
  EXPECT_LT(std::abs(jsonNumber(r.output, "share_error")), 0.01);
  // The cap's centroid height 3 (2R - h)^2 / (4 (3R - h)) above the centre.
  const std::size_t cz = r.output.find("\"centroid\"", second);
  std::smatch m;
  const std::string rest = r.output.substr(cz);
  ASSERT_TRUE(std::regex_search(rest, m, std::regex("\\[\\s*[-0-9.e+]+,\\s*[-0-9.e+]+,\\s*([-0-9.e+]+)")));
  EXPECT_NEAR(std::stod(m[1]), 3 * (2 * R - h) * (2 * R - h) / (4 * (3 * R - h)), 0.01 * R);
}

// --regrid-cells: the cap 0.25 thick (5 cells, a smallest extent below 10) gets a
// finer grid of its own; each fragment's surface encloses its mass volume to
// within the rounding of the rim (docs/breakage.md).
TEST(Cli, SplitRegridsAThinCapAndReportsEnclosedVolumes) {
  const Result r = run("split " + example("sphere.toml") + " --plane 0,0,1,0.25 --regrid-cells 10 --json");
  ASSERT_EQ(r.code, 0) << r.output;
  const std::size_t second = r.output.find("\"side\": -1") + 10;
  const std::string cap = r.output.substr(second);
  EXPECT_NE(cap.find("\"regridded\": true"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\"regridded\": false"), std::string::npos) << r.output;
  for (const std::string& fragment : {r.output, cap}) {
    const double volume = jsonNumber(fragment, "volume"), enclosed = jsonNumber(fragment, "enclosed_volume");
    EXPECT_NEAR(enclosed, volume, 0.03 * volume);
  }
  const Result bad = run("split " + example("sphere.toml") + " --plane 0,0,1,0.25 --regrid-cells -1");
  EXPECT_EQ(bad.code, 2) << bad.output;
  EXPECT_EQ(run("split " + example("sphere.toml") + " --plane 0,0,1,0.25 --regrid-cells 1001").code, 2);
  // The cap's nodes keep the parent's spacing, as a run's fragments do
  // (2631 nodes); per new cell they are 4x as many (10594).
  const Result perCell =
      run("split " + example("sphere.toml") + " --plane 0,0,1,0.25 --regrid-cells 10 --regrid-nodes per_new_cell --json");
  ASSERT_EQ(perCell.code, 0) << perCell.output;
  const double capNodes = jsonNumber(cap, "nodes");
  const double perCellNodes = jsonNumber(perCell.output.substr(perCell.output.find("\"side\": -1") + 10), "nodes");
  EXPECT_GT(perCellNodes, 3.0 * capNodes) << capNodes << " " << perCellNodes;
}

TEST(Cli, SplitRejectsABadPlane) {
  const Result r = run("split " + example("ellipse.toml") + " --plane 1,0");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("needs 3 numbers"), std::string::npos) << r.output;
  const Result nan = run("split " + example("ellipse.toml") + " --plane 1,x,0");
  EXPECT_EQ(nan.code, 2);
  // A normal of any finite length is a direction (n.x = d as given): near
  // the ends of the double range too (1e300 printed a 300-digit offset and
  // failed; 1e-300 was "zero"; 1e-320 "not a number").
  const double volume = jsonNumber(run("split " + example("ellipse.toml") + " --plane 0,1,0.1 --json").output, "volume");
  for (const char* plane : {"0,1e300,1e299", "0,1e-300,1e-301", "0,1e-320,1e-321"}) {
    const Result scaled = run("split " + example("ellipse.toml") + " --plane=" + plane + " --json");
    ASSERT_EQ(scaled.code, 0) << plane << "\n" << scaled.output;
    EXPECT_NEAR(jsonNumber(scaled.output, "volume"), volume, 1e-3 * volume) << plane;
  }
  const Result far = run("split " + example("ellipse.toml") + " --plane=0,1e-300,1e300");
  EXPECT_EQ(far.code, 2) << far.output;
  EXPECT_NE(far.output.find("lies farther than any shape can reach"), std::string::npos) << far.output;
}

// Command-line usage errors exit with 2, like bad input files (CLI11's own
// codes 105-109 before issue 16); help and version with 0.
TEST(Cli, UsageErrorsExitWithCode2) {
  for (const char* args : {"run --no-such-option", "run", "no-such-command", "run scene.toml --threads -3",
                           "run scene.toml --steps many", "shape", "split", "bench stability --case foo",
                           "bench stability --case cascade --out /proc/lsdem_no_such_folder",
                           "bench accuracy --seeds 5"}) {
    const Result r = run(args);
    EXPECT_EQ(r.code, 2) << args << "\n" << r.output;
    // One line, "lsdem: " first.
    EXPECT_EQ(r.output.rfind("lsdem: ", 0), 0u) << args << "\n" << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << args << "\n" << r.output;
  }
  EXPECT_EQ(run("run --help").code, 0);
}

// `lsdem run --check`: the default scene passes it (22 splits, none makes
// energy) and reports the check in summary.json; the limit needs --check.
TEST(Cli, CheckModeRunsTheDefaultScene) {
  const fs::path out = lsdem::test::tempPath("lsdem_test_cli_check_" + std::to_string(::getpid()));
  fs::remove_all(out);
  const Result r = run("run " + std::string(LSDEM_SOURCE_DIR) + "/apps/scenes/three_grains/three_grains_2d.toml --out " +
                       out.string() + " --quiet --check --split-energy-limit 0.01");
  ASSERT_EQ(r.code, 0) << r.output;
  std::ifstream in(out / "summary.json");
  const std::string summary((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_GE(jsonNumber(summary, "breakages"), 10.0);
  EXPECT_EQ(jsonNumber(summary, "largest_split_energy_gain"), 0.0);
  EXPECT_EQ(jsonNumber(summary, "unchecked_splits"), 0.0);
  fs::remove_all(out);

  const Result usage = run("run " + std::string(LSDEM_SOURCE_DIR) +
                           "/apps/scenes/three_grains/three_grains_2d.toml --split-energy-limit 0.01");
  EXPECT_EQ(usage.code, 2) << usage.output;
  EXPECT_NE(usage.output.find("--check"), std::string::npos) << usage.output;
}
