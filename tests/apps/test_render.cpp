// `lsdem render` end to end: a tiny run in 2D and in 3D, rendered to PNG
// (skipped only when gnuplot is absent); the frames the renderer reads hold
// the surfaces the run placed; bad folders, frames and options exit 2 with one
// line; a missing gnuplot exits 3.

#include "support/Files.h"
#include "support/Process.h"
#include "lsdem/io/VtpRead.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

namespace fs = std::filesystem;

namespace {

using Result = lsdem::test::ProcessResult;

// `ENV lsdem ARGS` (ENV: variable assignments), stdout and stderr together.
Result run(const std::string& args, const std::string& env = "") {
  return lsdem::test::runShell(env + " " + std::string(LSDEM_BINARY) + " " + args);
}

// One folder per process: ctest runs the tests of this file side by side, each
// in its own process that runs the scenes again.
fs::path tempDir() {
  const fs::path dir = lsdem::test::tempPath("lsdem_test_render_" + std::to_string(getpid()));
  fs::create_directories(dir);
  return dir;
}

bool haveGnuplot() { return std::system("command -v gnuplot > /dev/null 2>&1") == 0; }

bool isPng(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  char magic[8] = {};
  in.read(magic, 8);
  return in && std::string(magic, 8) == std::string("\x89PNG\r\n\x1a\n", 8);
}

// Two discs of radius 1 mm resting above a floor, next to a fixed square tool.
const char* kScene2d = R"(
[simulation]
dimension = 2
steps = 40
[contact]
kn = 1e5
[shapes.disc]
kind = "circle"
radius = 0.001
cells_across = 24
[shapes.block]
kind = "rectangle"
half_extents = [0.001, 0.001]
cells_across = 10
[[particles]]
shape = "disc"
density = 2650.0
positions = [[0.0, 0.0015], [0.0025, 0.0015]]
[[planes]]
name = "floor"
point = [0.0, 0.0]
[[tools]]
name = "block"
shape = "block"
position = [0.006, 0.0012]
[output]
frames = 2
)";

// The same in 3D, with spheres, a cube tool and a box of planes.
const char* kScene3d = R"(
[simulation]
dimension = 3
steps = 20
domain = { min = [-0.003, -0.003, 0.0], max = [0.009, 0.003, 0.004] }
[contact]
kn = 1e5
[shapes.ball]
kind = "sphere"
radius = 0.001
cells_across = 14
node_density = 1
[shapes.block]
kind = "box"
half_extents = [0.001, 0.001, 0.001]
cells_across = 8
[[particles]]
shape = "ball"
density = 2650.0
positions = [[0.0, 0.0, 0.0015], [0.0025, 0.0, 0.0015]]
[[planes]]
name = "floor"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
[[tools]]
name = "block"
shape = "block"
position = [0.006, 0.0, 0.0012]
[output]
frames = 2
)";

// Runs a scene once per test process; returns its output folder.
fs::path runScene(const std::string& name, const char* text) {
  const fs::path scene = tempDir() / (name + ".toml");
  std::ofstream(scene) << text;
  const fs::path out = tempDir() / (name + "-out");
  fs::remove_all(out);
  const Result r = run("run " + scene.string() + " --out " + out.string() + " --quiet");
  EXPECT_EQ(r.code, 0) << r.output;
  return out;
}

// Every surface point of every particle lies at the disc's / sphere's radius
// from that particle's centroid (the surfaces the renderer draws are the run's).
void expectSurfacesOnSpheres(const fs::path& out, double radius, double tolerance) {
  const lsdem::io::VtpPiece particles = lsdem::io::readVtp(out / "frames/particles_000002.vtp");
  const lsdem::io::VtpPiece surfaces = lsdem::io::readVtp(out / "frames/surfaces_000002.vtp");
  ASSERT_EQ(particles.pointCount(), 2u);
  const std::vector<double> pid = lsdem::io::arrayAsDoubles(*lsdem::io::findArray(particles.pointData, "id"));
  const std::vector<double> cid = lsdem::io::arrayAsDoubles(*lsdem::io::findArray(surfaces.cellData, "id"));
  std::map<std::int64_t, std::array<double, 3>> centre;
  for (std::size_t i = 0; i < 2; ++i) {
    centre[std::int64_t(pid[i])] = {particles.points[3 * i], particles.points[3 * i + 1], particles.points[3 * i + 2]};
  }
  const lsdem::io::VtkCells& cells = surfaces.polys.size() > 0 ? surfaces.polys : surfaces.lines;
  ASSERT_EQ(cid.size(), cells.size());
  ASSERT_GT(cells.size(), 1u);
  std::int64_t begin = 0;
  double worst = 0.0;
  for (std::size_t c = 0; c < cells.size(); ++c) {
    const auto& x0 = centre.at(std::int64_t(cid[c]));
    for (std::int64_t k = begin; k < cells.offsets[c]; ++k) {
      const std::size_t p = std::size_t(cells.connectivity[std::size_t(k)]);
      const double d = std::hypot(surfaces.points[3 * p] - x0[0], surfaces.points[3 * p + 1] - x0[1],
                                  surfaces.points[3 * p + 2] - x0[2]);
      worst = std::max(worst, std::abs(d - radius));
    }
    begin = cells.offsets[c];
  }
  EXPECT_LT(worst, tolerance);
}

