/// @file GrainFile.cpp
/// @brief Grain files: the full and minimal text forms and the binary form
/// (docs/grains.md), and folders of grain files as shape pools.

#include "lsdem/io/GrainFile.h"

#include "lsdem/io/InputError.h"

#include "Checksum.h"
#include "NumberText.h"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <system_error>
#include <type_traits>

namespace lsdem::io {
namespace {

namespace fs = std::filesystem;
using geometry::Grid;
using geometry::Index;
using geometry::Mat;
using geometry::MassMethod;
using geometry::NodeSet;
using geometry::Shape;
using geometry::Vec;

/// Format version written by this code (text key `lsdem_grain`, binary header).
constexpr std::uint32_t kVersion = 1;  // text form (contact_spacing, node_stiffness_scale are optional keys)
// 2 adds options.contactSpacing; 3 a closing CRC-32 of every byte before it;
// 4 options.nodeStiffnessScale before the CRC. Versions 1 to 3 are still read.
constexpr std::uint32_t kBinaryVersion = 4;
/// Binary magic: a non-ASCII first byte (so text and binary are told apart by
/// one byte), the name, and a newline that catches text-mode line-end mangling.
constexpr char kMagic[8] = {'\x89', 'L', 'S', 'D', 'E', 'M', 'G', '\n'};
/// Most grid values / surface nodes a grain may declare (guards against a
/// corrupt count asking for terabytes).
constexpr std::uint64_t kMaxValues = std::uint64_t(1) << 31;
constexpr std::uint64_t kMaxNodes = std::uint64_t(1) << 28;

const char* massMethodName(MassMethod m) { return m == MassMethod::Paper ? "paper" : "extrapolated"; }

template <int D>
std::string dimsText(const Index<D>& dims) {
  std::string s;
  for (int a = 0; a < D; ++a) s += (a ? " x " : "") + std::to_string(dims[a]);
  return s;
}

/// The shortest text that reads back as v.
std::string shortest(double v) { return numberText(v); }

// ============================================================================
// Text form: writing
// ============================================================================

/// Appends numbers in their shortest round-trip form.
class TextOut {
 public:
  void number(double v) { appendNumber(s_, v); }
  void number(float v) { appendNumber(s_, v); }
  void text(std::string_view t) { s_.append(t); }
  /// A line "key n0 n1 ..." of doubles.
  template <class Range>
  void line(std::string_view key, const Range& values) {
    s_.append(key);
    for (double v : values) {
      s_.push_back(' ');
      number(v);
    }
    s_.push_back('\n');
  }
  void line(std::string_view key, double v) { line(key, std::initializer_list<double>{v}); }
  std::string& str() { return s_; }

 private:
  std::string s_;
};

template <int D>
std::vector<double> flat(const Vec<D>& v) {
  return std::vector<double>(v.data(), v.data() + D);
}
/// Row-major entries of a D x D matrix.
template <int D>
std::vector<double> flat(const Mat<D>& m) {
  std::vector<double> r;
  for (int i = 0; i < D; ++i)
    for (int j = 0; j < D; ++j) r.push_back(m(i, j));
  return r;
}

template <int D>
std::string textGrain(const Shape<D>& shape) {
  const typename Shape<D>::Parts p = shape.parts();
  TextOut o;
  // Header and grid geometry.
  o.text("# lsdem grain file, full form (docs/grains.md); numbers round-trip exactly\n");
  o.text("lsdem_grain " + std::to_string(kVersion) + "\n");
  o.text("dimension " + std::to_string(D) + "\n");
  o.text("dims");
  for (int a = 0; a < D; ++a) o.text(" " + std::to_string(p.grid.dims()[a]));
  o.text("\n");
  o.line("origin", flat<D>(p.grid.origin()));
  o.line("spacing", p.grid.spacing());
  // Options the shape was made with.
  o.line("nodes_per_cell", p.options.nodesPerCell);
  o.text(std::string("mass_method ") + massMethodName(p.options.massMethod) + "\n");
  if (p.options.contactSpacing > 0.0) o.line("contact_spacing", p.options.contactSpacing);
  if (p.options.nodeStiffnessScale != 1.0) o.line("node_stiffness_scale", p.options.nodeStiffnessScale);
  // Body frame, mass properties per unit density, descriptors.
  o.line("body_to_grid_rotation", flat<D>(p.bodyToGrid.rotation));
  o.line("body_to_grid_translation", flat<D>(p.bodyToGrid.translation));
  o.line("volume", p.mass.volume);
  o.line("centroid", flat<D>(p.mass.centroid));
  o.line("second_moment", flat<D>(p.mass.secondMoment));
  o.line("bounding_radius", p.boundingRadius);
  o.line("descriptor_volume", p.descriptors.volume);
  o.line("surface_area", p.descriptors.surfaceArea);
  o.line("circularity", p.descriptors.circularity);
  o.line("aspect_ratio", p.descriptors.aspectRatio);
  o.line("best_fit_semi_axes", flat<D>(p.descriptors.bestFitSemiAxes));
  o.line("equivalent_diameter", p.descriptors.equivalentDiameter);
  o.line("sieve_size", p.descriptors.sieveSize);
  o.line("intermediate_axis", p.descriptors.intermediateAxis);
  // Grid values, one x-row per line.
  const std::vector<float>& values = p.grid.values();
  o.text("values " + std::to_string(values.size()) + "\n");
  const std::size_t row = std::size_t(p.grid.dims()[0]);
  for (std::size_t n = 0; n < values.size(); ++n) {
    o.number(values[n]);
    o.text((n + 1) % row == 0 ? "\n" : " ");
  }
  // Surface nodes in the body frame: D coordinates and the weight.
  o.text("body_nodes " + std::to_string(p.nodes.size()) + "\n");
  for (std::size_t i = 0; i < p.nodes.size(); ++i) {
    for (int a = 0; a < D; ++a) {
      o.number(p.nodes.positions[i][a]);
      o.text(" ");
    }
    o.number(p.nodes.weights[i]);
    o.text("\n");
  }
  o.text("end\n");
  return std::move(o.str());
}

// ============================================================================
// Binary form: writing and reading raw little-endian numbers
// ============================================================================

template <class T>
void putRaw(std::string& buf, T v) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &v, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) std::reverse(bytes, bytes + sizeof(T));
  buf.append(bytes, sizeof(T));
}

