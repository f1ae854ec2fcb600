// End to end: `lsdem ct2ls` on labelled volumes written in the test. A sphere
// comes back as a grain file with its volume and centroid, listed in
// grains.csv and particles.toml (names zero-padded to the largest label);
// labels on the border, below the voxel count or in pieces are skipped with
// a line each; bad input ends in one line naming the
// file (and the label) with exit code 2.

#include "support/Files.h"
#include "support/Process.h"

#include "lsdem/io/GrainFile.h"
#include "lsdem/io/VolumeFile.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace lsdem;
using geometry::Index;
using geometry::LabelVolume;
using geometry::Vec;

namespace {

fs::path tempDir(const std::string& name) {
  const fs::path dir = lsdem::test::tempPath("lsdem_test_ct2ls_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// 40 x 36 x 34 voxels of 0.1 mm: label 5 a sphere of radius 10 voxels inside,
// label 2 a block on the x = 0 face, label 9 a speck of 8 voxels, label 11
// two blocks of 125 voxels far apart.
LabelVolume threeLabels() {
  LabelVolume v;
  v.dims = Index<3>(40, 36, 34);
  v.spacing = Vec<3>::Constant(1e-4);
  v.origin = Vec<3>(0.001, 0.002, 0.003);
  v.labels.assign(v.voxelCount(), 0);
  for (int k = 0; k < v.dims[2]; ++k)
    for (int j = 0; j < v.dims[1]; ++j)
      for (int i = 0; i < v.dims[0]; ++i) {
        const Vec<3> d = Vec<3>(i, j, k) - Vec<3>(22.3, 17.6, 16.2);
        std::uint32_t& l = v.labels[v.linear(i, j, k)];
        if (d.norm() < 10.0) l = 5;
        if (i < 6 && j < 8 && k < 8) l = 2;
        if (i >= 2 && i < 4 && j >= 30 && j < 32 && k >= 28 && k < 30) l = 9;
        if (i >= 34 && i < 39 && ((j >= 2 && j < 7 && k >= 2 && k < 7) || (j >= 28 && j < 33 && k >= 26 && k < 31))) {
          l = 11;
        }
      }
  return v;
}

}  // namespace

TEST(Ct2ls, SphereBecomesAGrainWhereItWasScanned) {
  const fs::path dir = tempDir("sphere");
  io::writeNrrd((dir / "scan.nrrd").string(), threeLabels(), io::VoxelType::UInt16, true);
  const test::ProcessResult r =
      test::runCaptured({LSDEM_BINARY, "ct2ls", (dir / "scan.nrrd").string(), "-o", (dir / "grains").string()});
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("label 2: skipped: touches the image border"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("label 9: skipped: 8 voxels, below --min-voxels 100"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("1 grains written"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("label 11: skipped: 2 separate bodies (a grain is one; split the label in the segmentation)"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("1 skipped on the border, 1 below --min-voxels, 1 in pieces"), std::string::npos) << r.output;

  // The grain: the sphere's volume within 1 % and its centre where it was scanned.
  const auto shape = io::readGrainFile<3>((dir / "grains" / "grain_05.lsg").string());
  const double r0 = 1e-3, exact = 4.0 / 3.0 * M_PI * r0 * r0 * r0;
  EXPECT_NEAR(shape->volume() / exact, 1.0, 0.01);
  const Vec<3> centre = Vec<3>(0.001, 0.002, 0.003) + 1e-4 * Vec<3>(22.3, 17.6, 16.2);
  EXPECT_LT((shape->bodyToGrid().translation - centre).norm(), 1e-6);

  // grains.csv: one row, the same centroid; particles.toml places it there.
  const std::string csv = test::readFile(dir / "grains" / "grains.csv");
  std::istringstream rows(csv);
  std::string head, row;
  std::getline(rows, head);
  std::getline(rows, row);
  EXPECT_EQ(head.substr(0, 37), "label,voxels,volume_m3,voxel_volume_m");
  std::vector<std::string> cells;
  std::stringstream cellStream(row);
  for (std::string c; std::getline(cellStream, c, ',');) cells.push_back(c);
  ASSERT_EQ(cells.size(), 12u) << row;
  EXPECT_EQ(cells[0], "5");
  EXPECT_NEAR(std::stod(cells[4]), centre[0], 1e-6);
  EXPECT_NEAR(std::stod(cells[6]), centre[2], 1e-6);
  EXPECT_EQ(cells[11], "grain_05.lsg");
  EXPECT_FALSE(std::getline(rows, row));
  const std::string toml = test::readFile(dir / "grains" / "particles.toml");
  EXPECT_NE(toml.find("[shapes.label_5]\nkind = \"grain_file\"\npath = \"grain_05.lsg\""), std::string::npos) << toml;
  EXPECT_NE(toml.find("positions = [[" + cells[4] + ", "), std::string::npos) << toml;
  // rotations_deg [rx, ry, rz] turn the body frame as the grain lay: Rz Ry Rx = bodyToGrid.
  const double deg = M_PI / 180.0;
  const geometry::Mat<3> turn = (Eigen::AngleAxisd(std::stod(cells[9]) * deg, Vec<3>::UnitZ()) *
                                 Eigen::AngleAxisd(std::stod(cells[8]) * deg, Vec<3>::UnitY()) *
                                 Eigen::AngleAxisd(std::stod(cells[7]) * deg, Vec<3>::UnitX()))
                                    .toRotationMatrix();
  EXPECT_LT((turn - shape->bodyToGrid().rotation).norm(), 1e-7);

  // --keep-border keeps label 2 (a block: 6 x 8 x 8 voxels, its volume exact to 2 %).
  const test::ProcessResult k = test::runCaptured(
      {LSDEM_BINARY, "ct2ls", (dir / "scan.nrrd").string(), "-o", (dir / "all").string(), "--keep-border", "--binary"});
  ASSERT_EQ(k.code, 0) << k.output;
  const auto block = io::readGrainFile<3>((dir / "all" / "grain_02.lsg").string());
  EXPECT_NEAR(block->volume() / (6 * 8 * 8 * 1e-12), 1.0, 0.02);
}

TEST(Ct2ls, BadInputEndsInOneLine) {
  const fs::path dir = tempDir("bad");
  const LabelVolume v = threeLabels();
  io::writeNrrd((dir / "scan.nrrd").string(), v, io::VoxelType::UInt8, false);
  const std::string scan = (dir / "scan.nrrd").string();
  const auto fails = [&](std::vector<std::string> args, const std::string& expected) {
    args.insert(args.begin(), {LSDEM_BINARY, "ct2ls"});
    const test::ProcessResult r = test::runCaptured(args);
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find(expected), std::string::npos) << r.output;
    // One error line, the last.
    const std::size_t at = r.output.find("lsdem: ");
    EXPECT_NE(at, std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("lsdem: ", at + 1), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find('\n', at), r.output.size() - 1) << r.output;
  };
  // Truncated file.
  const std::string text = test::readFile(scan);
  std::ofstream(dir / "cut.nrrd", std::ios::binary) << text.substr(0, text.size() - 100);
  fails({(dir / "cut.nrrd").string(), "-o", (dir / "o").string()},
        "lsdem: " + (dir / "cut.nrrd").string() + ": truncated: holds 48860 bytes of data");
  // A label over the memory cap, named.
  fails({scan, "-o", (dir / "o").string(), "--max-memory", "1"}, "lsdem: " + scan + ": label 5: needs about");
  // TIFF carries no spacing: asked for.
  io::writeTiff((dir / "scan.tif").string(), v, io::VoxelType::UInt8, true);
  fails({(dir / "scan.tif").string(), "-o", (dir / "o").string()},
        (dir / "scan.tif").string() + ": the tiff file gives no voxel spacing; give --spacing");
  // A multi-page TIFF cut short (a partial copy): refused, not read as fewer
  // slices (3/4 of the file was read as 26 of its 34 pages, exit 0).
  for (const double part : {0.25, 0.5, 0.75, 0.99}) {
    const std::string tiff = test::readFile(dir / "scan.tif");
    std::ofstream(dir / "cut.tif", std::ios::binary | std::ios::trunc) << tiff.substr(0, std::size_t(part * double(tiff.size())));
    fails({(dir / "cut.tif").string(), "-o", (dir / "o").string(), "--spacing", "1e-4", "--keep-border"},
          "truncated or corrupt");
  }
  // Only background.
  LabelVolume empty = v;
  std::fill(empty.labels.begin(), empty.labels.end(), 0u);
  io::writeNrrd((dir / "empty.nrrd").string(), empty, io::VoxelType::UInt8, true);
  fails({(dir / "empty.nrrd").string(), "-o", (dir / "o").string()},
        "empty.nrrd: holds no label other than the background 0");
  // Every label skipped.
  fails({scan, "-o", (dir / "o").string(), "--min-voxels", "100000"},
        "no grain written: all 4 labels skipped (1 on the border, 3 below --min-voxels, 0 in pieces)");
  // Bad options.
  fails({scan, "-o", (dir / "o").string(), "--cells-across", "-3"}, "lsdem: --cells-across: must be in [2, 10000], got -3");
  // (1 cell across made 5x the scanned volume; a spacing of 0 was taken as none.)
  fails({scan, "-o", (dir / "o").string(), "--cells-across", "1"}, "lsdem: --cells-across: must be in [2, 10000], got 1");
  fails({scan, "-o", (dir / "o").string(), "--grid-spacing", "0"}, "lsdem: --grid-spacing: must be positive, got 0");
  fails({scan, "-o", (dir / "o").string(), "--origin", "nan,0,0"},
        "lsdem: --origin: the first voxel lies at (nan, 0, 0) m: lsdem takes coordinates within 1e10 m");
  fails({scan, "-o", (dir / "o").string(), "--origin", "1e300,0,0"},
        "lsdem: --origin: the first voxel lies at (1e+300, 0, 0) m: lsdem takes coordinates within 1e10 m");
  fails({scan, "-o", (dir / "o").string(), "--grid-spacing", "0.01"},
        "lsdem: --grid-spacing: 0.01 m gives label 5 0.2 cells across its smallest extent (0.002 m); a grain needs 2 to "
        "10000 (lower it, or raise --min-voxels to skip small labels)");
  fails({scan, "-o", (dir / "o").string(), "--grid-spacing", "1e-9"},
        "lsdem: --grid-spacing: 1e-09 m gives label 5 2e+06 cells across its smallest extent (0.002 m); a grain needs 2 "
        "to 10000 (raise it)");
  fails({scan, "-o", (dir / "o").string(), "--raw-dims", "40,36", "--raw-type", "uint8"},
        "lsdem: --raw-dims: needs three sizes NX,NY,NZ");
  fails({scan, "-o", (dir / "o").string(), "--raw-endian", "big"}, "lsdem: --raw-endian: needs --raw-dims");
  fails({scan, "-o", (dir / "o").string(), "--raw-dims", "40,36,34"}, "lsdem: --raw-dims: needs --raw-type");
  fails({scan, "-o", (dir / "o").string(), "--raw-dims", "40,36,34", "--raw-type", "float"},
        "lsdem: --raw-type: must be uint8, uint16, uint32, int8, int16 or int32, got 'float'");
}

// A grain whose level set holds another volume than its voxels is noted
// (the sphere at 2 cells across: far too coarse), one that holds the same is not.
TEST(Ct2ls, AGrainOffItsVoxelsVolumeIsNoted) {
  const fs::path dir = tempDir("note");
  io::writeNrrd((dir / "scan.nrrd").string(), threeLabels(), io::VoxelType::UInt8, false);
  const auto run = [&](const std::string& cells) {
    return test::runCaptured(
        {LSDEM_BINARY, "ct2ls", (dir / "scan.nrrd").string(), "-o", (dir / "o").string(), "--cells-across", cells});
  };
  const test::ProcessResult coarse = run("2");
  EXPECT_EQ(coarse.code, 0) << coarse.output;
  EXPECT_NE(coarse.output.find("  note: label 5: its grain's volume is "), std::string::npos) << coarse.output;
  EXPECT_NE(coarse.output.find("% above its voxels' (2 cells across its smallest extent)"), std::string::npos)
      << coarse.output;
  EXPECT_NE(coarse.output.find("ct2ls: 1 notes above (a volume more than 2% off the voxels', or few surface nodes)"),
            std::string::npos)
      << coarse.output;
  const test::ProcessResult fine = run("20");
  EXPECT_EQ(fine.code, 0) << fine.output;
  EXPECT_EQ(fine.output.find("note:"), std::string::npos) << fine.output;
  EXPECT_EQ(fine.output.find("notes above"), std::string::npos) << fine.output;
}

// A headerless raw file and TIFF slices give the same grain as the NRRD.
TEST(Ct2ls, RawAndTiffGiveTheSameGrain) {
  const fs::path dir = tempDir("formats");
  const LabelVolume v = threeLabels();
  io::writeNrrd((dir / "scan.nrrd").string(), v, io::VoxelType::UInt8, false);
  const std::string nrrd = test::readFile(dir / "scan.nrrd");
  std::ofstream(dir / "scan.raw", std::ios::binary) << nrrd.substr(nrrd.size() - v.voxelCount());
  io::writeTiff((dir / "scan.tif").string(), v, io::VoxelType::UInt16, true);
  const std::string spacing = "--spacing=0.1", origin = "--origin=1,2,3";
  const std::vector<std::vector<std::string>> runs = {
      {(dir / "scan.nrrd").string(), "-o", (dir / "a").string()},
      {(dir / "scan.raw").string(), "-o", (dir / "b").string(), "--raw-dims", "40,36,34", "--raw-type", "uint8",
       spacing, origin, "--scale", "0.001"},
      {(dir / "scan.tif").string(), "-o", (dir / "c").string(), spacing, origin, "--scale", "0.001"}};
  std::vector<double> volumes;
  for (std::vector<std::string> args : runs) {
    args.insert(args.begin(), {LSDEM_BINARY, "ct2ls"});
    const test::ProcessResult r = test::runCaptured(args);
    ASSERT_EQ(r.code, 0) << r.output;
    const auto shape = io::readGrainFile<3>((fs::path(args[4]) / "grain_05.lsg").string());
    volumes.push_back(shape->volume());
  }
  EXPECT_NEAR(volumes[1] / volumes[0], 1.0, 1e-9);
  EXPECT_NEAR(volumes[2] / volumes[0], 1.0, 1e-9);
}

// The shipped example (apps/scenes/ct_grains) is what ct2ls makes of the
// shipped volume: the command in the scene's header gives grains.csv again
// (volumes and places to 1e-6; the NRRD names its lengths in mm, so no --scale).
TEST(Ct2ls, ShippedExampleIsReproduced) {
  const fs::path dir = tempDir("shipped");
  const fs::path scene = fs::path(LSDEM_SOURCE_DIR) / "apps" / "scenes" / "ct_grains";
  const test::ProcessResult r =
      test::runCaptured({LSDEM_BINARY, "ct2ls", (scene / "ct_grains.nrrd").string(), "-o", dir.string(),
                         "--cells-across", "10", "--nodes-per-cell", "1", "--binary"});
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("lengths in mm -> scale 0.001"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("label 7: skipped: touches the image border"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("label 8: skipped: 12 voxels"), std::string::npos) << r.output;
  const auto table = [](const fs::path& p) {
    std::vector<std::vector<std::string>> rows;
    std::istringstream in(test::readFile(p));
    for (std::string line; std::getline(in, line);) {
      std::vector<std::string> cells;
      std::stringstream cellStream(line);
      for (std::string c; std::getline(cellStream, c, ',');) cells.push_back(c);
      rows.push_back(cells);
    }
    return rows;
  };
  const auto made = table(dir / "grains.csv"), shipped = table(scene / "grains" / "grains.csv");
  ASSERT_EQ(made.size(), 7u);
  ASSERT_EQ(made.size(), shipped.size());
  EXPECT_EQ(made[0], shipped[0]);
  for (std::size_t i = 1; i < made.size(); ++i) {
    ASSERT_EQ(made[i].size(), 12u);
    EXPECT_EQ(made[i][0], shipped[i][0]);    // label
    EXPECT_EQ(made[i][1], shipped[i][1]);    // voxels
    EXPECT_EQ(made[i][11], shipped[i][11]);  // file
    for (const int c : {2, 4, 5, 6}) {
      EXPECT_NEAR(std::stod(made[i][std::size_t(c)]) / std::stod(shipped[i][std::size_t(c)]), 1.0, 1e-6)
          << "row " << i << " column " << c;
    }
    // The level set's volume is the voxel count's to 1 %.
    EXPECT_NEAR(std::stod(made[i][2]) / std::stod(made[i][3]), 1.0, 0.01) << "row " << i;
  }
}