class Render : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    out2d_ = runScene("render2d", kScene2d);
    out3d_ = runScene("render3d", kScene3d);
  }
  static void TearDownTestSuite() { fs::remove_all(tempDir()); }
  static fs::path out2d_, out3d_;
};
fs::path Render::out2d_, Render::out3d_;

}  // namespace

TEST_F(Render, FramesHoldTheRunsSurfaces) {
  // Discs of 1 mm on 24 cells: the outline is within 1% of a cell of the circle
  // plus marching-squares chord error; spheres on 14 cells likewise.
  expectSurfacesOnSpheres(out2d_, 0.001, 0.002 * 0.001);
  expectSurfacesOnSpheres(out3d_, 0.001, 0.01 * 0.001);
}

TEST_F(Render, DrawsPngIn2dAnd3d) {
  if (!haveGnuplot()) GTEST_SKIP() << "gnuplot is not installed";
  const fs::path png2 = tempDir() / "two.png", png3 = tempDir() / "three.png", pngp = tempDir() / "spheres.png";
  fs::remove(png2);
  fs::remove(png3);
  Result r = run("render " + out2d_.string() + " -o " + png2.string() + " --size 320x240");
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("2D, frame 2"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("2 particles"), std::string::npos) << r.output;
  EXPECT_TRUE(isPng(png2));
  r = run("render " + out3d_.string() + " --frame 0 --view 30,20 --color generation -o " + png3.string());
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("3D, frame 0"), std::string::npos) << r.output;
  EXPECT_TRUE(isPng(png3));
  r = run("render " + out3d_.string() + " --series particles --up y -o " + pngp.string());
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(isPng(pngp));
  // The script is kept on request and draws the same image.
  const fs::path gp = tempDir() / "two.gp";
  r = run("render " + out2d_.string() + " -o " + png2.string() + " --script " + gp.string());
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_GT(fs::file_size(gp), 100u);
}

TEST_F(Render, BadInputExitsTwoWithOneLine) {
  const std::string png = (tempDir() / "bad.png").string();
  const Result noDir = run("render " + (tempDir() / "nowhere").string() + " -o " + png);
  EXPECT_EQ(noDir.code, 2) << noDir.output;
  EXPECT_NE(noDir.output.find("is not a folder"), std::string::npos) << noDir.output;
  const Result notRun = run("render " + tempDir().string() + " -o " + png);
  EXPECT_EQ(notRun.code, 2) << notRun.output;
  EXPECT_NE(notRun.output.find("has no surfaces.pvd"), std::string::npos) << notRun.output;
  const Result frame = run("render " + out2d_.string() + " --frame 7 -o " + png);
  EXPECT_EQ(frame.code, 2) << frame.output;
  EXPECT_NE(frame.output.find("frame 7 does not exist"), std::string::npos) << frame.output;
  EXPECT_NE(frame.output.find("frames 0 to 2"), std::string::npos) << frame.output;
  for (const std::string opt : {"--frame x", "--view 30", "--size 10x10", "--color red", "--series nodes"}) {
    const Result r = run("render " + out2d_.string() + " " + opt + " -o " + png);
    EXPECT_EQ(r.code, 2) << opt << ": " << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  }
  const Result jpg = run("render " + out2d_.string() + " -o x.jpg");
  EXPECT_EQ(jpg.code, 2) << jpg.output;
}

// `lsdem paraview` checks its options as render does, before it looks for
// pvpython (so also where ParaView is not installed): a colouring it does
// not know, a size outside [64, 8000] pixels.
TEST_F(Render, ParaviewOptionsAreCheckedFirst) {
  for (const auto& [opt, says] : {std::pair<std::string, std::string>{"--color red", "--color: expected 'auto', 'id' or 'generation', got 'red'"},
                                  {"--size 16x16", "--size: width and height must be whole numbers of pixels in [64, 8000], got '16x16'"},
                                  {"--size 800", "--size: expected two numbers separated by 'x', got '800'"}}) {
    const Result r = run("paraview " + out2d_.string() + " " + opt + " --screenshot " + (tempDir() / "p.png").string());
    EXPECT_EQ(r.code, 2) << opt << ": " << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
    EXPECT_NE(r.output.find(says), std::string::npos) << r.output;
  }
}

TEST_F(Render, MissingGnuplotExitsThree) {
  const fs::path empty = tempDir() / "empty-path";
  fs::create_directories(empty);
  const Result r = run("render " + out2d_.string() + " -o " + (tempDir() / "none.png").string(),
                       "env PATH=" + empty.string());
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_NE(r.output.find("gnuplot is not installed"), std::string::npos) << r.output;
}
