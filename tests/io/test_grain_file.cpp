// Grain files: full text and binary round trips bit for bit (2D and 3D, a
// random grain and a sphere), several grains in one stream, the minimal text
// form rebuilt from a hand-made grid, shape pools from folders, and one test
// per kind of bad input checking file, line, key and message.

#include "support/Files.h"
#include "lsdem/io/GrainFile.h"

#include "lsdem/geometry/Primitives.h"
#include "lsdem/geometry/ShapeDef.h"
#include "lsdem/io/InputError.h"
#include "support/Shapes.h"

#include <gtest/gtest.h>

#include <zlib.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <sstream>
#include <string>

namespace fs = std::filesystem;
using namespace lsdem;
using geometry::Shape;
using geometry::Vec;

namespace {

constexpr double kPi = 3.14159265358979323846;

template <int D>
std::shared_ptr<const Shape<D>> randomGrain(std::uint64_t seed) {
  geometry::ShapeDef<D> def;
  def.kind = geometry::ShapeKind::RandomGrain;
  def.grain.equivalentDiameter = 0.002;
  def.grain.elongation = 1.4;
  def.grain.roughness = 0.12;
  def.grain.seed = seed;
  def.cellsAcross = D == 2 ? 30 : 14;
  def.options.nodesPerCell = 1.5;
  def.options.massMethod = D == 2 ? geometry::MassMethod::Paper : geometry::MassMethod::Extrapolated;
  return geometry::buildShape(def);
}

// Bitwise equality of doubles (tells -0 from 0, unlike ==).
void expectSame(double a, double b, const std::string& what) {
  EXPECT_EQ(std::bit_cast<std::uint64_t>(a), std::bit_cast<std::uint64_t>(b)) << what << ": " << a << " vs " << b;
}
template <class M>
void expectSameMatrix(const M& a, const M& b, const std::string& what) {
  for (Eigen::Index i = 0; i < a.size(); ++i) expectSame(a.data()[i], b.data()[i], what + "[" + std::to_string(i) + "]");
}

// Every stored part of two shapes equal bit for bit, and a level-set look-up equal.
template <int D>
void expectSameShape(const Shape<D>& a, const Shape<D>& b) {
  const auto pa = a.parts();
  const auto pb = b.parts();
  // Grid.
  ASSERT_TRUE((pa.grid.dims() == pb.grid.dims()).all());
  expectSameMatrix(pa.grid.origin(), pb.grid.origin(), "origin");
  expectSame(pa.grid.spacing(), pb.grid.spacing(), "spacing");
  ASSERT_EQ(pa.grid.size(), pb.grid.size());
  std::size_t differing = 0;
  for (std::size_t n = 0; n < pa.grid.size(); ++n) {
    differing += std::bit_cast<std::uint32_t>(pa.grid[n]) != std::bit_cast<std::uint32_t>(pb.grid[n]);
  }
  EXPECT_EQ(differing, 0u) << "grid values differ";
  // Body frame, nodes.
  expectSameMatrix(pa.bodyToGrid.rotation, pb.bodyToGrid.rotation, "rotation");
  expectSameMatrix(pa.bodyToGrid.translation, pb.bodyToGrid.translation, "translation");
  ASSERT_EQ(pa.nodes.size(), pb.nodes.size());
  for (std::size_t i = 0; i < pa.nodes.size(); ++i) {
    expectSameMatrix(pa.nodes.positions[i], pb.nodes.positions[i], "node");
    expectSame(pa.nodes.weights[i], pb.nodes.weights[i], "weight");
  }
  // Mass properties, descriptors, bounding radius, options.
  expectSame(pa.mass.volume, pb.mass.volume, "volume");
  expectSameMatrix(pa.mass.centroid, pb.mass.centroid, "centroid");
  expectSameMatrix(pa.mass.secondMoment, pb.mass.secondMoment, "second moment");
  expectSame(pa.descriptors.volume, pb.descriptors.volume, "descriptor volume");
  expectSame(pa.descriptors.surfaceArea, pb.descriptors.surfaceArea, "surface area");
  expectSame(pa.descriptors.circularity, pb.descriptors.circularity, "circularity");
  expectSame(pa.descriptors.aspectRatio, pb.descriptors.aspectRatio, "aspect ratio");
  expectSameMatrix(pa.descriptors.bestFitSemiAxes, pb.descriptors.bestFitSemiAxes, "semi-axes");
  expectSame(pa.descriptors.equivalentDiameter, pb.descriptors.equivalentDiameter, "equivalent diameter");
  expectSame(pa.descriptors.sieveSize, pb.descriptors.sieveSize, "sieve size");
  expectSame(pa.descriptors.intermediateAxis, pb.descriptors.intermediateAxis, "intermediate axis");
  expectSame(pa.boundingRadius, pb.boundingRadius, "bounding radius");
  expectSame(pa.options.nodesPerCell, pb.options.nodesPerCell, "nodes per cell");
  expectSame(pa.options.contactSpacing, pb.options.contactSpacing, "contact spacing");
  expectSame(pa.options.nodeStiffnessScale, pb.options.nodeStiffnessScale, "node stiffness scale");
  EXPECT_EQ(pa.options.massMethod, pb.options.massMethod);
  // A look-up with gradient at body-frame points inside, on and outside the grain.
  for (double s : {0.0, 0.3, 0.77, 1.2}) {
    Vec<D> x = Vec<D>::Constant(0.1 * a.boundingRadius());
    x[0] = s * a.boundingRadius();
    Vec<D> ga, gb;
    expectSame(a.valueAndGradient(x, ga), b.valueAndGradient(x, gb), "look-up");
    expectSameMatrix(ga, gb, "gradient");
  }
}

template <int D>
std::shared_ptr<const Shape<D>> roundTrip(const Shape<D>& shape, io::GrainFormat format, std::string* text = nullptr) {
  std::stringstream s;
  io::writeGrain<D>(s, shape, format);
  if (text) *text = s.str();
  return io::readGrain<D>(s, "mem.lsg");
}

fs::path tempDir(const std::string& name) {
  const fs::path dir = lsdem::test::tempPath("lsdem_test_grain_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// The InputError a read of `text` as a D-dimensional grain throws.
template <int D>
io::InputError readError(const std::string& text) {
  std::istringstream in(text);
  try {
    io::readGrain<D>(in, "bad.lsg");
  } catch (const io::InputError& e) {
    return e;
  }
  ADD_FAILURE() << "no InputError for\n" << text.substr(0, 400);
  return io::InputError("", 0, "", "");
}

void expectError(const io::InputError& e, int line, const std::string& key, const std::string& words) {
  EXPECT_EQ(e.file(), "bad.lsg");
  EXPECT_EQ(e.line(), line) << e.what();
  EXPECT_EQ(e.key(), key) << e.what();
  EXPECT_NE(e.problem().find(words), std::string::npos) << e.what();
}

// A hand-made minimal 2D grain: the signed distance of a circle of radius r
// about c on an n x n grid of spacing h with origin o.
std::string minimalCircle(double r, int n, double h, const std::string& extra = "") {
  std::ostringstream s;
  const double o = -0.5 * h * (n - 1);
  s << "# hand-made circle\ndimension 2\ndims " << n << ' ' << n << "\norigin " << o << ' ' << o << "\nspacing " << h
    << "\nvalues\n";
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) s << std::hypot(o + i * h - 0.01 * r, o + j * h) - r << (i + 1 < n ? " " : "\n");
  }
  s << extra;
  return s.str();
}

}  // namespace