template <int D>
void putVec(std::string& buf, const Vec<D>& v) {
  for (int a = 0; a < D; ++a) putRaw<double>(buf, v[a]);
}
template <int D>
void putMat(std::string& buf, const Mat<D>& m) {
  for (double v : flat<D>(m)) putRaw<double>(buf, v);
}

template <int D>
std::string binaryGrain(const Shape<D>& shape) {
  const typename Shape<D>::Parts p = shape.parts();
  std::string b;
  b.reserve(p.grid.bytes() + p.nodes.size() * (D + 1) * sizeof(double) + 512);
  // Header.
  b.append(kMagic, sizeof(kMagic));
  putRaw<std::uint32_t>(b, kBinaryVersion);
  putRaw<std::uint32_t>(b, std::uint32_t(D));
  // Grid.
  for (int a = 0; a < D; ++a) putRaw<std::int32_t>(b, p.grid.dims()[a]);
  putVec<D>(b, p.grid.origin());
  putRaw<double>(b, p.grid.spacing());
  putRaw<std::uint64_t>(b, p.grid.size());
  for (float v : p.grid.values()) putRaw<float>(b, v);
  // Body frame and nodes.
  putMat<D>(b, p.bodyToGrid.rotation);
  putVec<D>(b, p.bodyToGrid.translation);
  putRaw<std::uint64_t>(b, p.nodes.size());
  for (const Vec<D>& x : p.nodes.positions) putVec<D>(b, x);
  for (double w : p.nodes.weights) putRaw<double>(b, w);
  // Mass properties, descriptors, bounding radius, options.
  putRaw<double>(b, p.mass.volume);
  putVec<D>(b, p.mass.centroid);
  putMat<D>(b, p.mass.secondMoment);
  putRaw<double>(b, p.descriptors.volume);
  putRaw<double>(b, p.descriptors.surfaceArea);
  putRaw<double>(b, p.descriptors.circularity);
  putRaw<double>(b, p.descriptors.aspectRatio);
  putVec<D>(b, p.descriptors.bestFitSemiAxes);
  putRaw<double>(b, p.descriptors.equivalentDiameter);
  putRaw<double>(b, p.descriptors.sieveSize);
  putRaw<double>(b, p.descriptors.intermediateAxis);
  putRaw<double>(b, p.boundingRadius);
  putRaw<double>(b, p.options.nodesPerCell);
  putRaw<std::uint32_t>(b, p.options.massMethod == MassMethod::Paper ? 0u : 1u);
  putRaw<double>(b, p.options.contactSpacing);
  putRaw<double>(b, p.options.nodeStiffnessScale);
  // Checksum of everything above.
  putRaw<std::uint32_t>(b, crc32Of(b.data(), b.size()));
  return b;
}

/// Reads the binary fields of one grain from a stream, reporting a short read
/// as a truncated file under the field's key.
class BinaryIn {
 public:
  BinaryIn(std::istream& in, const std::string& source) : in_(in), source_(source) {}

  [[noreturn]] void fail(const std::string& key, const std::string& what) const { throw InputError(source_, 0, key, what); }

