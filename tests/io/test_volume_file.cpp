// Labelled volumes: each reader gives back what was written (NRRD raw and
// gzip, multi-page TIFF, a folder and a pattern of TIFF slices, headerless
// raw), and every broken file ends in an InputError that names the file and
// says what is wrong.

#include "support/Files.h"

#include "lsdem/io/InputError.h"
#include "lsdem/io/VolumeFile.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace fs = std::filesystem;
using namespace lsdem;
using geometry::Index;
using geometry::LabelVolume;
using geometry::Vec;

namespace {

fs::path tempDir(const std::string& name) {
  const fs::path dir = lsdem::test::tempPath("lsdem_test_volume_file_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// A 7 x 5 x 4 volume whose labels run up to `largest` (so the type's width matters).
LabelVolume sample(std::uint32_t largest) {
  LabelVolume v;
  v.dims = Index<3>(7, 5, 4);
  v.spacing = Vec<3>(0.5, 0.25, 1.5);
  v.origin = Vec<3>(-1.0, 2.0, 0.125);
  v.labels.resize(v.voxelCount());
  for (std::size_t i = 0; i < v.labels.size(); ++i) v.labels[i] = std::uint32_t((i * 2654435761u) % (largest + 1u));
  v.labels[3] = largest;
  return v;
}

void expectSameLabels(const LabelVolume& a, const LabelVolume& b) {
  EXPECT_EQ(a.dims.matrix(), b.dims.matrix());
  EXPECT_EQ(a.labels, b.labels);
}

// The message of the InputError `f` throws ("" and a failure when none).
template <class F>
std::string errorOf(F&& f) {
  try {
    f();
  } catch (const io::InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InputError";
  return "";
}

void writeText(const fs::path& p, const std::string& text) {
  std::ofstream f(p, std::ios::binary);
  f << text;
}

}  // namespace

TEST(VolumeFile, NrrdRoundTripsRawAndGzip) {
  const fs::path dir = tempDir("nrrd");
  const struct {
    io::VoxelType type;
    std::uint32_t largest;
  } cases[] = {{io::VoxelType::UInt8, 255u},
               {io::VoxelType::UInt16, 65535u},
               {io::VoxelType::UInt32, 4000000000u},
               {io::VoxelType::Int16, 32767u}};
  for (const auto& c : cases) {
    for (const bool gzip : {false, true}) {
      const LabelVolume v = sample(c.largest);
      const fs::path p = dir / ("v" + std::to_string(c.largest) + (gzip ? "gz" : "") + ".nrrd");
      io::writeNrrd(p.string(), v, c.type, gzip);
      const io::VolumeRead r = io::readLabelVolume(p.string());
      expectSameLabels(r.volume, v);
      EXPECT_EQ(r.format, "nrrd");
      EXPECT_TRUE(r.hasSpacing);
      EXPECT_TRUE(r.hasOrigin);
      EXPECT_EQ(r.volume.spacing, v.spacing);
      EXPECT_EQ(r.volume.origin, v.origin);
    }
  }
  // gzip at the smallest size of the three (the sample is noisy; a label image compresses).
  LabelVolume flat = sample(3);
  std::fill(flat.labels.begin(), flat.labels.end(), 2u);
  io::writeNrrd((dir / "flat.nrrd").string(), flat, io::VoxelType::UInt16, true);
  EXPECT_LT(fs::file_size(dir / "flat.nrrd"), 400u);
  expectSameLabels(io::readLabelVolume((dir / "flat.nrrd").string()).volume, flat);
}

// A detached header (.nhdr) with "spacings", big-endian 16-bit data and a byte skip.
TEST(VolumeFile, NrrdDetachedHeaderBigEndian) {
  const fs::path dir = tempDir("nhdr");
  writeText(dir / "v.nhdr",
            "NRRD0004\n# a comment\ntype: unsigned short\ndimension: 3\nsizes: 2 2 1\nspacings: 0.1 0.2 0.3\n"
            "endian: big\nencoding: raw\nbyte skip: 3\ndata file: v.raw\n");
  writeText(dir / "v.raw", std::string("abc") + std::string("\x00\x01\x01\x00\x00\x00\xff\xff", 8));
  const io::VolumeRead r = io::readLabelVolume((dir / "v.nhdr").string());
  ASSERT_EQ(r.volume.labels.size(), 4u);
  EXPECT_EQ(r.volume.labels[0], 1u);
  EXPECT_EQ(r.volume.labels[1], 256u);
  EXPECT_EQ(r.volume.labels[2], 0u);
  EXPECT_EQ(r.volume.labels[3], 65535u);
  EXPECT_DOUBLE_EQ(r.volume.spacing[2], 0.3);
  EXPECT_FALSE(r.hasOrigin);
  EXPECT_EQ(r.units, "");
  // "space units" are read (one unit for all axes).
  writeText(dir / "mm.nrrd",
            "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 1 1 1\nspace units: \"mm\" \"mm\" \"mm\"\n"
            "encoding: raw\n\n\1");
  EXPECT_EQ(io::readLabelVolume((dir / "mm.nrrd").string()).units, "mm");
  writeText(dir / "mixed.nrrd",
            "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 1 1 1\nspace units: \"mm\" \"mm\" \"m\"\n");
  try {
    io::readLabelVolume((dir / "mixed.nrrd").string());
    ADD_FAILURE() << "mixed units read";
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("mixed.nrrd:5: space units: axes in different units are not supported"),
              std::string::npos)
        << e.what();
  }
}

TEST(VolumeFile, TiffMultiPageRoundTrips) {
  const fs::path dir = tempDir("tiff");
  for (const auto type : {io::VoxelType::UInt8, io::VoxelType::UInt16, io::VoxelType::UInt32}) {
    for (const bool compress : {false, true}) {
      const LabelVolume v = sample(type == io::VoxelType::UInt8 ? 200u : 60000u);
      const fs::path p = dir / ("v" + std::to_string(int(type)) + (compress ? "c" : "") + ".tif");
      io::writeTiff(p.string(), v, type, compress);
      const io::VolumeRead r = io::readLabelVolume(p.string());
      expectSameLabels(r.volume, v);
      EXPECT_EQ(r.format, "tiff");
      EXPECT_FALSE(r.hasSpacing);
    }
  }
}

// Slices named without zero padding come in natural order (slice_2 before slice_10).
TEST(VolumeFile, TiffSliceFolderAndPattern) {
  const fs::path dir = tempDir("slices");
  LabelVolume v = sample(1000);
  v.dims[2] = 12;
  v.labels.resize(v.voxelCount());
  for (std::size_t i = 0; i < v.labels.size(); ++i) v.labels[i] = std::uint32_t(i % 997);
  const std::size_t slice = std::size_t(v.dims[0]) * std::size_t(v.dims[1]);
  for (int z = 0; z < v.dims[2]; ++z) {
    LabelVolume s = v;
    s.dims[2] = 1;
    s.labels.assign(v.labels.begin() + std::ptrdiff_t(z * slice), v.labels.begin() + std::ptrdiff_t((z + 1) * slice));
    io::writeTiff((dir / ("slice_" + std::to_string(z) + ".tif")).string(), s, io::VoxelType::UInt16, z % 2 == 0);
  }
  writeText(dir / "notes.txt", "not a slice");
  const io::VolumeRead folder = io::readLabelVolume(dir.string());
  expectSameLabels(folder.volume, v);
  EXPECT_EQ(folder.files, 12);
  EXPECT_EQ(folder.format, "tiff slices");
  const io::VolumeRead pattern = io::readLabelVolume((dir / "slice_*.tif").string());
  expectSameLabels(pattern.volume, v);
  // A slice of another size is named.
  LabelVolume odd = sample(10);
  odd.dims = Index<3>(3, 3, 1);
  odd.labels.assign(9, 1u);
  io::writeTiff((dir / "slice_12.tif").string(), odd, io::VoxelType::UInt16, false);
  const std::string e = errorOf([&] { io::readLabelVolume(dir.string()); });
  EXPECT_NE(e.find("slice_12.tif: slice is 3 x 3 pixels, the first (slice_0.tif) is 7 x 5"), std::string::npos) << e;
}

TEST(VolumeFile, RawWithLayout) {
  const fs::path dir = tempDir("raw");
  writeText(dir / "v.raw", std::string("HDR!") + std::string("\x00\x02\x00\x03\x01\x00\x00\x00", 8));
  io::VolumeReadOptions o;
  io::RawLayout layout;
  layout.dims = Index<3>(1, 2, 2);
  layout.type = io::VoxelType::UInt16;
  layout.bigEndian = true;
  layout.headerBytes = 4;
  o.raw = layout;
  const io::VolumeRead r = io::readLabelVolume((dir / "v.raw").string(), o);
  ASSERT_EQ(r.volume.labels.size(), 4u);
  EXPECT_EQ(r.volume.labels[0], 2u);
  EXPECT_EQ(r.volume.labels[1], 3u);
  EXPECT_EQ(r.volume.labels[2], 256u);
  EXPECT_EQ(r.volume.labels[3], 0u);
  // One voxel more than the file holds.
  o.raw->dims = Index<3>(1, 2, 3);
  const std::string e = errorOf([&] { io::readLabelVolume((dir / "v.raw").string(), o); });
  EXPECT_NE(e.find("v.raw: truncated: holds 12 bytes, 4 header bytes and 1 x 2 x 3 voxels of 2 bytes give 16"),
            std::string::npos)
      << e;
}

TEST(VolumeFile, BadFilesNameTheFileAndTheProblem) {
  const fs::path dir = tempDir("bad");
  const LabelVolume v = sample(200);
  const std::string header = "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 7 5 4\nencoding: raw\n\n";
  const auto check = [&](const std::string& name, const std::string& content, const std::string& expected) {
    writeText(dir / name, content);
    const std::string e = errorOf([&] { io::readLabelVolume((dir / name).string()); });
    EXPECT_NE(e.find((dir / name).string() + expected), std::string::npos) << e;
  };
  check("short.nrrd", header + std::string(139, '\1'),
        ": truncated: holds 139 bytes of data, the header's sizes 7 x 5 x 4 of uint8 give 140");
  check("long.nrrd", header + std::string(141, '\1'), ": inconsistent: holds 141 bytes of data");
  check("float.nrrd", "NRRD0004\ntype: float\ndimension: 3\n", ":2: type: unsupported type 'float'");
  check("dim2.nrrd", "NRRD0004\ntype: uint8\ndimension: 2\n", ":3: dimension: must be 3");
  check("noendian.nrrd", "NRRD0004\ntype: uint16\ndimension: 3\nsizes: 1 1 1\nencoding: raw\n\n\1\1",
        ": endian: missing");
  check("notnrrd.nrrd", "P5 1 1 255\n", ":1: not a NRRD file");
  check("rotated.nrrd",
        "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 1 1 1\nspace directions: (1,1,0) (0,1,0) (0,0,1)\nencoding: "
        "raw\n\n\1",
        ":5: space directions: axes are not along x, y, z");
  check("negative.nrrd", "NRRD0004\ntype: int8\ndimension: 3\nsizes: 2 1 1\nencoding: raw\n\n\1\xfe",
        ": voxel (1, 0, 0) holds the negative label -2");
  check("unknown.vol", "hello", ": unknown volume format");
  // A field twice (its last was read), sizes past the range (said to be "not positive").
  check("twice.nrrd", "NRRD0004\ntype: uint8\ndimension: 3\ntype: uint16\n", ":4: type: given twice (first on line 2)");
  check("huge.nrrd", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4000000000 1 1\nencoding: raw\n\n",
        ":4: sizes: must be whole numbers from 1 to 1e9 (voxels per axis), got '4e+09'");
  // gzip: cut short, and corrupt.
  io::writeNrrd((dir / "gz.nrrd").string(), v, io::VoxelType::UInt8, true);
  std::string gz = lsdem::test::readFile(dir / "gz.nrrd");
  check("gzcut.nrrd", gz.substr(0, gz.size() - 30), ": truncated");
  gz[gz.size() - 40] = char(gz[gz.size() - 40] ^ 0x55);
  check("gzbad.nrrd", gz, ": gzip data is corrupt");
  // TIFF: cut short.
  io::writeTiff((dir / "t.tif").string(), v, io::VoxelType::UInt8, false);
  const std::string tif = lsdem::test::readFile(dir / "t.tif");
  check("tcut.tif", tif.substr(0, 60), "");
  check("tjunk.tif", std::string("II*\0garbage", 11), ": cannot open as TIFF");
  // Over the memory cap: refused before allocating.
  writeText(dir / "huge.nrrd",
            "NRRD0004\ntype: uint32\ndimension: 3\nsizes: 4000 4000 4000\nendian: little\nencoding: raw\n\n");
  const std::string e = errorOf([&] { io::readLabelVolume((dir / "huge.nrrd").string()); });
  EXPECT_NE(e.find("huge.nrrd: volume of 4000 x 4000 x 4000 voxels needs 488281 MB to read, over the cap of 4096 MB"),
            std::string::npos)
      << e;
  EXPECT_NE(errorOf([&] { io::readLabelVolume((dir / "missing.nrrd").string()); }).find("no such file"),
            std::string::npos);
}