TEST(GrainFile, TextAndBinaryRoundTripsAreExact2D) {
  for (const auto& shape : {randomGrain<2>(7), test::sphereShape<2>(0.5, 12)}) {
    for (io::GrainFormat f : {io::GrainFormat::Text, io::GrainFormat::Binary}) {
      SCOPED_TRACE(f == io::GrainFormat::Text ? "text" : "binary");
      expectSameShape<2>(*shape, *roundTrip<2>(*shape, f));
    }
  }
}

TEST(GrainFile, TextAndBinaryRoundTripsAreExact3D) {
  for (const auto& shape : {randomGrain<3>(11), test::sphereShape<3>(0.25, 10)}) {
    for (io::GrainFormat f : {io::GrainFormat::Text, io::GrainFormat::Binary}) {
      SCOPED_TRACE(f == io::GrainFormat::Text ? "text" : "binary");
      expectSameShape<3>(*shape, *roundTrip<3>(*shape, f));
    }
  }
}

// A re-gridded fragment's contact options (contact spacing, per-node
// stiffness scale) survive both forms; a text grain can set them by hand.
TEST(GrainFile, ContactOptionsRoundTrip) {
  geometry::ShapeOptions options;
  options.contactSpacing = 0.07;
  options.nodeStiffnessScale = 0.37;
  const auto shape = geometry::Shape<2>::fromGrid(geometry::sphereGrid<2>(0.5, 0.05), options);
  for (io::GrainFormat f : {io::GrainFormat::Text, io::GrainFormat::Binary}) {
    const auto back = roundTrip<2>(*shape, f);
    EXPECT_EQ(back->nodeStiffnessScale(), 0.37);
    EXPECT_EQ(back->contactSpacing(), 0.07);
  }
  const auto minimal = [](const std::string& extra) {
    std::istringstream in(minimalCircle(0.3, 16, 0.05, extra));
    return io::readGrain<2>(in, "bad.lsg");
  };
  EXPECT_EQ(minimal("")->nodeStiffnessScale(), 1.0);
  EXPECT_EQ(minimal("node_stiffness_scale 0.5\n")->nodeStiffnessScale(), 0.5);
  expectError(readError<2>(minimalCircle(0.3, 16, 0.05, "node_stiffness_scale -1\n")), 23, "node_stiffness_scale",
              "must be positive");
}