  void bytes(char* dst, std::size_t n, const std::string& key) {
    in_.read(dst, std::streamsize(n));
    if (std::size_t(in_.gcount()) != n) fail(key, "the file ends early (truncated binary grain)");
    crc_.add(dst, n);
  }
  /// CRC-32 of every byte read so far.
  std::uint32_t crc() const { return crc_.value(); }
  template <class T>
  T raw(const std::string& key) {
    char b[sizeof(T)];
    bytes(b, sizeof(T), key);
    if constexpr (std::endian::native == std::endian::big) std::reverse(b, b + sizeof(T));
    T v;
    std::memcpy(&v, b, sizeof(T));
    return v;
  }
  /// A finite double.
  double real(const std::string& key) {
    const double v = raw<double>(key);
    if (!std::isfinite(v)) fail(key, "is not finite");
    return v;
  }
  template <int D>
  Vec<D> vec(const std::string& key) {
    Vec<D> v;
    for (int a = 0; a < D; ++a) v[a] = real(key);
    return v;
  }
  template <int D>
  Mat<D> mat(const std::string& key) {
    Mat<D> m;
    for (int i = 0; i < D; ++i)
      for (int j = 0; j < D; ++j) m(i, j) = real(key);
    return m;
  }
  /// `count` values of T, read in chunks so a corrupt count fails on the
  /// short read instead of allocating everything first.
  template <class T>
  std::vector<T> array(std::uint64_t count, const std::string& key) {
    std::vector<T> out;
    constexpr std::uint64_t kChunk = 1 << 20;
    while (out.size() < count) {
      const std::size_t n = std::size_t(std::min<std::uint64_t>(kChunk, count - out.size()));
      const std::size_t at = out.size();
      out.resize(at + n);
      for (std::size_t i = 0; i < n; ++i) out[at + i] = raw<T>(key);
    }
    return out;
  }

 private:
  std::istream& in_;
  const std::string& source_;
  Crc32 crc_;
};

/// Reads the binary header after the first byte: magic, version, dimension.
std::uint32_t readBinaryHeader(BinaryIn& b, std::uint32_t* versionOut = nullptr) {
  char magic[sizeof(kMagic)];
  b.bytes(magic, sizeof(magic), "magic");
  if (std::memcmp(magic, kMagic, sizeof(kMagic)) != 0) b.fail("magic", "not an lsdem binary grain (bad magic)");
  const auto version = b.raw<std::uint32_t>("version");
  if (version < 1 || version > kBinaryVersion) {
    b.fail("version", "binary grain version " + std::to_string(version) + " is not supported (this lsdem reads 1 to " +
                          std::to_string(kBinaryVersion) + ")");
  }
  if (versionOut) *versionOut = version;
  const auto dimension = b.raw<std::uint32_t>("dimension");
  if (dimension != 2 && dimension != 3) b.fail("dimension", "must be 2 or 3, got " + std::to_string(dimension));
  return dimension;
}

/// Wraps a failure of Shape's own checks as an input error on the grain.
template <class F>
auto checkedShape(const std::string& source, int line, const std::string& key, F make) {
  try {
    return make();
  } catch (const std::invalid_argument& e) {
    throw InputError(source, line, key, e.what());
  }
}

