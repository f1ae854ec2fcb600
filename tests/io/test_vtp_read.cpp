// The VTP and PVD reader (io/VtpRead.h): what io's writer writes reads back
// exactly in both encodings; VTK's own two-stream base64 and UInt32 headers
// read; inconsistent or unsupported files are refused with the file, line and
// element named.

#include "support/Files.h"
#include "lsdem/io/InputError.h"
#include "lsdem/io/Vtk.h"
#include "lsdem/io/VtpRead.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>

namespace fs = std::filesystem;
using namespace lsdem::io;

namespace {

fs::path tempDir() {
  const fs::path dir = lsdem::test::tempPath("lsdem_test_vtp_read");
  fs::create_directories(dir);
  return dir;
}

void writeText(const fs::path& file, const std::string& text) { std::ofstream(file, std::ios::binary) << text; }

std::string readText(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// A piece with every cell kind and every value type the writer knows,
// including values whose decimal form is long (0.1, 1/3, extremes).
VtpPiece samplePiece() {
  VtpPiece p;
  p.points = {0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.1, 1.0 / 3.0, -2.5e-7, 1e300, -1e-300, 7.0};
  const std::int64_t v0[] = {4};
  p.verts.add(v0);
  const std::int64_t l0[] = {0, 1, 2, 0};
  p.lines.add(l0);
  const std::int64_t t0[] = {0, 1, 2}, t1[] = {1, 2, 3, 4};
  p.polys.add(t0);
  p.polys.add(t1);
  p.pointData.push_back({"id", 1, std::vector<std::uint64_t>{0, 1, 2, std::numeric_limits<std::uint64_t>::max(), 5}});
  p.pointData.push_back({"velocity", 3, std::vector<double>{0.1, 0.2, 0.3, -1, -2, -3, 1e-20, 0, 0, 4, 5, 6, 7, 8, 9}});
  p.cellData.push_back({"generation", 1, std::vector<std::int32_t>{0, -1, 2, std::numeric_limits<std::int32_t>::min()}});
  p.cellData.push_back({"parent", 1, std::vector<std::int64_t>{-1, 3, std::numeric_limits<std::int64_t>::max(), 0}});
  return p;
}

void expectSameArrays(const std::vector<VtkArray>& a, const std::vector<VtkArray>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].name, b[k].name);
    EXPECT_EQ(a[k].components, b[k].components);
    EXPECT_EQ(a[k].values.index(), b[k].values.index()) << a[k].name;
    EXPECT_TRUE(a[k].values == b[k].values) << a[k].name;
  }
}

void expectSamePiece(const VtpPiece& a, const VtpPiece& b) {
  EXPECT_EQ(a.points, b.points);
  for (auto cells : {&VtpPiece::verts, &VtpPiece::lines, &VtpPiece::polys}) {
    EXPECT_EQ((a.*cells).connectivity, (b.*cells).connectivity);
    EXPECT_EQ((a.*cells).offsets, (b.*cells).offsets);
  }
  expectSameArrays(a.pointData, b.pointData);
  expectSameArrays(a.cellData, b.cellData);
}