TEST(GrainFile, TextFormHasTheDocumentedKeysAndBinaryTheMagic) {
  const auto shape = test::sphereShape<3>(0.25, 8);
  std::string text, binary;
  roundTrip<3>(*shape, io::GrainFormat::Text, &text);
  roundTrip<3>(*shape, io::GrainFormat::Binary, &binary);
  for (const char* key : {"\nlsdem_grain 1\n", "\ndimension 3\n", "\ndims ", "\norigin ", "\nspacing ", "\nvalues ",
                          "\nbody_nodes ", "\nbody_to_grid_rotation ", "\nmass_method extrapolated\n", "\nend\n"}) {
    EXPECT_NE(text.find(key), std::string::npos) << key;
  }
  ASSERT_GE(binary.size(), 16u);
  EXPECT_EQ(binary.substr(0, 8), std::string("\x89LSDEMG\n", 8));
  // Header (16 bytes) + dims + origin + spacing + count + float values ... : at least the values' bytes.
  EXPECT_GT(binary.size(), shape->grid().size() * 4 + shape->nodes().size() * 4 * 8);
  // The binary form is smaller than the text.
  EXPECT_LT(binary.size(), text.size());
}

TEST(GrainFile, SeveralGrainsFollowEachOtherInOneStream) {
  const auto a = randomGrain<2>(3);
  const auto b = test::sphereShape<2>(0.4, 10);
  for (io::GrainFormat f : {io::GrainFormat::Text, io::GrainFormat::Binary}) {
    std::stringstream s;
    io::writeGrain<2>(s, *a, f);
    io::writeGrain<2>(s, *b, f);
    const auto ra = io::readGrain<2>(s, "stream");
    const auto rb = io::readGrain<2>(s, "stream");
    expectSameShape<2>(*a, *ra);
    expectSameShape<2>(*b, *rb);
  }
}