template <int D>
std::shared_ptr<const Shape<D>> readBinary(std::istream& in, const std::string& source) {
  BinaryIn b(in, source);
  std::uint32_t version = 0;
  const std::uint32_t dimension = readBinaryHeader(b, &version);
  if (int(dimension) != D) {
    b.fail("dimension", "the file holds a " + std::to_string(dimension) + "D grain, a " + std::to_string(D) +
                            "D one is needed");
  }
  // Grid geometry.
  Index<D> dims;
  std::uint64_t expected = 1;
  for (int a = 0; a < D; ++a) {
    dims[a] = b.raw<std::int32_t>("dims");
    if (dims[a] < 2) b.fail("dims", "each must be >= 2, got " + std::to_string(dims[a]));
    expected *= std::uint64_t(dims[a]);
    if (expected > kMaxValues) b.fail("dims", "more than 2^31 grid values");
  }
  const Vec<D> origin = b.vec<D>("origin");
  const double spacing = b.real("spacing");
  if (!(spacing > 0.0)) b.fail("spacing", "must be positive");
  // Grid values.
  const auto count = b.raw<std::uint64_t>("values");
  if (count != expected) {
    b.fail("values", "count " + std::to_string(count) + " does not match dims (" + std::to_string(expected) + ")");
  }
  typename Shape<D>::Parts p;
  p.grid = Grid<D>(dims, origin, spacing);
  p.grid.values() = b.array<float>(count, "values");
  for (std::size_t n = 0; n < p.grid.size(); ++n) {
    if (!std::isfinite(p.grid[n])) b.fail("values", "value " + std::to_string(n) + " is not finite");
  }
  // Body frame and nodes.
  p.bodyToGrid.rotation = b.mat<D>("body_to_grid_rotation");
  p.bodyToGrid.translation = b.vec<D>("body_to_grid_translation");
  const auto nodes = b.raw<std::uint64_t>("body_nodes");
  if (nodes == 0 || nodes > kMaxNodes) b.fail("body_nodes", "node count " + std::to_string(nodes) + " out of range");
  // Read before anything is sized by the count: a false count fails on the short read.
  const std::vector<double> xyz = b.array<double>(nodes * D, "body_nodes");
  p.nodes.positions.resize(std::size_t(nodes));
  for (std::size_t i = 0; i < nodes; ++i) {
    for (int a = 0; a < D; ++a) p.nodes.positions[i][a] = xyz[i * D + a];
  }
  p.nodes.weights = b.array<double>(nodes, "body_nodes");
  // Mass properties, descriptors, bounding radius, options.
  p.mass.volume = b.real("volume");
  p.mass.centroid = b.vec<D>("centroid");
  p.mass.secondMoment = b.mat<D>("second_moment");
  p.descriptors.volume = b.real("descriptor_volume");
  p.descriptors.surfaceArea = b.real("surface_area");
  p.descriptors.circularity = b.real("circularity");
  p.descriptors.aspectRatio = b.real("aspect_ratio");
  p.descriptors.bestFitSemiAxes = b.vec<D>("best_fit_semi_axes");
  p.descriptors.equivalentDiameter = b.real("equivalent_diameter");
  p.descriptors.sieveSize = b.real("sieve_size");
  p.descriptors.intermediateAxis = b.real("intermediate_axis");
  p.boundingRadius = b.real("bounding_radius");
  p.options.nodesPerCell = b.real("nodes_per_cell");
  const auto method = b.raw<std::uint32_t>("mass_method");
  if (method > 1) b.fail("mass_method", "unknown method code " + std::to_string(method));
  p.options.massMethod = method == 0 ? MassMethod::Paper : MassMethod::Extrapolated;
  if (version >= 2) {
    p.options.contactSpacing = b.real("contact_spacing");
    if (!(p.options.contactSpacing >= 0.0)) b.fail("contact_spacing", "must be >= 0");
  }
  if (version >= 4) {
    p.options.nodeStiffnessScale = b.real("node_stiffness_scale");
    if (!(p.options.nodeStiffnessScale > 0.0)) b.fail("node_stiffness_scale", "must be positive");
  }
  if (version >= 3) {
    const std::uint32_t computed = b.crc();
    if (b.raw<std::uint32_t>("checksum") != computed) {
      b.fail("checksum", "does not match the contents: the file is damaged (a bit flip, a partial copy or an edit)");
    }
  }
  // The body frame must be a rotation (orthonormal, determinant +1).
  const Mat<D> R = p.bodyToGrid.rotation;
  if (!((R.transpose() * R - Mat<D>::Identity()).cwiseAbs().maxCoeff() <= 1e-9) || !(R.determinant() > 0.0)) {
    b.fail("body_to_grid_rotation", "is not a rotation (orthonormal with determinant +1)");
  }
  return checkedShape(source, 0, "", [&] { return Shape<D>::fromParts(std::move(p)); });
}

// ============================================================================
// Text form: reading
// ============================================================================

/// One line of a text grain, split into whitespace-separated tokens with
/// comments ('#' to the end of the line) removed.
struct TextLine {
  int number = 0;
  std::vector<std::string> tokens;
};

/// Reads the next non-empty line; false at the end of the stream.
bool nextLine(std::istream& in, int& lineNumber, TextLine& line) {
  std::string text;
  while (std::getline(in, text)) {
    ++lineNumber;
    if (const auto hash = text.find('#'); hash != std::string::npos) text.erase(hash);
    std::istringstream words(text);
    line.tokens.clear();
    for (std::string w; words >> w;) line.tokens.push_back(w);
    if (!line.tokens.empty()) {
      line.number = lineNumber;
      return true;
    }
  }
  return false;
}

/// How a token parses as a number.
enum class Parsed { Number, NotFinite, NotANumber };

template <class T>
Parsed parseNumber(const std::string& token, T& value) {
  const char* first = token.data();
  const char* last = token.data() + token.size();
  if (first != last && *first == '+') ++first;  // from_chars does not take a leading '+'
  const auto r = std::from_chars(first, last, value);
  if (r.ec != std::errc() || r.ptr != last) return Parsed::NotANumber;
  if constexpr (std::is_floating_point_v<T>) {
    if (!std::isfinite(value)) return Parsed::NotFinite;
  }
  return Parsed::Number;
}

/// The scalar and vector keys of the text form with their number counts.
template <int D>
const std::map<std::string, int>& numberKeys() {
  static const std::map<std::string, int> keys = {
      {"origin", D},          {"spacing", 1},          {"nodes_per_cell", 1},     {"contact_spacing", 1},
      {"node_stiffness_scale", 1},
      {"body_to_grid_rotation", D * D},                {"body_to_grid_translation", D},
      {"volume", 1},          {"centroid", D},         {"second_moment", D * D},
      {"bounding_radius", 1}, {"descriptor_volume", 1}, {"surface_area", 1},
      {"circularity", 1},     {"aspect_ratio", 1},     {"best_fit_semi_axes", D},
      {"equivalent_diameter", 1}, {"sieve_size", 1},   {"intermediate_axis", 1}};
  return keys;
}