// Base64 of bytes (test-side encoder, to build VTK-style files by hand).
std::string base64(const std::string& bytes) {
  static const char* a = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    const unsigned b0 = (unsigned char)bytes[i];
    const unsigned b1 = i + 1 < bytes.size() ? (unsigned char)bytes[i + 1] : 0;
    const unsigned b2 = i + 2 < bytes.size() ? (unsigned char)bytes[i + 2] : 0;
    const unsigned v = (b0 << 16) | (b1 << 8) | b2;
    out += a[(v >> 18) & 63];
    out += a[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? a[(v >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? a[v & 63] : '=';
  }
  return out;
}

template <class T>
std::string rawBytes(std::initializer_list<T> values) {
  std::string s;
  for (T v : values) s.append(reinterpret_cast<const char*>(&v), sizeof(T));
  return s;
}

// Expects readVtp(file) to throw an InputError whose text holds `needle`.
void expectRefused(const fs::path& file, const std::string& needle) {
  try {
    readVtp(file);
    ADD_FAILURE() << "no error for " << file;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    EXPECT_EQ(e.file(), file.string());
  }
}

}  // namespace

TEST(VtpRead, BinaryRoundTripIsExact) {
  const fs::path f = tempDir() / "binary.vtp";
  const VtpPiece written = samplePiece();
  writeVtp(f, written, VtkEncoding::Binary);
  expectSamePiece(readVtp(f), written);
}

TEST(VtpRead, CompressedAndAppendedRoundTripsAreExact) {
  // A piece larger than one compression block (32 KiB), so several blocks
  // and a partial last one are written and read back.
  VtpPiece written = samplePiece();
  std::vector<double> big(3 * 5000);
  for (std::size_t k = 0; k < big.size(); ++k) big[k] = std::sin(0.001 * double(k)) * 1e3;
  std::vector<double> points;
  for (std::size_t k = 0; k < 5000; ++k) points.insert(points.end(), {big[3 * k], big[3 * k + 1], big[3 * k + 2]});
  written.points = points;
  written.pointData = {VtkArray{"x", 3, big}};
  written.cellData.clear();
  written.verts = {};
  written.lines = {};
  written.polys = {};
  for (VtkEncoding e : {VtkEncoding::Compressed, VtkEncoding::Appended}) {
    const fs::path f = tempDir() / (std::string(encodingName(e)) + ".vtp");
    writeVtp(f, written, e);
    expectSamePiece(readVtp(f), written);
    const std::string text = readText(f);
    EXPECT_NE(text.find("<AppendedData encoding=\"raw\">"), std::string::npos);
    EXPECT_EQ(text.find("compressor=") != std::string::npos, e == VtkEncoding::Compressed);
  }
  // The sample piece (every array kind, cells of every kind) too.
  const fs::path small = tempDir() / "small-compressed.vtp";
  writeVtp(small, samplePiece(), VtkEncoding::Compressed);
  expectSamePiece(readVtp(small), samplePiece());
  // Smooth data compresses: the compressed file is smaller than the raw one.
  EXPECT_LT(fs::file_size(tempDir() / "compressed.vtp"), fs::file_size(tempDir() / "appended.vtp"));
}

TEST(VtpRead, VtkStyleInlineCompressedData) {
  // Inline zlib data as VTK writes it: the compression header and the
  // blocks as two base64 streams; two blocks of 8 bytes, the last partial.
  const std::string values = rawBytes<float>({1.f, 2.f, 3.f, 4.f, 5.f, 6.f});  // 24 bytes
  std::vector<std::string> blocks;
  for (std::size_t first = 0; first < values.size(); first += 16) {
    const std::string raw = values.substr(first, 16);
    uLongf length = compressBound(uLong(raw.size()));
    std::string z(length, '\0');
    ASSERT_EQ(compress(reinterpret_cast<Bytef*>(z.data()), &length, reinterpret_cast<const Bytef*>(raw.data()),
                       uLong(raw.size())),
              Z_OK);
    z.resize(length);
    blocks.push_back(z);
  }
  const std::string header = rawBytes<std::uint32_t>(
      {2u, 16u, 8u, std::uint32_t(blocks[0].size()), std::uint32_t(blocks[1].size())});
  const std::string text =
      "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"0.1\" byte_order=\"LittleEndian\" "
      "compressor=\"vtkZLibDataCompressor\">\n<PolyData>\n<Piece NumberOfPoints=\"2\">\n"
      "<Points><DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"binary\">\n" +
      base64(header) + base64(blocks[0] + blocks[1]) + "\n</DataArray></Points>\n</Piece>\n</PolyData>\n</VTKFile>\n";
  const fs::path f = tempDir() / "inline-zlib.vtp";
  writeText(f, text);
  EXPECT_EQ(readVtp(f).points, (std::vector<double>{1, 2, 3, 4, 5, 6}));
}

TEST(VtpRead, TimeValueRoundTrips) {
  VtpPiece written = samplePiece();
  written.time = 0.1 + 1.0 / 3.0;
  for (VtkEncoding e : {VtkEncoding::Compressed, VtkEncoding::Binary, VtkEncoding::Ascii}) {
    const fs::path f = tempDir() / (std::string("time-") + encodingName(e) + ".vtp");
    writeVtp(f, written, e);
    const VtpPiece read = readVtp(f);
    EXPECT_EQ(read.time, written.time);
    expectSamePiece(read, written);
  }
  EXPECT_FALSE(readVtp(tempDir() / "time-ascii.vtp").points.empty());
  // No time written, none read.
  const fs::path plain = tempDir() / "no-time.vtp";
  writeVtp(plain, samplePiece(), VtkEncoding::Compressed);
  EXPECT_FALSE(readVtp(plain).time.has_value());
}

TEST(VtpRead, AsciiRoundTripIsExact) {
  const fs::path f = tempDir() / "ascii.vtp";
  const VtpPiece written = samplePiece();
  writeVtp(f, written, VtkEncoding::Ascii);
  expectSamePiece(readVtp(f), written);
}

TEST(VtpRead, EmptyPieceReads) {
  const fs::path f = tempDir() / "empty.vtp";
  writeVtp(f, VtpPiece{}, VtkEncoding::Binary);
  const VtpPiece p = readVtp(f);
  EXPECT_EQ(p.pointCount(), 0u);
  EXPECT_EQ(p.cellCount(), 0u);
}

TEST(VtpRead, VtkStyleTwoStreamsUInt32HeaderFloat32AndLeadingZeroOffsets) {
  // The header and the data base64-encoded separately (VTK's writer), a
  // UInt32 header, Float32 points and offsets with a leading 0.
  const std::string points = rawBytes<float>({0.f, 0.f, 0.f, 1.5f, 0.f, 0.f, 0.f, 2.25f, 0.f});
  const std::string conn = rawBytes<std::int32_t>({0, 1, 2});
  const std::string offs = rawBytes<std::int32_t>({0, 3});
  auto stream = [](const std::string& data) { return base64(rawBytes<std::uint32_t>({std::uint32_t(data.size())})) + base64(data); };
  const std::string text =
      "<?xml version=\"1.0\"?>\n<!-- made by hand -->\n"
      "<VTKFile type='PolyData' version='0.1' byte_order='LittleEndian'>\n<PolyData>\n"
      "<Piece NumberOfPoints=\"3\" NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"1\">\n"
      "<PointData></PointData><CellData/>\n"
      "<Points><DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"binary\">" + stream(points) +
      "</DataArray></Points>\n<Polys>\n<DataArray type=\"Int32\" Name=\"connectivity\" format=\"binary\">\n" +
      stream(conn) + "\n</DataArray>\n<DataArray type=\"Int32\" Name=\"offsets\" format=\"binary\">" + stream(offs) +
      "</DataArray>\n</Polys>\n</Piece>\n</PolyData>\n</VTKFile>\n";
  const fs::path f = tempDir() / "vtkstyle.vtp";
  writeText(f, text);
  const VtpPiece p = readVtp(f);
  EXPECT_EQ(p.points, (std::vector<double>{0, 0, 0, 1.5, 0, 0, 0, 2.25, 0}));
  EXPECT_EQ(p.polys.connectivity, (std::vector<std::int64_t>{0, 1, 2}));
  EXPECT_EQ(p.polys.offsets, (std::vector<std::int64_t>{3}));
}

TEST(VtpRead, RefusesBrokenFiles) {
  const fs::path dir = tempDir();
  const fs::path good = dir / "good.vtp";
  writeVtp(good, samplePiece(), VtkEncoding::Ascii);
  const std::string text = readText(good);
  auto variant = [&](const std::string& name, const std::string& from, const std::string& to) {
    std::string t = text;
    const std::size_t at = t.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) t.replace(at, from.size(), to);
    writeText(dir / name, t);
    return dir / name;
  };
  // Truncated: no closing root.
  writeText(dir / "truncated.vtp", text.substr(0, text.size() / 2));
  expectRefused(dir / "truncated.vtp", "ends");
  writeText(dir / "unclosed.vtp", text.substr(0, text.find("</PolyData>")));
  expectRefused(dir / "unclosed.vtp", "ends before </VTKFile>");
  // Wrong type, another compressor.
  expectRefused(variant("grid.vtp", "type=\"PolyData\"", "type=\"ImageData\""), "not PolyData");
  expectRefused(variant("lz4.vtp", "header_type", "compressor=\"vtkLZ4DataCompressor\" header_type"),
                "vtkZLibDataCompressor only");
  // A point count that disagrees with the points.
  expectRefused(variant("count.vtp", "NumberOfPoints=\"5\"", "NumberOfPoints=\"6\""), "declares 6 points");
  // A cell naming a point that does not exist (the vertex cell's index 4 made 9).
  expectRefused(variant("index.vtp", "Name=\"connectivity\" format=\"ascii\">\n          4",
                        "Name=\"connectivity\" format=\"ascii\">\n          9"),
                "names point 9 of 5");
  // A number that is not one.
  expectRefused(variant("nan.vtp", "0.1 ", "zero.one "), "'zero.one' is not a Float64 value");
  // A binary array whose header announces more bytes than follow.
  const fs::path bin = dir / "bin.vtp";
  writeVtp(bin, samplePiece(), VtkEncoding::Binary);
  std::string b = readText(bin);
  const std::size_t at = b.find("format=\"binary\">");
  ASSERT_NE(at, std::string::npos);
  const std::size_t data = b.find_first_not_of(" \n", at + 16);
  b[data + 1] = b[data + 1] == 'B' ? 'C' : 'B';  // changes the byte count
  writeText(dir / "header.vtp", b);
  expectRefused(dir / "header.vtp", "bytes");
  // Compressed files cut short, with a damaged block, an offset past the end.
  const fs::path zipped = dir / "zipped.vtp";
  writeVtp(zipped, samplePiece(), VtkEncoding::Compressed);
  const std::string z = readText(zipped);
  const std::size_t mark = z.find('_', z.find("<AppendedData"));
  ASSERT_NE(mark, std::string::npos);
  writeText(dir / "zcut.vtp", z.substr(0, mark + 40));
  expectRefused(dir / "zcut.vtp", "past the end of the file");
  std::string damaged = z;
  damaged[mark + 1 + 4 * 8 + 2] ^= 0x5a;  // inside the first array's zlib stream
  writeText(dir / "zdamaged.vtp", damaged);
  expectRefused(dir / "zdamaged.vtp", "does not decompress");
  std::string far = z;
  const std::size_t offset = far.find("offset=\"0\"");
  ASSERT_NE(offset, std::string::npos);
  far.replace(offset, 10, "offset=\"99999999\"");
  writeText(dir / "zfar.vtp", far);
  expectRefused(dir / "zfar.vtp", "past the end of the appended data");
  // Missing file.
  expectRefused(dir / "absent.vtp", "cannot open");
}