TEST(GrainFile, FilesAreWrittenAtomicallyAndTellTheirDimension) {
  const fs::path dir = tempDir("files");
  const auto s2 = test::sphereShape<2>(0.5, 10);
  const auto s3 = test::sphereShape<3>(0.5, 8);
  io::writeGrainFile<2>((dir / "c.lsg").string(), *s2, io::GrainFormat::Text);
  io::writeGrainFile<3>((dir / "s.lsg").string(), *s3, io::GrainFormat::Binary);
  EXPECT_FALSE(fs::exists(dir / "c.lsg.tmp"));
  EXPECT_EQ(io::grainFileDimension((dir / "c.lsg").string()), 2);
  EXPECT_EQ(io::grainFileDimension((dir / "s.lsg").string()), 3);
  expectSameShape<2>(*s2, *io::readGrainFile<2>((dir / "c.lsg").string()));
  expectSameShape<3>(*s3, *io::readGrainFile<3>((dir / "s.lsg").string()));
  // Overwriting replaces the file.
  io::writeGrainFile<2>((dir / "c.lsg").string(), *randomGrain<2>(5), io::GrainFormat::Binary);
  EXPECT_EQ(io::grainFileDimension((dir / "c.lsg").string()), 2);
  EXPECT_NE(io::readGrainFile<2>((dir / "c.lsg").string())->volume(), s2->volume());
  // A folder that cannot be written into.
  EXPECT_THROW(io::writeGrainFile<2>((dir / "no/such/dir/x.lsg").string(), *s2, io::GrainFormat::Text), std::runtime_error);
}

TEST(GrainFile, MinimalFormRebuildsTheShape) {
  // Grid only: a circle of radius 0.01 m, 40 x 40 nodes of 0.7 mm.
  const double r = 0.01;
  std::istringstream in0(minimalCircle(r, 40, 0.0007));
  const auto grid = io::readGrain<2>(in0, "circle.lsg");
  EXPECT_NEAR(grid->volume(), kPi * r * r, 0.005 * kPi * r * r);
  EXPECT_NEAR(grid->descriptors().surfaceArea, 2 * kPi * r, 0.01 * 2 * kPi * r);
  EXPECT_NEAR(grid->bodyToGrid().translation[0], 0.01 * r, 0.02 * r);  // centroid where the circle was put
  EXPECT_NEAR(grid->descriptors().circularity, 1.0, 0.02);

  // With 64 nodes in the grid frame and no weights: weights share the perimeter equally.
  std::string nodes = "nodes 64\n";
  for (int i = 0; i < 64; ++i) {
    const double t = 2 * kPi * i / 64;
    nodes += std::to_string(0.01 * r + r * std::cos(t)) + " " + std::to_string(r * std::sin(t)) + "\n";
  }
  std::istringstream in(minimalCircle(r, 40, 0.0007, nodes + "nodes_per_cell 3\nmass_method paper\n"));
  const auto withNodes = io::readGrain<2>(in, "circle.lsg");
  ASSERT_EQ(withNodes->nodes().size(), 64u);
  EXPECT_NEAR(withNodes->nodes().totalWeight(), 2 * kPi * r, 0.01 * 2 * kPi * r);
  EXPECT_DOUBLE_EQ(withNodes->nodes().weights[0], withNodes->nodes().weights[63]);
  EXPECT_EQ(withNodes->options().massMethod, geometry::MassMethod::Paper);
  EXPECT_EQ(withNodes->options().nodesPerCell, 3.0);
  // Nodes are moved to the body frame: at distance r from the centroid.
  for (const Vec<2>& x : withNodes->nodes().positions) EXPECT_NEAR(x.norm(), r, 0.01 * r);
  EXPECT_NEAR(withNodes->volume(), kPi * r * r, 0.01 * kPi * r * r);

  // With weights given, they are kept.
  std::string weighted = "nodes 4\n";
  for (int i = 0; i < 4; ++i) {
    const double t = 2 * kPi * i / 4;
    weighted += std::to_string(r * std::cos(t)) + " " + std::to_string(r * std::sin(t)) + " 0.0125\n";
  }
  std::istringstream in2(minimalCircle(r, 40, 0.0007, weighted + "end\n"));
  const auto w = io::readGrain<2>(in2, "circle.lsg");
  EXPECT_DOUBLE_EQ(w->nodes().totalWeight(), 0.05);
}