/// Keys that make a text grain the full form (every one is then required).
const std::vector<std::string>& fullFormKeys() {
  static const std::vector<std::string> keys = {
      "body_to_grid_rotation", "body_to_grid_translation", "volume", "centroid", "second_moment",
      "bounding_radius", "descriptor_volume", "surface_area", "circularity", "aspect_ratio",
      "best_fit_semi_axes", "equivalent_diameter", "sieve_size", "intermediate_axis", "body_nodes"};
  return keys;
}

/// A text grain being read: every key's numbers and line, then the blocks.
template <int D>
class TextGrainReader {
 public:
  TextGrainReader(std::istream& in, const std::string& source) : in_(in), source_(source) {}

  std::shared_ptr<const Shape<D>> read() {
    // Read every line up to `end` or the end of the stream.
    TextLine line;
    while (nextLine(in_, lineNumber_, line)) {
      const std::string& key = line.tokens[0];
      if (key == "end") break;
      if (lines_.count(key)) fail(line.number, key, "appears twice (first on line " + std::to_string(lines_[key]) + ")");
      lines_[key] = line.number;
      readKey(line);
    }
    if (lines_.empty()) fail(lineNumber_, "", "holds no grain (empty file)");
    return assemble();
  }

 private:
  [[noreturn]] void fail(int line, const std::string& key, const std::string& what) const {
    throw InputError(source_, line, key, what);
  }

  int count(const TextLine& line, std::size_t expected) const {
    const std::size_t got = line.tokens.size() - 1;
    if (got != expected) {
      fail(line.number, line.tokens[0],
           "expected " + std::to_string(expected) + " value" + (expected == 1 ? "" : "s") + ", got " + std::to_string(got));
    }
    return int(got);
  }

  template <class T>
  T number(const TextLine& line, std::size_t i) const {
    T v{};
    switch (parseNumber(line.tokens[i], v)) {
      case Parsed::Number: return v;
      case Parsed::NotFinite: fail(line.number, line.tokens[0], "'" + line.tokens[i] + "' is not finite");
      case Parsed::NotANumber: break;
    }
    fail(line.number, line.tokens[0], "'" + line.tokens[i] + "' is not a number");
  }

  void needDimension(const TextLine& line) const {
    if (!dimensionSeen_) fail(line.number, line.tokens[0], "the key 'dimension' must come first");
  }

  void readKey(const TextLine& line) {
    const std::string& key = line.tokens[0];
    // Header keys.
    if (key == "lsdem_grain") {
      count(line, 1);
      const int version = number<int>(line, 1);
      if (version != int(kVersion)) {
        fail(line.number, key, "grain format version " + std::to_string(version) + " is not supported (this lsdem reads " +
                                   std::to_string(kVersion) + ")");
      }
      return;
    }
    if (key == "dimension") {
      count(line, 1);
      const int dimension = number<int>(line, 1);
      if (dimension != 2 && dimension != 3) fail(line.number, key, "must be 2 or 3, got " + line.tokens[1]);
      if (dimension != D) {
        fail(line.number, key, "the file holds a " + std::to_string(dimension) + "D grain, a " + std::to_string(D) +
                                   "D one is needed");
      }
      dimensionSeen_ = true;
      return;
    }
    needDimension(line);
    // Grid geometry.
    if (key == "dims") {
      count(line, D);
      std::uint64_t total = 1;
      for (int a = 0; a < D; ++a) {
        dims_[a] = number<int>(line, std::size_t(a) + 1);
        if (dims_[a] < 2) fail(line.number, key, "each must be >= 2, got " + line.tokens[std::size_t(a) + 1]);
        total *= std::uint64_t(dims_[a]);
        if (total > kMaxValues) fail(line.number, key, "more than 2^31 grid values");
      }
      valueCount_ = std::size_t(total);
      return;
    }
    if (key == "mass_method") {
      count(line, 1);
      if (line.tokens[1] == "paper") {
        options_.massMethod = MassMethod::Paper;
      } else if (line.tokens[1] == "extrapolated") {
        options_.massMethod = MassMethod::Extrapolated;
      } else {
        fail(line.number, key, "must be 'paper' or 'extrapolated', got '" + line.tokens[1] + "'");
      }
      return;
    }
    // Blocks.
    if (key == "values") return readValues(line);
    if (key == "nodes" || key == "body_nodes") return readNodes(line);
    // Scalars and vectors.
    const auto& keys = numberKeys<D>();
    const auto it = keys.find(key);
    if (it == keys.end()) fail(line.number, key, "unknown key");
    count(line, std::size_t(it->second));
    std::vector<double>& v = numbers_[key];
    for (int i = 0; i < it->second; ++i) v.push_back(number<double>(line, std::size_t(i) + 1));
  }