TEST(VtpRead, ErrorsNameTheLine) {
  const fs::path f = tempDir() / "line.vtp";
  writeText(f,
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" header_type=\"UInt64\">\n<PolyData>\n"
            "<Piece NumberOfPoints=\"1\">\n<Points>\n"
            "<DataArray type=\"Float128\" NumberOfComponents=\"3\" format=\"ascii\">0 0 0</DataArray>\n"
            "</Points></Piece></PolyData></VTKFile>\n");
  try {
    readVtp(f);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 6);
    EXPECT_NE(e.problem().find("Float128"), std::string::npos) << e.what();
  }
}

TEST(VtpRead, PvdReadsWhatPvdSeriesWrites) {
  const fs::path f = tempDir() / "series.pvd";
  fs::remove(f);
  {
    PvdSeries s(f);
    s.add(0.0, "frames/a_000000.vtp");
    s.add(0.1, "frames/a & b_000001.vtp");
    s.add(1.0 / 3.0, "frames/a_000002.vtp");
  }
  const std::string before = readText(f);
  const std::vector<PvdSeries::Entry> e = readPvd(f);
  ASSERT_EQ(e.size(), 3u);
  EXPECT_EQ(e[0].time, 0.0);
  EXPECT_EQ(e[1].time, 0.1);
  EXPECT_EQ(e[2].time, 1.0 / 3.0);
  EXPECT_EQ(e[1].file, "frames/a & b_000001.vtp");
  EXPECT_EQ(readText(f), before);  // only read
  // Not a series.
  const fs::path bad = tempDir() / "bad.pvd";
  writeText(bad, "<VTKFile type=\"PolyData\"></VTKFile>");
  EXPECT_THROW(readPvd(bad), InputError);
}