TEST(GrainFile, ShapePoolFromAFolderInNameOrder) {
  const fs::path dir = tempDir("pool");
  const auto big = test::sphereShape<3>(0.5, 8);
  const auto small = test::sphereShape<3>(0.25, 8);
  io::writeGrainFile<3>((dir / "b_small.lsg").string(), *small, io::GrainFormat::Text);
  io::writeGrainFile<3>((dir / "a_big.lsg").string(), *big, io::GrainFormat::Binary);
  std::ofstream(dir / "notes.txt") << "not a grain\n";
  fs::create_directories(dir / "sub.lsg");  // a folder named like a grain is skipped
  const auto pool = io::readGrainFolder<3>(dir.string());
  ASSERT_EQ(pool.size(), 2u);
  expectSame(pool[0]->volume(), big->volume(), "first = a_big");
  expectSame(pool[1]->volume(), small->volume(), "second = b_small");

  // Errors: not a folder, a folder without grains, a grain of the wrong dimension.
  try {
    io::readGrainFolder<3>((dir / "missing").string());
    ADD_FAILURE();
  } catch (const io::InputError& e) {
    EXPECT_NE(e.problem().find("is not a folder"), std::string::npos);
  }
  const fs::path empty = tempDir("pool_empty");
  try {
    io::readGrainFolder<3>(empty.string());
    ADD_FAILURE();
  } catch (const io::InputError& e) {
    EXPECT_EQ(e.file(), empty.string());
    EXPECT_NE(e.problem().find("no *.lsg"), std::string::npos);
  }
  try {
    io::readGrainFolder<2>(dir.string());
    ADD_FAILURE();
  } catch (const io::InputError& e) {
    EXPECT_EQ(e.file(), (dir / "a_big.lsg").string());
    EXPECT_EQ(e.key(), "dimension");
  }
}

TEST(GrainFile, BadTextInputNamesFileLineAndKey) {
  const auto sphere = test::sphereShape<2>(0.5, 6);
  std::string full;
  roundTrip<2>(*sphere, io::GrainFormat::Text, &full);
  const std::string circle = minimalCircle(0.01, 10, 0.003);  // key `values` on line 6, rows on lines 7-16

  // Unknown dimension and the other dimension.
  expectError(readError<2>("dimension 4\n"), 1, "dimension", "must be 2 or 3, got 4");
  expectError(readError<3>(circle), 2, "dimension", "holds a 2D grain, a 3D one is needed");
  // Unknown key, duplicated key, a key before the dimension.
  expectError(readError<2>("dimension 2\ncolour red\n"), 2, "colour", "unknown key");
  expectError(readError<2>("dimension 2\nspacing 1\nspacing 2\n"), 3, "spacing", "appears twice (first on line 2)");
  expectError(readError<2>("spacing 1\n"), 1, "spacing", "'dimension' must come first");
  // Wrong counts on a key line and in the values block.
  expectError(readError<2>("dimension 2\norigin 1 2 3\n"), 2, "origin", "expected 2 values, got 3");
  expectError(readError<2>("dimension 2\ndims 10 1\n"), 2, "dims", "each must be >= 2, got 1");
  expectError(readError<2>("dimension 2\ndims 10 10\nvalues 99\n"), 3, "values", "count 99 does not match dims 10 x 10");
  {
    // A values block one row short, followed by a key.
    std::string shortRows = circle;
    const std::size_t row = shortRows.find("\n", shortRows.find("values\n") + 7);
    shortRows.erase(shortRows.find("values\n") + 7, row - shortRows.find("values\n") - 6);
    expectError(readError<2>(shortRows + "nodes_per_cell 2\n"), 16, "values", "expected 100 values (dims 10 x 10), found 90");
    // The same file ending there: truncated.
    expectError(readError<2>(shortRows), 15, "values", "ends after 90 of 100 values (truncated)");
  }
  {
    // One value too many on the last row.
    std::string extra = circle;
    extra.insert(extra.size() - 1, " 0.5");
    expectError(readError<2>(extra), 16, "values", "more values than dims 10 x 10 hold (100)");
  }
  {
    // NaN and a non-number among the values (line 8 holds the second row).
    std::string nan = circle;
    const std::size_t second = nan.find('\n', nan.find("values\n") + 7) + 1;
    nan.replace(second, nan.find(' ', second) - second, "nan");
    expectError(readError<2>(nan), 8, "values", "value 10 ('nan') is not finite");
    std::string word = circle;
    word.replace(second, word.find(' ', second) - second, "1.2.3");
    expectError(readError<2>(word), 8, "values", "'1.2.3' is not a number");
  }
  // NaN in a scalar, a non-positive spacing, a missing key.
  expectError(readError<2>("dimension 2\nspacing nan\n"), 2, "spacing", "'nan' is not finite");
  {
    std::string zero = circle;
    zero.replace(zero.find("spacing 0.003"), 13, "spacing -1");
    expectError(readError<2>(zero), 5, "spacing", "must be positive, got -1");
    std::string noOrigin = circle;
    noOrigin.erase(noOrigin.find("origin"), noOrigin.find('\n', noOrigin.find("origin")) - noOrigin.find("origin") + 1);
    expectError(readError<2>(noOrigin), 15, "origin", "missing");
  }
  // A grid with no inside.
  expectError(readError<2>("dimension 2\ndims 2 2\norigin 0 0\nspacing 1\nvalues\n1 1\n1 1\n"), 5, "values", "no value is negative");
  // Truncated full form: cut inside the node block.
  {
    const std::string cut = full.substr(0, full.find("\nend") - 1);
    const io::InputError e = readError<2>(cut.substr(0, cut.rfind('\n')));
    EXPECT_EQ(e.key(), "body_nodes");
    EXPECT_NE(e.problem().find("nodes (truncated)"), std::string::npos) << e.what();
    EXPECT_GT(e.line(), 20);
  }
  // A full form with a part removed.
  {
    std::string noVolume = full;
    noVolume.erase(noVolume.find("\nvolume ") + 1, noVolume.find('\n', noVolume.find("\nvolume ") + 1) - noVolume.find("\nvolume "));
    const io::InputError e = readError<2>(noVolume);
    EXPECT_EQ(e.key(), "volume");
    EXPECT_NE(e.problem().find("missing"), std::string::npos);
  }
  // Node lines with the wrong number of numbers.
  expectError(readError<2>(circle + "nodes 2\n0.01 0\n0 0.01 1 1\n"), 19, "nodes", "node 1: expected 2 or 3 numbers");
  // Empty input.
  expectError(readError<2>(""), 0, "", "holds no grain");
  expectError(readError<2>("# only a comment\n\n"), 2, "", "holds no grain");
}