  /// `values [COUNT]` and the grid values on the following lines, any number per line.
  void readValues(const TextLine& head) {
    if (!lines_.count("dims")) fail(head.number, "values", "the key 'dims' must come before the values");
    if (head.tokens.size() > 2) fail(head.number, "values", "expected at most a count after 'values'");
    if (head.tokens.size() == 2) {
      const auto declared = number<std::uint64_t>(head, 1);
      if (declared != valueCount_) {
        fail(head.number, "values", "count " + head.tokens[1] + " does not match dims " +
                                        dimsText<D>(dims_) + " (" + std::to_string(valueCount_) +
                                        " values)");
      }
    }
    values_.reserve(valueCount_);
    TextLine line;
    while (values_.size() < valueCount_) {
      if (!nextLine(in_, lineNumber_, line)) {
        fail(lineNumber_, "values", "the file ends after " + std::to_string(values_.size()) + " of " +
                                        std::to_string(valueCount_) + " values (truncated)");
      }
      for (std::size_t i = 0; i < line.tokens.size(); ++i) {
        float v = 0.0f;
        const Parsed parsed = parseNumber(line.tokens[i], v);
        if (parsed == Parsed::NotFinite) {
          fail(line.number, "values", "value " + std::to_string(values_.size()) + " ('" + line.tokens[i] + "') is not finite");
        }
        if (parsed == Parsed::NotANumber) {
          // A key where a value was due: the block is short.
          if (i == 0 && std::isalpha(static_cast<unsigned char>(line.tokens[i][0]))) {
            fail(line.number, "values", "expected " + std::to_string(valueCount_) + " values (dims " +
                                            dimsText<D>(dims_) + "), found " +
                                            std::to_string(values_.size()));
          }
          fail(line.number, "values", "'" + line.tokens[i] + "' is not a number");
        }
        if (values_.size() == valueCount_) {
          fail(line.number, "values", "more values than dims " + dimsText<D>(dims_) + " hold (" +
                                          std::to_string(valueCount_) + ")");
        }
        values_.push_back(v);
      }
    }
  }

  /// `nodes N` (grid frame, minimal form) or `body_nodes N` (body frame, full
  /// form) and N lines of D coordinates and a weight (optional for `nodes`).
  void readNodes(const TextLine& head) {
    const std::string& key = head.tokens[0];
    if (lines_.count("nodes") && lines_.count("body_nodes")) fail(head.number, key, "a grain has either nodes or body_nodes");
    count(head, 1);
    const auto n = number<std::uint64_t>(head, 1);
    if (n == 0 || n > kMaxNodes) fail(head.number, key, "node count must be in [1, 2^28], got " + head.tokens[1]);
    const bool weightRequired = key == "body_nodes";
    TextLine line;
    for (std::uint64_t i = 0; i < n; ++i) {
      if (!nextLine(in_, lineNumber_, line)) {
        fail(lineNumber_, key, "the file ends after " + std::to_string(i) + " of " + head.tokens[1] + " nodes (truncated)");
      }
      const std::size_t k = line.tokens.size();
      const bool hasWeight = k == std::size_t(D) + 1;
      if (k != std::size_t(D) + 1 && (weightRequired || k != std::size_t(D))) {
        const std::string expected = weightRequired ? std::to_string(D + 1)
                                                    : std::to_string(D) + " or " + std::to_string(D + 1);
        fail(line.number, key, "node " + std::to_string(i) + ": expected " + expected + " numbers (" +
                                   (D == 3 ? "x y z" : "x y") + (weightRequired ? " weight" : " [weight]") + "), got " +
                                   std::to_string(k) + " (" + std::to_string(n) + " nodes declared)");
      }
      if (i == 0) nodesWeighted_ = hasWeight;
      if (hasWeight != nodesWeighted_) fail(line.number, key, "node " + std::to_string(i) + ": either every node has a weight or none");
      Vec<D> x;
      for (int a = 0; a < D; ++a) {
        x[a] = parseToken(line, std::size_t(a), key);
      }
      nodes_.positions.push_back(x);
      if (hasWeight) {
        const double w = parseToken(line, std::size_t(D), key);
        if (w < 0.0) fail(line.number, key, "node " + std::to_string(i) + ": weight must be >= 0, got " + line.tokens[std::size_t(D)]);
        nodes_.weights.push_back(w);
      }
    }
  }

  double parseToken(const TextLine& line, std::size_t i, const std::string& key) const {
    double v = 0.0;
    const Parsed parsed = parseNumber(line.tokens[i], v);
    if (parsed == Parsed::NotFinite) fail(line.number, key, "'" + line.tokens[i] + "' is not finite");
    if (parsed == Parsed::NotANumber) fail(line.number, key, "'" + line.tokens[i] + "' is not a number");
    return v;
  }

  /// The numbers of a required key.
  const std::vector<double>& need(const std::string& key) const {
    const auto it = numbers_.find(key);
    if (it == numbers_.end()) fail(lineNumber_, key, "missing (required)");
    return it->second;
  }
  double scalar(const std::string& key) const { return need(key)[0]; }
  Vec<D> vec(const std::string& key) const { return Vec<D>::Map(need(key).data()); }
  Mat<D> mat(const std::string& key) const {
    const std::vector<double>& v = need(key);
    Mat<D> m;
    for (int i = 0; i < D; ++i)
      for (int j = 0; j < D; ++j) m(i, j) = v[std::size_t(i * D + j)];
    return m;
  }