TEST(VtpRead, FindArrayAndDoubles) {
  const VtpPiece p = samplePiece();
  const VtkArray* gen = findArray(p.cellData, "generation");
  ASSERT_NE(gen, nullptr);
  EXPECT_EQ(arrayAsDoubles(*gen), (std::vector<double>{0, -1, 2, -2147483648.0}));
  EXPECT_EQ(findArray(p.cellData, "nothing"), nullptr);
}

// A parallel index (.pvtp) of two pieces: it declares the pieces' arrays
// with their types, and reads back as the pieces joined; an index that names
// no piece, or a piece that is not there, is refused.
TEST(VtpRead, ParallelIndexReadsAsItsPiecesJoined) {
  const fs::path dir = tempDir();
  const VtpPiece a = samplePiece();
  VtpPiece b = samplePiece();
  for (double& x : b.points) x += 10.0;
  writeVtp(dir / "p_0.vtp", a, VtkEncoding::Compressed);
  writeVtp(dir / "p_1.vtp", b, VtkEncoding::Binary);
  const std::vector<std::string> pieces{"p_0.vtp", "p_1.vtp"};
  writePvtp(dir / "p.pvtp", layoutOf(a), pieces);
  const std::string index = readText(dir / "p.pvtp");
  EXPECT_NE(index.find("type=\"PPolyData\""), std::string::npos);
  EXPECT_NE(index.find("<PDataArray type=\"UInt64\" Name=\"id\" NumberOfComponents=\"1\"/>"), std::string::npos);
  EXPECT_NE(index.find("<PDataArray type=\"Float64\" Name=\"velocity\" NumberOfComponents=\"3\"/>"), std::string::npos);
  EXPECT_NE(index.find("<PDataArray type=\"Int32\" Name=\"generation\" NumberOfComponents=\"1\"/>"), std::string::npos);
  EXPECT_NE(index.find("<Piece Source=\"p_1.vtp\"/>"), std::string::npos);
  const std::vector<VtpPiece> both{a, b};
  expectSamePiece(readVtp(dir / "p.pvtp"), joinPieces(both));
  EXPECT_EQ(readVtp(dir / "p.pvtp").pointCount(), 2 * a.pointCount());

  writePvtp(dir / "none.pvtp", layoutOf(a), {});
  expectRefused(dir / "none.pvtp", "names no piece");
  const std::vector<std::string> missing{"p_0.vtp", "p_7.vtp"};
  writePvtp(dir / "missing.pvtp", layoutOf(a), missing);
  try {
    readVtp(dir / "missing.pvtp");
    ADD_FAILURE() << "no error for a missing piece";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("p_7.vtp"), std::string::npos) << e.what();
  }
}