TEST(GrainFile, BadBinaryInputNamesFileAndKey) {
  const auto sphere = test::sphereShape<3>(0.5, 8);
  std::string bin;
  roundTrip<3>(*sphere, io::GrainFormat::Binary, &bin);
  // Wrong magic after the first byte.
  std::string magic = bin;
  magic[3] = 'X';
  expectError(readError<3>(magic), 0, "magic", "bad magic");
  // Unknown version and dimension.
  std::string version = bin;
  version[8] = 9;
  expectError(readError<3>(version), 0, "version", "version 9 is not supported");
  std::string dimension = bin;
  dimension[12] = 5;
  expectError(readError<3>(dimension), 0, "dimension", "must be 2 or 3, got 5");
  expectError(readError<2>(bin), 0, "dimension", "holds a 3D grain, a 2D one is needed");
  // Truncated in the values and at the last field.
  expectError(readError<3>(bin.substr(0, 100)), 0, "values", "truncated");
  expectError(readError<3>(bin.substr(0, bin.size() - 1)), 0, "checksum", "truncated");
  expectError(readError<3>(bin.substr(0, bin.size() - 5)), 0, "node_stiffness_scale", "truncated");
  expectError(readError<3>(bin.substr(0, bin.size() - 13)), 0, "contact_spacing", "truncated");
  // A NaN value in the grid (first value at byte 16 + 12 + 24 + 8 + 8 = 68).
  std::string nan = bin;
  const float q = std::nanf("");
  std::memcpy(nan.data() + 68, &q, 4);
  expectError(readError<3>(nan), 0, "values", "value 0 is not finite");
  // Single-bit flips anywhere after the header: refused by the checksum (or,
  // in a count or size, by the check that reads it), never read as another grain.
  for (int k = 0; k < 20; ++k) {
    std::string flipped = bin;
    const std::size_t at = 16 + (bin.size() - 17) * std::size_t(k) / 19;
    flipped[at] = char(flipped[at] ^ (1 << (k % 8)));
    EXPECT_NE(readError<3>(flipped).problem(), "") << "byte " << at;
  }
  std::string flipped = bin;
  flipped[bin.size() / 2] = char(flipped[bin.size() / 2] ^ 4);  // in the grid values
  expectError(readError<3>(flipped), 0, "checksum", "does not match the contents");
  // A body frame that is not a rotation (5 x identity), with a valid checksum.
  std::string scaled = bin;
  const std::size_t rotation = 68 + 4 * sphere->grid().size();
  for (int i = 0; i < 3; ++i) {
    const double five = 5.0;
    const auto& R = sphere->bodyToGrid().rotation;
    for (int j = 0; j < 3; ++j) {
      const double v = five * R(i, j);
      std::memcpy(scaled.data() + rotation + 8 * std::size_t(3 * i + j), &v, 8);
    }
  }
  const std::uint32_t crc = std::uint32_t(
      crc32(crc32(0L, Z_NULL, 0), reinterpret_cast<const Bytef*>(scaled.data()), uInt(scaled.size() - 4)));
  std::memcpy(scaled.data() + scaled.size() - 4, &crc, 4);
  expectError(readError<3>(scaled), 0, "body_to_grid_rotation", "is not a rotation");
  // A header that claims 2^28 nodes (6.4 GB of positions and weights) in a
  // file of a few kB: refused by the short read of the first megabyte of
  // values (the array grows by chunks as it is read), not by an allocation.
  std::string huge = bin;
  const std::size_t nodeCount = rotation + 8 * 9 + 8 * 3;
  std::uint64_t claimed = 0;
  std::memcpy(&claimed, huge.data() + nodeCount, 8);
  ASSERT_EQ(claimed, sphere->nodes().size());
  claimed = std::uint64_t(1) << 28;
  std::memcpy(huge.data() + nodeCount, &claimed, 8);
  expectError(readError<3>(huge), 0, "body_nodes", "truncated");
  claimed = (std::uint64_t(1) << 28) + 1;
  std::memcpy(huge.data() + nodeCount, &claimed, 8);
  expectError(readError<3>(huge), 0, "body_nodes", "out of range");
  // A missing file.
  try {
    io::readGrainFile<3>("/nonexistent/grain.lsg");
    ADD_FAILURE();
  } catch (const io::InputError& e) {
    EXPECT_EQ(e.file(), "/nonexistent/grain.lsg");
    EXPECT_NE(e.problem().find("cannot open"), std::string::npos);
  }
  EXPECT_THROW(io::grainFileDimension("/nonexistent/grain.lsg"), io::InputError);
}