  std::shared_ptr<const Shape<D>> assemble() {
    // The grid, required in both forms.
    if (!dimensionSeen_) fail(lineNumber_, "dimension", "missing (required)");
    for (const char* key : {"dims", "values"}) {
      if (!lines_.count(key)) fail(lineNumber_, key, "missing (required)");
    }
    const double spacing = scalar("spacing");
    if (!(spacing > 0.0)) fail(lines_.at("spacing"), "spacing", "must be positive, got " + shortest(spacing));
    Grid<D> grid(dims_, vec("origin"), spacing);
    grid.values() = std::move(values_);
    if (numbers_.count("nodes_per_cell")) {
      options_.nodesPerCell = scalar("nodes_per_cell");
      if (!(options_.nodesPerCell > 0.0)) fail(lines_.at("nodes_per_cell"), "nodes_per_cell", "must be positive");
    }
    if (numbers_.count("contact_spacing")) {
      options_.contactSpacing = scalar("contact_spacing");
      if (!(options_.contactSpacing > 0.0)) fail(lines_.at("contact_spacing"), "contact_spacing", "must be positive");
    }
    if (numbers_.count("node_stiffness_scale")) {
      options_.nodeStiffnessScale = scalar("node_stiffness_scale");
      if (!(options_.nodeStiffnessScale > 0.0)) {
        fail(lines_.at("node_stiffness_scale"), "node_stiffness_scale", "must be positive");
      }
    }
    // Which form: any full-form key asks for all of them.
    const bool full = std::any_of(fullFormKeys().begin(), fullFormKeys().end(),
                                  [&](const std::string& k) { return lines_.count(k) > 0; });
    if (full) return assembleFull(std::move(grid));
    return assembleMinimal(std::move(grid));
  }

  std::shared_ptr<const Shape<D>> assembleFull(Grid<D> grid) {
    if (lines_.count("nodes")) fail(lines_.at("nodes"), "nodes", "the full form holds body_nodes, not nodes");
    if (!lines_.count("body_nodes")) fail(lineNumber_, "body_nodes", "missing (required in the full form)");
    typename Shape<D>::Parts p;
    p.grid = std::move(grid);
    p.bodyToGrid.rotation = mat("body_to_grid_rotation");
    p.bodyToGrid.translation = vec("body_to_grid_translation");
    p.nodes = std::move(nodes_);
    p.mass.volume = scalar("volume");
    p.mass.centroid = vec("centroid");
    p.mass.secondMoment = mat("second_moment");
    p.descriptors.volume = scalar("descriptor_volume");
    p.descriptors.surfaceArea = scalar("surface_area");
    p.descriptors.circularity = scalar("circularity");
    p.descriptors.aspectRatio = scalar("aspect_ratio");
    p.descriptors.bestFitSemiAxes = vec("best_fit_semi_axes");
    p.descriptors.equivalentDiameter = scalar("equivalent_diameter");
    p.descriptors.sieveSize = scalar("sieve_size");
    p.descriptors.intermediateAxis = scalar("intermediate_axis");
    p.boundingRadius = scalar("bounding_radius");
    p.options = options_;
    return checkedShape(source_, 0, "", [&] { return Shape<D>::fromParts(std::move(p)); });
  }

  std::shared_ptr<const Shape<D>> assembleMinimal(Grid<D> grid) {
    // A grid without an inside makes no grain.
    const bool hasInside = std::any_of(grid.values().begin(), grid.values().end(), [](float v) { return v < 0.0f; });
    if (!hasInside) fail(lines_.at("values"), "values", "no value is negative: the grid holds no grain (phi < 0 inside)");
    const int line = lines_.at("values");
    if (!lines_.count("nodes")) {
      return checkedShape(source_, line, "values", [&] { return Shape<D>::fromGrid(std::move(grid), options_); });
    }
    // Nodes without weights share the surface measured by the grid's own nodes equally.
    if (!nodesWeighted_) {
      const auto probe = checkedShape(source_, line, "values", [&] { return Shape<D>::fromGrid(grid, options_); });
      const double share = probe->nodes().totalWeight() / double(nodes_.size());
      nodes_.weights.assign(nodes_.size(), share);
    }
    return checkedShape(source_, lines_.at("nodes"), "nodes",
                        [&] { return Shape<D>::fromGridAndNodes(std::move(grid), std::move(nodes_), options_); });
  }

  std::istream& in_;
  const std::string& source_;
  int lineNumber_ = 0;
  bool dimensionSeen_ = false;
  std::map<std::string, int> lines_;                  // key -> line it was on
  std::map<std::string, std::vector<double>> numbers_;  // scalar and vector keys
  Index<D> dims_ = Index<D>::Zero();
  std::size_t valueCount_ = 0;
  std::vector<float> values_;
  NodeSet<D> nodes_;
  bool nodesWeighted_ = true;
  geometry::ShapeOptions options_;
};

