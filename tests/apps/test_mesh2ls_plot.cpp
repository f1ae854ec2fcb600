// End-to-end checks of `lsdem mesh2ls` and `lsdem plot` as a user runs them:
// a cube STL becomes a grain file with the cube's volume and centroid, broken
// meshes and bad options end in one line and exit code 2, and `lsdem plot`
// draws PNG files, says when gnuplot is missing (exit 3) and when the folder
// holds no CSV file (exit 2) or none with rows (exit 3).

#include "support/Files.h"
#include "support/Json.h"
#include "support/Process.h"
#include "lsdem/geometry/MeshIO.h"
#include "lsdem/geometry/TriangleMesh.h"
#include "lsdem/io/GrainFile.h"

#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <sys/wait.h>

namespace fs = std::filesystem;
using lsdem::test::jsonNumber;
using namespace lsdem;

namespace {

using Result = lsdem::test::ProcessResult;

// `ENV lsdem ARGS` (ENV: variable assignments), stdout and stderr together.
Result run(const std::string& args, const std::string& env = "") {
  return lsdem::test::runShell(env + " " + std::string(LSDEM_BINARY) + " " + args);
}

fs::path tempDir(const std::string& name) {
  const fs::path dir = lsdem::test::tempPath("lsdem_test_mesh2ls_plot_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// An axis-aligned box [lo, lo + size]^3 as 12 outward triangles.
geometry::TriangleMesh box(double lo, double size) {
  geometry::TriangleMesh m;
  for (int k = 0; k < 8; ++k) m.vertices.push_back(geometry::Vec<3>(lo + size * (k & 1), lo + size * ((k >> 1) & 1), lo + size * (k >> 2)));
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    m.faces.push_back({q[0], q[1], q[2]});
    m.faces.push_back({q[0], q[2], q[3]});
  }
  return m;
}

bool isPng(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::string head(8, '\0');
  in.read(head.data(), 8);
  return in && head == std::string("\x89PNG\r\n\x1a\n", 8);
}

}  // namespace

TEST(Mesh2ls, CubeBecomesAGrainFile) {
  const fs::path dir = tempDir("cube");
  // A 10 mm cube written in millimetres from 2 to 12, converted at 1 mm spacing.
  geometry::writeStl(box(2.0, 10.0), (dir / "cube.stl").string());
  const std::string grain = (dir / "cube.lsg").string();
  const Result r = run("mesh2ls " + (dir / "cube.stl").string() + " --spacing 0.001 --scale 0.001 -o " + grain + " --json");
  ASSERT_EQ(r.code, 0) << r.output;
  // Volume 1e-6 m^3 (the sharp edges at 10 cells across cost ~1%), centroid at 7 mm.
  const double volume = jsonNumber(r.output, "volume");
  EXPECT_NEAR(volume, 1e-6, 0.02e-6);
  EXPECT_DOUBLE_EQ(jsonNumber(r.output, "mesh_volume"), 1e-6);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(jsonNumber(r.output, "centroid", a), 0.007, 1e-6);
  EXPECT_GT(jsonNumber(r.output, "nodes"), 1000);
  // The file holds that grain.
  EXPECT_EQ(io::grainFileDimension(grain), 3);
  const auto shape = io::readGrainFile<3>(grain);
  EXPECT_EQ(shape->volume(), volume);
  EXPECT_EQ(double(shape->nodes().size()), jsonNumber(r.output, "nodes"));
  EXPECT_NEAR(shape->bodyToGrid().translation[2], 0.007, 1e-6);

  // Binary form, 1 node per cell, text report.
  const std::string bin = (dir / "cube_bin.lsg").string();
  const Result b = run("mesh2ls " + (dir / "cube.stl").string() + " --spacing 0.001 --scale 0.001 --binary --nodes-per-cell 1 -o " + bin);
  ASSERT_EQ(b.code, 0) << b.output;
  EXPECT_NE(b.output.find("volume"), std::string::npos);
  EXPECT_NE(b.output.find("centroid       (0.007, 0.007, 0.007) m"), std::string::npos) << b.output;
  std::ifstream in(bin, std::ios::binary);
  EXPECT_EQ(in.get(), 0x89);
  const auto coarse = io::readGrainFile<3>(bin);
  EXPECT_EQ(coarse->volume(), shape->volume());  // same grid, same mass properties
  EXPECT_LT(coarse->nodes().size(), shape->nodes().size());
  EXPECT_EQ(b.output.find("note:"), std::string::npos) << b.output;

  // A handful of nodes is written, and noted (as `lsdem shape` notes it).
  const Result few = run("mesh2ls " + (dir / "cube.stl").string() + " --spacing 0.001 --scale 0.001 --nodes-per-cell 1e-6 -o " +
                         (dir / "few.lsg").string());
  ASSERT_EQ(few.code, 0) << few.output;
  EXPECT_NE(few.output.find("lsdem: note: " + (dir / "few.lsg").string() + ": the grain has only "), std::string::npos)
      << few.output;
  EXPECT_NE(few.output.find(" surface nodes: contacts are found at these points only (--nodes-per-cell)"),
            std::string::npos)
      << few.output;
}

TEST(Mesh2ls, BadInputEndsInOneLineAndExitCode2) {
  const fs::path dir = tempDir("bad");
  // An open cube (one face missing).
  geometry::TriangleMesh open = box(0.0, 1.0);
  open.faces.pop_back();
  const std::string openPath = (dir / "open.stl").string();
  geometry::writeStl(open, openPath);
  const Result o = run("mesh2ls " + openPath + " --spacing 0.1 -o " + (dir / "x.lsg").string());
  EXPECT_EQ(o.code, 2);
  EXPECT_EQ(o.output, "lsdem: " + openPath + ": mesh is not closed (3 border edges)\n");
  EXPECT_FALSE(fs::exists(dir / "x.lsg"));
  // Not a mesh at all.
  std::ofstream(dir / "junk.stl") << "hello\n";
  const Result j = run("mesh2ls " + (dir / "junk.stl").string() + " --spacing 0.1 -o " + (dir / "x.lsg").string());
  EXPECT_EQ(j.code, 2);
  EXPECT_EQ(j.output.rfind("lsdem: " + (dir / "junk.stl").string() + ": cannot read mesh file", 0), 0u) << j.output;
  EXPECT_EQ(std::count(j.output.begin(), j.output.end(), '\n'), 1);
  // A missing file and bad numbers.
  const Result m = run("mesh2ls " + (dir / "missing.stl").string() + " --spacing 0.1 -o x.lsg");
  EXPECT_EQ(m.code, 2);
  EXPECT_EQ(m.output, "lsdem: " + (dir / "missing.stl").string() + ": no such mesh file\n");
  geometry::writeStl(box(0.0, 1.0), (dir / "cube.stl").string());
  const Result s = run("mesh2ls " + (dir / "cube.stl").string() + " --spacing 0 -o x.lsg");
  EXPECT_EQ(s.code, 2);
  EXPECT_EQ(s.output, "lsdem: --spacing: must be positive, got 0\n");
  const Result c = run("mesh2ls " + (dir / "cube.stl").string() + " --spacing 0.1 --scale -2 -o x.lsg");
  EXPECT_EQ(c.code, 2);
  EXPECT_EQ(c.output, "lsdem: --scale: must be positive, got -2\n");
  // A spacing that cannot resolve the cube (0.5 cells across it), as a
  // scene's mesh shape is refused.
  const Result coarse = run("mesh2ls " + (dir / "cube.stl").string() + " --spacing 2 -o " + (dir / "x.lsg").string());
  EXPECT_EQ(coarse.code, 2);
  EXPECT_EQ(coarse.output,
            "lsdem: --spacing: gives 0.5 cells across the mesh's smallest extent (1 at spacing 2); it must give 2 to 1e4\n");
  EXPECT_FALSE(fs::exists(dir / "x.lsg"));
  // A required option missing: CLI11's usage error, non-zero.
  EXPECT_NE(run("mesh2ls " + (dir / "cube.stl").string() + " -o x.lsg").code, 0);
}

TEST(Plot, RunFolderToPngs) {
  const fs::path dir = tempDir("run");
  // An empty folder: one line, exit 2.
  const Result e = run("plot " + dir.string());
  EXPECT_EQ(e.code, 2);
  EXPECT_EQ(e.output.rfind("lsdem: " + dir.string() + ": holds none of history.csv", 0), 0u) << e.output;
  EXPECT_EQ(std::count(e.output.begin(), e.output.end(), '\n'), 1);

  // A history with a specimen and a breakage log.
  {
    std::ofstream h(dir / "history.csv");
    h << "step,time_s,particles,contacts,breakages,removed_mass_kg,kinetic_J,elastic_J,gravity_work_J,boundary_work_J,"
         "damping_loss_J,contact_loss_J,energy_error_J,stress_Pa,strain,void_ratio\n";
    for (int i = 1; i <= 10; ++i) {
      h << i << ',' << 0.1 * i << ",3,2," << i / 4 << ",0,1,2,3,4,5,6,0," << 1e5 * i << ',' << 0.01 * i << ','
        << 0.8 - 0.01 * i << '\n';
    }
    std::ofstream b(dir / "breakage_log.csv");
    b << "time_s,parent_id,child_ids,criterion_value_Pa,strength_Pa,manual,buckling\n"
         "0.4,1,4;5,2e6,1.9e6,0,0\n0.8,4,6;7,3e6,2.5e6,0,0\n";
  }
  // Without gnuplot (PATH emptied): the message and exit 3.
  const Result n = run("plot " + dir.string(), "PATH=/nonexistent-lsdem");
  EXPECT_EQ(n.code, 3);
  EXPECT_EQ(n.output, "lsdem plot: gnuplot is not installed (apt-get install gnuplot-nox); the CSV files in " + dir.string() +
                       " can be plotted with any tool\n");
  // With gnuplot: PNG files in DIR/plots, or in --out.
  const Result probe = run("plot " + dir.string() + " --out " + (dir / "p").string());
  if (probe.code == 3) GTEST_SKIP() << "gnuplot is not installed";
  ASSERT_EQ(probe.code, 0) << probe.output;
  for (const char* png : {"energies.png", "breakages.png", "stress_strain.png", "void_ratio.png", "breakage_stress.png"}) {
    EXPECT_TRUE(isPng(dir / "p" / png)) << png;
    EXPECT_NE(probe.output.find(png), std::string::npos) << probe.output;
  }
  const Result d = run("plot " + dir.string());
  ASSERT_EQ(d.code, 0) << d.output;
  EXPECT_TRUE(isPng(dir / "plots" / "stress_strain.png"));
  EXPECT_NE(d.output.find("wrote " + (dir / "plots" / "void_ratio.png").string()), std::string::npos) << d.output;
  // An --out that cannot be made: an option error (it was a filesystem error, exit 1).
  const Result bad = run("plot " + dir.string() + " --out /proc/lsdem_no_such_folder");
  EXPECT_EQ(bad.code, 2) << bad.output;
  EXPECT_EQ(bad.output.rfind("lsdem: --out: cannot make the folder /proc/lsdem_no_such_folder", 0), 0u) << bad.output;

  // CSV files without rows: nothing drawn, exit 3.
  const fs::path headerOnly = tempDir("header_only");
  std::ofstream(headerOnly / "history.csv") << "step,time_s,particles,contacts,breakages,kinetic_J\n";
  const Result h = run("plot " + headerOnly.string());
  EXPECT_EQ(h.code, 3) << h.output;
  EXPECT_NE(h.output.find("lsdem plot: nothing to plot in " + headerOnly.string()), std::string::npos) << h.output;
}