TEST(GrainFile, ShippedExamplesRead) {
  const std::string dir = std::string(LSDEM_SOURCE_DIR) + "/examples/grains/";
  // The cube made by `lsdem mesh2ls` (10 mm edge): full form, written back identically.
  EXPECT_EQ(io::grainFileDimension(dir + "cube.lsg"), 3);
  const auto cube = io::readGrainFile<3>(dir + "cube.lsg");
  EXPECT_NEAR(cube->volume(), 1e-6, 0.03e-6);
  std::ifstream in(dir + "cube.lsg");
  const std::string original((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::string rewritten;
  roundTrip<3>(*cube, io::GrainFormat::Text, &rewritten);
  EXPECT_EQ(rewritten, original);
  // The hand-made ellipse (3 mm x 2 mm): minimal form with 16 nodes.
  EXPECT_EQ(io::grainFileDimension(dir + "ellipse_minimal.lsg"), 2);
  const auto ellipse = io::readGrainFile<2>(dir + "ellipse_minimal.lsg");
  EXPECT_NEAR(ellipse->volume(), kPi * 0.003 * 0.002, 0.02 * kPi * 0.003 * 0.002);
  EXPECT_EQ(ellipse->nodes().size(), 16u);
  EXPECT_NEAR(ellipse->descriptors().aspectRatio, 2.0 / 3.0, 0.03);
}