bool isBinary(std::istream& in) { return in.peek() == static_cast<unsigned char>(kMagic[0]); }

std::ifstream openForReading(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    const std::error_code ec(errno, std::generic_category());
    throw InputError(path, 0, "", "cannot open grain file: " + ec.message());
  }
  return in;
}

}  // namespace

template <int D>
void writeGrain(std::ostream& out, const Shape<D>& shape, GrainFormat format) {
  const std::string bytes = format == GrainFormat::Text ? textGrain<D>(shape) : binaryGrain<D>(shape);
  out.write(bytes.data(), std::streamsize(bytes.size()));
  if (!out) throw std::runtime_error("writing a grain failed (stream error)");
}

template <int D>
void writeGrainFile(const std::string& path, const Shape<D>& shape, GrainFormat format) {
  // Write beside the target, then rename over it (atomic on one file system).
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) {
      const std::error_code ec(errno, std::generic_category());
      throw std::runtime_error("cannot write grain file '" + path + "': " + ec.message());
    }
    writeGrain<D>(out, shape, format);
    out.close();
    if (!out) {
      std::error_code ignored;
      fs::remove(tmp, ignored);
      throw std::runtime_error("cannot write grain file '" + path + "': write failed");
    }
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw std::runtime_error("cannot write grain file '" + path + "': " + ec.message());
  }
}

template <int D>
std::shared_ptr<const Shape<D>> readGrain(std::istream& in, const std::string& sourceName) {
  if (in.peek() == std::char_traits<char>::eof()) throw InputError(sourceName, 0, "", "holds no grain (empty file)");
  if (isBinary(in)) return readBinary<D>(in, sourceName);
  return TextGrainReader<D>(in, sourceName).read();
}

template <int D>
std::shared_ptr<const Shape<D>> readGrainFile(const std::string& path) {
  std::ifstream in = openForReading(path);
  return readGrain<D>(in, path);
}

int grainFileDimension(const std::string& path) {
  std::ifstream in = openForReading(path);
  if (in.peek() == std::char_traits<char>::eof()) throw InputError(path, 0, "", "holds no grain (empty file)");
  // Binary: the header.
  if (isBinary(in)) {
    BinaryIn b(in, path);
    return int(readBinaryHeader(b));
  }
  // Text: the `dimension` key, which comes before the grid.
  int lineNumber = 0;
  TextLine line;
  while (nextLine(in, lineNumber, line)) {
    const std::string& key = line.tokens[0];
    if (key == "lsdem_grain") continue;
    if (key != "dimension") break;
    int dimension = 0;
    if (line.tokens.size() != 2 || parseNumber(line.tokens[1], dimension) != Parsed::Number ||
        (dimension != 2 && dimension != 3)) {
      throw InputError(path, line.number, "dimension", "must be 2 or 3, got '" +
                                                           (line.tokens.size() > 1 ? line.tokens[1] : std::string()) + "'");
    }
    return dimension;
  }
  throw InputError(path, lineNumber, "dimension", "missing: a text grain starts with 'dimension 2' or 'dimension 3'");
}

template <int D>
std::vector<std::shared_ptr<const Shape<D>>> readGrainFolder(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError(dir, 0, "", "is not a folder of grain files");
  // The *.lsg regular files, sorted by name.
  std::vector<fs::path> files;
  for (const fs::directory_entry& e : fs::directory_iterator(dir)) {
    if (e.is_regular_file() && e.path().extension() == ".lsg") files.push_back(e.path());
  }
  if (files.empty()) throw InputError(dir, 0, "", "holds no *.lsg grain files");
  std::sort(files.begin(), files.end(),
            [](const fs::path& a, const fs::path& b) { return a.filename().string() < b.filename().string(); });
  std::vector<std::shared_ptr<const Shape<D>>> pool;
  pool.reserve(files.size());
  for (const fs::path& f : files) pool.push_back(readGrainFile<D>(f.string()));
  return pool;
}

template void writeGrain<2>(std::ostream&, const Shape<2>&, GrainFormat);
template void writeGrain<3>(std::ostream&, const Shape<3>&, GrainFormat);
template void writeGrainFile<2>(const std::string&, const Shape<2>&, GrainFormat);
template void writeGrainFile<3>(const std::string&, const Shape<3>&, GrainFormat);
template std::shared_ptr<const Shape<2>> readGrain<2>(std::istream&, const std::string&);
template std::shared_ptr<const Shape<3>> readGrain<3>(std::istream&, const std::string&);
template std::shared_ptr<const Shape<2>> readGrainFile<2>(const std::string&);
template std::shared_ptr<const Shape<3>> readGrainFile<3>(const std::string&);
template std::vector<std::shared_ptr<const Shape<2>>> readGrainFolder<2>(const std::string&);
template std::vector<std::shared_ptr<const Shape<3>>> readGrainFolder<3>(const std::string&);

}  // namespace lsdem::io
