#include "lsdem/io/Vtk.h"

#include "NumberText.h"

#include "lsdem/breakage/GrainStress.h"
#include "lsdem/geometry/Contours.h"
#include "lsdem/io/InputError.h"
#include "lsdem/io/VtpRead.h"

#include "OutputNames.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <system_error>

#include <zlib.h>

namespace lsdem::io {

static_assert(std::endian::native == std::endian::little,
              "the VTK writer stores raw little-endian bytes; a big-endian build needs a byte swap here");

namespace {

using geometry::Vec;

// ---------------------------------------------------------------------------
// Text helpers

// A string safe inside a double-quoted XML attribute.
std::string xmlEscape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

// The inverse of xmlEscape for the five predefined entities.
std::string xmlUnescape(const std::string& s) {
  static const std::array<std::pair<const char*, char>, 5> entities{
      {{"&amp;", '&'}, {"&lt;", '<'}, {"&gt;", '>'}, {"&quot;", '"'}, {"&apos;", '\''}}};
  std::string out;
  for (std::size_t k = 0; k < s.size();) {
    bool matched = false;
    if (s[k] == '&') {
      for (const auto& [name, c] : entities) {
        const std::size_t n = std::strlen(name);
        if (s.compare(k, n, name) == 0) {
          out += c;
          k += n;
          matched = true;
          break;
        }
      }
    }
    if (!matched) out += s[k++];
  }
  return out;
}

// ---------------------------------------------------------------------------
// Base64 (RFC 4648) of one continuous byte stream, appended to a string.

class Base64Stream {
 public:
  explicit Base64Stream(std::string& out) : out_(out) {}

  // Appends `n` bytes to the stream.
  void put(const void* data, std::size_t n) {
    const auto* b = static_cast<const unsigned char*>(data);
    std::size_t k = 0;
    // Complete a pending triplet first.
    while (pending_ > 0 && pending_ < 3 && k < n) buffer_[pending_++] = b[k++];
    if (pending_ == 3) {
      emit(buffer_[0], buffer_[1], buffer_[2], 3);
      pending_ = 0;
    }
    // Whole triplets straight from the input.
    for (; k + 3 <= n; k += 3) emit(b[k], b[k + 1], b[k + 2], 3);
    // Keep the tail for the next put or finish.
    while (k < n) buffer_[pending_++] = b[k++];
  }

  // Flushes the last 1-2 bytes with '=' padding.
  void finish() {
    if (pending_ == 1) emit(buffer_[0], 0, 0, 1);
    if (pending_ == 2) emit(buffer_[0], buffer_[1], 0, 2);
    pending_ = 0;
  }

 private:
  void emit(unsigned char a, unsigned char b, unsigned char c, int count) {
    static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    const unsigned v = (unsigned(a) << 16) | (unsigned(b) << 8) | unsigned(c);
    out_ += kAlphabet[(v >> 18) & 63];
    out_ += kAlphabet[(v >> 12) & 63];
    out_ += count > 1 ? kAlphabet[(v >> 6) & 63] : '=';
    out_ += count > 2 ? kAlphabet[v & 63] : '=';
  }

  std::string& out_;
  std::array<unsigned char, 3> buffer_{};
  int pending_ = 0;
};

// ---------------------------------------------------------------------------
// DataArray writing

template <class T>
const char* vtkTypeName() {
  if constexpr (std::is_same_v<T, double>) return "Float64";
  if constexpr (std::is_same_v<T, float>) return "Float32";
  if constexpr (std::is_same_v<T, std::int64_t>) return "Int64";
  if constexpr (std::is_same_v<T, std::uint64_t>) return "UInt64";
  if constexpr (std::is_same_v<T, std::int32_t>) return "Int32";
}

// A .vtp being built: the XML text, and the bytes of the appended block
// (the appended encodings).
struct Document {
  VtkEncoding encoding = VtkEncoding::Compressed;
  std::string xml;
  std::string appended;
};

// Bytes of a compressed array's block (VTK's default).
constexpr std::size_t kCompressionBlock = std::size_t(1) << 15;

// Appends `bytes` bytes at `data` to the appended block as VTK reads a
// compressed array: the header [blocks, block size, last block's size (0:
// full), compressed size of each block], then the zlib streams. Blocks are
// compressed in parallel (they are independent), each at zlib's level 1:
// on a demolition surfaces frame 3x faster than level 6 for 1 % more bytes
// (most of the bytes are coordinates, which no level compresses much).
void appendCompressed(std::string& out, const unsigned char* data, std::size_t bytes) {
  const std::size_t blocks = (bytes + kCompressionBlock - 1) / kCompressionBlock;
  std::vector<std::string> compressed(blocks);
  bool failed = false;
  const std::ptrdiff_t count = std::ptrdiff_t(blocks);
#pragma omp parallel for schedule(dynamic, 1) if (blocks > 4)
  for (std::ptrdiff_t k = 0; k < count; ++k) {
    const std::size_t first = std::size_t(k) * kCompressionBlock;
    const std::size_t size = std::min(kCompressionBlock, bytes - first);
    std::string& z = compressed[std::size_t(k)];
    uLongf length = compressBound(uLong(size));
    z.resize(length);
    if (compress2(reinterpret_cast<Bytef*>(z.data()), &length, data + first, uLong(size), 1) != Z_OK) {
#pragma omp atomic write
      failed = true;
    }
    z.resize(length);
  }
  if (failed) throw std::runtime_error("zlib could not compress a VTP array");
  std::vector<std::uint64_t> header{blocks, kCompressionBlock, bytes % kCompressionBlock};
  std::size_t total = 0;
  for (const std::string& z : compressed) {
    header.push_back(z.size());
    total += z.size();
  }
  out.reserve(out.size() + header.size() * sizeof(std::uint64_t) + total);
  out.append(reinterpret_cast<const char*>(header.data()), header.size() * sizeof(std::uint64_t));
  for (const std::string& z : compressed) out += z;
}

// One <DataArray> element with its values in the document's encoding.
template <class T>
void appendDataArray(Document& doc, const std::string& name, int components, std::span<const T> values) {
  std::string& out = doc.xml;
  out += "        <DataArray type=\"";
  out += vtkTypeName<T>();
  out += "\" Name=\"" + xmlEscape(name) + "\"";
  if (components > 1) out += " NumberOfComponents=\"" + std::to_string(components) + "\"";
  const std::uint64_t bytes = values.size() * sizeof(T);
  switch (doc.encoding) {
    case VtkEncoding::Compressed:
    case VtkEncoding::Appended:
      // The values go to the appended block; the element says where.
      out += " format=\"appended\" offset=\"" + std::to_string(doc.appended.size()) + "\"/>\n";
      if (doc.encoding == VtkEncoding::Compressed) {
        appendCompressed(doc.appended, reinterpret_cast<const unsigned char*>(values.data()), bytes);
      } else {
        doc.appended.append(reinterpret_cast<const char*>(&bytes), sizeof(bytes));
        doc.appended.append(reinterpret_cast<const char*>(values.data()), bytes);
      }
      return;
    case VtkEncoding::Binary: {
      // One base64 stream: UInt64 byte count, then the raw little-endian values.
      out += " format=\"binary\">\n          ";
      Base64Stream b64(out);
      b64.put(&bytes, sizeof(bytes));
      b64.put(values.data(), bytes);
      b64.finish();
      out += '\n';
      break;
    }
    case VtkEncoding::Ascii:
      // Blank-separated numbers, one tuple group of up to 12 values per line.
      out += " format=\"ascii\">\n";
      for (std::size_t k = 0; k < values.size(); ++k) {
        out += (k % 12 == 0) ? "          " : " ";
        appendNumber(out, values[k]);
        if (k % 12 == 11 || k + 1 == values.size()) out += '\n';
      }
      break;
  }
  out += "        </DataArray>\n";
}

void appendArray(Document& doc, const VtkArray& a) {
  std::visit(
      [&](const auto& v) {
        using T = typename std::decay_t<decltype(v)>::value_type;
        appendDataArray<T>(doc, a.name, a.components, std::span<const T>(v));
      },
      a.values);
}

// Checks the arrays of one attribute set against their tuple count.
void checkArrays(const std::vector<VtkArray>& arrays, std::size_t tuples, const char* what) {
  for (const VtkArray& a : arrays) {
    if (a.components < 1) {
      throw std::invalid_argument(std::string(what) + " array '" + a.name + "' has " + std::to_string(a.components) +
                                  " components");
    }
    if (a.valueCount() != tuples * std::size_t(a.components)) {
      throw std::invalid_argument(std::string(what) + " array '" + a.name + "' has " +
                                  std::to_string(a.valueCount()) + " values for " + std::to_string(tuples) +
                                  " tuples of " + std::to_string(a.components));
    }
  }
}

// Checks one cell block: increasing offsets ending at the connectivity size,
// indices naming existing points.
void checkCells(const VtkCells& cells, std::size_t points, const char* what) {
  std::int64_t previous = 0;
  for (std::int64_t o : cells.offsets) {
    if (o < previous) throw std::invalid_argument(std::string(what) + " offsets decrease at " + std::to_string(o));
    previous = o;
  }
  if (std::size_t(previous) != cells.connectivity.size()) {
    throw std::invalid_argument(std::string(what) + " offsets end at " + std::to_string(previous) + " but there are " +
                                std::to_string(cells.connectivity.size()) + " indices");
  }
  for (std::int64_t i : cells.connectivity) {
    if (i < 0 || std::size_t(i) >= points) {
      throw std::invalid_argument(std::string(what) + " refer to point " + std::to_string(i) + " of " +
                                  std::to_string(points));
    }
  }
}

void appendCells(Document& doc, const char* tag, const VtkCells& cells) {
  if (cells.size() == 0) return;
  doc.xml += "      <";
  doc.xml += tag;
  doc.xml += ">\n";
  // Int32 where every index and offset fits (half the bytes), else Int64.
  const bool narrow = cells.offsets.back() <= std::numeric_limits<std::int32_t>::max();
  for (const auto& [name, values] : {std::pair<const char*, const std::vector<std::int64_t>*>{"connectivity", &cells.connectivity},
                                     std::pair<const char*, const std::vector<std::int64_t>*>{"offsets", &cells.offsets}}) {
    if (narrow) {
      const std::vector<std::int32_t> small(values->begin(), values->end());
      appendDataArray<std::int32_t>(doc, name, 1, small);
    } else {
      appendDataArray<std::int64_t>(doc, name, 1, *values);
    }
  }
  doc.xml += "      </";
  doc.xml += tag;
  doc.xml += ">\n";
}

// ---------------------------------------------------------------------------
// Frame helpers

// A D-vector as 3 coordinates (z = 0 in 2D).
template <int D>
void push3(std::vector<double>& out, const Vec<D>& v) {
  out.push_back(v[0]);
  out.push_back(v[1]);
  out.push_back(D == 3 ? v[D - 1] : 0.0);
}

// An angular quantity as 3 components: (0, 0, w) in 2D.
template <int D>
void pushSpin(std::vector<double>& out, const dynamics::Spin<D>& w) {
  if constexpr (D == 2) {
    out.insert(out.end(), {0.0, 0.0, w});
  } else {
    out.insert(out.end(), {w[0], w[1], w[2]});
  }
}

// An orientation as a unit quaternion (w, x, y, z); 2D: rotation about z.
template <int D>
void pushQuaternion(std::vector<double>& out, const dynamics::Orientation<D>& q) {
  if constexpr (D == 2) {
    out.insert(out.end(), {std::cos(0.5 * q), 0.0, 0.0, std::sin(0.5 * q)});
  } else {
    out.insert(out.end(), {q.w(), q.x(), q.y(), q.z()});
  }
}

// Places a body contour at a pose and appends its points and cells (and its
// normals, rotated, where `normals` is given and the contour has them).
template <int D>
void appendPlaced(VtpPiece& piece, VtkCells& cells, const BodyContour<D>& contour, const geometry::Mat<D>& rotation,
                  const Vec<D>& position, std::vector<float>* normals = nullptr) {
  const auto base = std::int64_t(piece.pointCount());
  for (const Vec<D>& xb : contour.vertices) push3<D>(piece.points, Vec<D>(rotation * xb + position));
  const auto connectivityBase = std::int64_t(cells.connectivity.size());
  for (std::int64_t i : contour.connectivity) cells.connectivity.push_back(base + i);
  for (std::int64_t o : contour.offsets) cells.offsets.push_back(connectivityBase + o);
  if (normals != nullptr && !contour.normals.empty()) {
    for (const Vec<D>& nb : contour.normals) {
      const Vec<D> n = rotation * nb;
      for (int a = 0; a < 3; ++a) normals->push_back(a < D ? float(n[a]) : 0.0f);
    }
  }
}

// A particle's criterion ratio: its stress over its strength (how close it
// is to breaking, 1 at the criterion), 0 where it has no finite positive
// strength (breakage off, or made unbreakable).
double criterionRatio(double stress, double strength) {
  return std::isfinite(strength) && strength > 0.0 ? stress / strength : 0.0;
}

// A particle's strength as the frames show it: -1 for a grain made
// unbreakable (infinite strength).
double shownStrength(double strength) { return std::isfinite(strength) ? strength : -1.0; }

// The frames' per-particle stress measure: empty, or one value per particle.
void checkStressMeasure(const char* frame, std::span<const double> stressMeasure, std::size_t particles) {
  if (!stressMeasure.empty() && stressMeasure.size() != particles) {
    throw std::invalid_argument(std::string(frame) + " frame: stress measure has " +
                                std::to_string(stressMeasure.size()) + " values for " + std::to_string(particles) +
                                " particles");
  }
}

// Orthonormal tangent basis of a 3D plane with unit normal n.
void tangentBasis(const Vec<3>& n, Vec<3>& u, Vec<3>& v) {
  const Vec<3> helper = std::abs(n[0]) < 0.9 ? Vec<3>::UnitX() : Vec<3>::UnitY();
  u = n.cross(helper).normalized();
  v = n.cross(u);
}

// The plane {n.(x - p) = 0} clipped to a box: 2 points in 2D (a segment),
// 3-6 points in 3D (a convex polygon in order around its normal). A plane that
// misses the box gives a segment / square of the box's diagonal, centred at
// the projection of the box centre.
template <int D>
std::vector<Vec<D>> clipPlane(const dynamics::Plane<D>& plane, const geometry::Box<D>& box) {
  const Vec<D> n = plane.normal.normalized();
  const double diagonal = box.size().norm();
  const double tol = 1e-12 * diagonal;
  // Intersections of the plane with the box edges (edges along each axis a).
  std::vector<Vec<D>> hits;
  for (int a = 0; a < D; ++a) {
    for (int corner = 0; corner < (1 << D); ++corner) {
      if (corner & (1 << a)) continue;
      Vec<D> p0;
      for (int c = 0; c < D; ++c) p0[c] = (corner & (1 << c)) ? box.upper[c] : box.lower[c];
      Vec<D> p1 = p0;
      p1[a] = box.upper[a];
      const double s0 = n.dot(p0 - plane.point), s1 = n.dot(p1 - plane.point);
      if ((s0 > 0.0 && s1 > 0.0) || (s0 < 0.0 && s1 < 0.0) || s0 == s1) continue;
      const double t = s0 / (s0 - s1);
      const Vec<D> x = p0 + t * (p1 - p0);
      // Skip repeats (a plane through a corner meets several edges there).
      bool repeat = false;
      for (const Vec<D>& h : hits) repeat = repeat || (h - x).norm() <= tol;
      if (!repeat) hits.push_back(x);
    }
  }
  // The tangent direction(s) of the plane.
  const Vec<D> centre = 0.5 * (box.lower + box.upper);
  const Vec<D> foot = centre - n.dot(centre - plane.point) * n;
  if constexpr (D == 2) {
    const Vec<2> t(-n[1], n[0]);
    if (hits.size() < 2) return {foot - 0.5 * diagonal * t, foot + 0.5 * diagonal * t};
    // The two extreme hits along the tangent.
    auto [lo, hi] = std::minmax_element(hits.begin(), hits.end(),
                                        [&](const Vec<2>& x, const Vec<2>& y) { return t.dot(x) < t.dot(y); });
    return {*lo, *hi};
  } else {
    Vec<3> u, v;
    tangentBasis(n, u, v);
    if (hits.size() < 3) {
      const double h = 0.5 * diagonal;
      return {foot - h * u - h * v, foot + h * u - h * v, foot + h * u + h * v, foot - h * u + h * v};
    }
    // Counter-clockwise around n, by angle about the centroid of the hits.
    Vec<3> mid = Vec<3>::Zero();
    for (const Vec<3>& h : hits) mid += h;
    mid /= double(hits.size());
    std::sort(hits.begin(), hits.end(), [&](const Vec<3>& x, const Vec<3>& y) {
      return std::atan2(v.dot(x - mid), u.dot(x - mid)) < std::atan2(v.dot(y - mid), u.dot(y - mid));
    });
    return hits;
  }
}

}  // namespace

// ---------------------------------------------------------------------------
// Low-level writing

const char* encodingName(VtkEncoding encoding) {
  switch (encoding) {
    case VtkEncoding::Compressed: return "compressed";
    case VtkEncoding::Appended: return "appended";
    case VtkEncoding::Binary: return "binary";
    case VtkEncoding::Ascii: return "ascii";
  }
  return "";
}

std::optional<VtkEncoding> encodingNamed(std::string_view name) {
  for (VtkEncoding e : {VtkEncoding::Compressed, VtkEncoding::Appended, VtkEncoding::Binary, VtkEncoding::Ascii}) {
    if (name == encodingName(e)) return e;
  }
  return std::nullopt;
}

std::size_t VtkArray::valueCount() const {
  return std::visit([](const auto& v) { return v.size(); }, values);
}

void VtkCells::add(std::span<const std::int64_t> points) {
  connectivity.insert(connectivity.end(), points.begin(), points.end());
  offsets.push_back(std::int64_t(connectivity.size()));
}

namespace {

// Values [first, first + count) tuples of `components` of an array, appended.
template <class T>
void appendTuples(std::vector<T>& out, const std::vector<T>& values, std::size_t first, std::size_t count,
                  std::size_t components) {
  const auto begin = values.begin() + std::ptrdiff_t(first * components);
  out.insert(out.end(), begin, begin + std::ptrdiff_t(count * components));
}

// The array `a` of pieces[0] joined over every piece, tuples [first(p),
// first(p) + count(p)) of each piece's array by that name in turn (`ranges`:
// per pass, per piece, first and count); nullopt when a piece lacks it.
std::optional<VtkArray> joinArray(std::span<const VtpPiece> pieces, std::vector<VtkArray> VtpPiece::*data,
                                  const VtkArray& a,
                                  const std::vector<std::vector<std::pair<std::size_t, std::size_t>>>& ranges) {
  std::vector<const VtkArray*> arrays;
  bool sameType = true;
  for (const VtpPiece& p : pieces) {
    const auto it = std::find_if((p.*data).begin(), (p.*data).end(), [&](const VtkArray& b) { return b.name == a.name; });
    if (it == (p.*data).end() || it->components != a.components) return std::nullopt;
    sameType = sameType && it->values.index() == a.values.index();
    arrays.push_back(&*it);
  }
  const auto c = std::size_t(a.components);
  VtkArray out{a.name, a.components, std::vector<double>()};
  if (sameType) {
    std::visit(
        [&](const auto& first) {
          using Vector = std::decay_t<decltype(first)>;
          Vector joined;
          for (const auto& pass : ranges) {
            for (std::size_t k = 0; k < pieces.size(); ++k) {
              appendTuples(joined, std::get<Vector>(arrays[k]->values), pass[k].first, pass[k].second, c);
            }
          }
          out.values = std::move(joined);
        },
        a.values);
  } else {
    std::vector<double> joined;
    for (const auto& pass : ranges) {
      for (std::size_t k = 0; k < pieces.size(); ++k) {
        std::vector<double> v;
        std::visit([&](const auto& values) { v.assign(values.begin(), values.end()); }, arrays[k]->values);
        appendTuples(joined, v, pass[k].first, pass[k].second, c);
      }
    }
    out.values = std::move(joined);
  }
  return out;
}

}  // namespace

VtpPiece joinPieces(std::span<const VtpPiece> pieces) {
  VtpPiece out;
  if (pieces.empty()) return out;
  // Points, then each cell kind in piece order.
  std::vector<std::int64_t> base;
  for (const VtpPiece& p : pieces) {
    base.push_back(std::int64_t(out.pointCount()));
    out.points.insert(out.points.end(), p.points.begin(), p.points.end());
  }
  for (VtkCells VtpPiece::*kind : {&VtpPiece::verts, &VtpPiece::lines, &VtpPiece::polys}) {
    VtkCells& to = out.*kind;
    for (std::size_t k = 0; k < pieces.size(); ++k) {
      const VtkCells& from = pieces[k].*kind;
      const auto connectivityBase = std::int64_t(to.connectivity.size());
      for (std::int64_t i : from.connectivity) to.connectivity.push_back(base[k] + i);
      for (std::int64_t o : from.offsets) to.offsets.push_back(connectivityBase + o);
    }
  }
  // Point data: each piece's points in turn. Cell data: verts of every
  // piece, then lines, then polygons.
  std::vector<std::vector<std::pair<std::size_t, std::size_t>>> pointRanges(1), cellRanges(3);
  for (const VtpPiece& p : pieces) {
    pointRanges[0].emplace_back(0, p.pointCount());
    cellRanges[0].emplace_back(0, p.verts.size());
    cellRanges[1].emplace_back(p.verts.size(), p.lines.size());
    cellRanges[2].emplace_back(p.verts.size() + p.lines.size(), p.polys.size());
  }
  for (const VtkArray& a : pieces[0].pointData) {
    if (auto joined = joinArray(pieces, &VtpPiece::pointData, a, pointRanges)) out.pointData.push_back(std::move(*joined));
  }
  for (const VtkArray& a : pieces[0].cellData) {
    if (auto joined = joinArray(pieces, &VtpPiece::cellData, a, cellRanges)) out.cellData.push_back(std::move(*joined));
  }
  return out;
}

void writeFileAtomically(const std::filesystem::path& file, const std::string& content) {
  const std::string_view part(content);
  writeFileAtomically(file, std::span<const std::string_view>(&part, 1));
}

void writeFileAtomically(const std::filesystem::path& file, std::span<const std::string_view> parts) {
  // Write the whole content to a temporary file beside the target.
  std::filesystem::path tmp = file;
  tmp += ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) {
      throw std::runtime_error("cannot write '" + file.string() + "': cannot open '" + tmp.string() +
                               "': " + std::strerror(errno));
    }
    // A failed write, flush or close (a full disk, a file size limit, a
    // network file system reporting late) leaves the target as it was.
    errno = 0;
    for (const std::string_view part : parts) out.write(part.data(), std::streamsize(part.size()));
    out.flush();
    if (out) out.close();
    if (!out) {
      const std::string reason = errno != 0 ? std::strerror(errno) : "write failed";
      if (out.is_open()) out.close();
      std::error_code ignored;
      std::filesystem::remove(tmp, ignored);
      throw std::runtime_error("cannot write '" + file.string() + "': " + reason);
    }
  }
  // Replace the target in one step.
  std::error_code ec;
  std::filesystem::rename(tmp, file, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    throw std::runtime_error("cannot write '" + file.string() + "': rename failed: " + ec.message());
  }
}

void writeVtp(const std::filesystem::path& file, const VtpPiece& piece, VtkEncoding encoding) {
  // Validate sizes and indices before writing anything.
  if (piece.points.size() % 3 != 0) {
    throw std::invalid_argument("VTP points hold " + std::to_string(piece.points.size()) +
                                " coordinates, not a multiple of 3");
  }
  const std::size_t points = piece.pointCount();
  checkCells(piece.verts, points, "vertex cells");
  checkCells(piece.lines, points, "line cells");
  checkCells(piece.polys, points, "polygon cells");
  checkArrays(piece.pointData, points, "point data");
  checkArrays(piece.cellData, piece.cellCount(), "cell data");

  // The document, built in memory and written in one piece.
  Document doc;
  doc.encoding = encoding;
  std::string& out = doc.xml;
  const bool appended = encoding == VtkEncoding::Compressed || encoding == VtkEncoding::Appended;
  if (!appended) {
    out.reserve(256 + 12 * piece.points.size() + 12 * (piece.verts.connectivity.size() +
                                                       piece.lines.connectivity.size() + piece.polys.connectivity.size()));
  }
  out += "<?xml version=\"1.0\"?>\n";
  out += "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\"";
  if (encoding == VtkEncoding::Compressed) out += " compressor=\"vtkZLibDataCompressor\"";
  out += ">\n";
  out += "  <PolyData>\n";
  if (piece.time) {
    out += "    <FieldData>\n";
    out += "      <DataArray type=\"Float64\" Name=\"TimeValue\" NumberOfTuples=\"1\" format=\"ascii\">";
    appendNumber(out, *piece.time);
    out += "</DataArray>\n";
    out += "    </FieldData>\n";
  }
  out += "    <Piece NumberOfPoints=\"" + std::to_string(points) + "\" NumberOfVerts=\"" +
         std::to_string(piece.verts.size()) + "\" NumberOfLines=\"" + std::to_string(piece.lines.size()) +
         "\" NumberOfStrips=\"0\" NumberOfPolys=\"" + std::to_string(piece.polys.size()) + "\">\n";
  // Attributes on points and cells.
  out += "      <PointData>\n";
  for (const VtkArray& a : piece.pointData) appendArray(doc, a);
  out += "      </PointData>\n";
  out += "      <CellData>\n";
  for (const VtkArray& a : piece.cellData) appendArray(doc, a);
  out += "      </CellData>\n";
  // Geometry and topology.
  out += "      <Points>\n";
  if (piece.singlePrecisionPoints) {
    const std::vector<float> points32(piece.points.begin(), piece.points.end());
    appendDataArray<float>(doc, "Points", 3, points32);
  } else {
    appendDataArray<double>(doc, "Points", 3, piece.points);
  }
  out += "      </Points>\n";
  appendCells(doc, "Verts", piece.verts);
  appendCells(doc, "Lines", piece.lines);
  appendCells(doc, "Polys", piece.polys);
  out += "    </Piece>\n";
  out += "  </PolyData>\n";
  if (appended) {
    // The XML, the appended bytes, the end: written in turn, not joined.
    out += "  <AppendedData encoding=\"raw\">\n   _";
    const std::string_view parts[] = {out, doc.appended, "\n  </AppendedData>\n</VTKFile>\n"};
    writeFileAtomically(file, parts);
    return;
  }
  out += "</VTKFile>\n";
  writeFileAtomically(file, out);
}

VtpPiece layoutOf(const VtpPiece& piece) {
  VtpPiece layout;
  const auto strip = [](const std::vector<VtkArray>& arrays, std::vector<VtkArray>& into) {
    for (const VtkArray& a : arrays) {
      VtkArray e{a.name, a.components, {}};
      std::visit([&](const auto& v) { e.values = std::decay_t<decltype(v)>(); }, a.values);
      into.push_back(std::move(e));
    }
  };
  strip(piece.pointData, layout.pointData);
  strip(piece.cellData, layout.cellData);
  layout.singlePrecisionPoints = piece.singlePrecisionPoints;
  return layout;
}

void writePvtp(const std::filesystem::path& file, const VtpPiece& layout, std::span<const std::string> pieceFiles) {
  const auto declare = [](std::string& out, const VtkArray& a) {
    std::visit(
        [&](const auto& v) {
          using T = typename std::decay_t<decltype(v)>::value_type;
          out += "      <PDataArray type=\"" + std::string(vtkTypeName<T>()) + "\" Name=\"" + xmlEscape(a.name) +
                 "\" NumberOfComponents=\"" + std::to_string(a.components) + "\"/>\n";
        },
        a.values);
  };
  std::string out = "<?xml version=\"1.0\"?>\n";
  out += "<VTKFile type=\"PPolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n";
  out += "  <PPolyData GhostLevel=\"0\">\n";
  out += "    <PPointData>\n";
  for (const VtkArray& a : layout.pointData) declare(out, a);
  out += "    </PPointData>\n";
  out += "    <PCellData>\n";
  for (const VtkArray& a : layout.cellData) declare(out, a);
  out += "    </PCellData>\n";
  out += "    <PPoints>\n";
  out += std::string("      <PDataArray type=\"") + (layout.singlePrecisionPoints ? "Float32" : "Float64") +
         "\" Name=\"Points\" NumberOfComponents=\"3\"/>\n";
  out += "    </PPoints>\n";
  for (const std::string& piece : pieceFiles) out += "    <Piece Source=\"" + xmlEscape(piece) + "\"/>\n";
  out += "  </PPolyData>\n";
  out += "</VTKFile>\n";
  writeFileAtomically(file, out);
}

// ---------------------------------------------------------------------------
// Body contours and their cache

template <int D>
std::size_t BodyContour<D>::pieceCount() const {
  if constexpr (D == 3) {
    return offsets.size();
  } else {
    // A closed loop of n vertices has n edges.
    return connectivity.size();
  }
}

template <int D>
BodyContour<D> bodyContour(const geometry::Shape<D>& shape) {
  BodyContour<D> c;
  const geometry::Rigid<D>& bodyToGrid = shape.bodyToGrid();
  if constexpr (D == 2) {
    // Closed loops: each a polygon, its vertices in order around it.
    for (const std::vector<Vec<2>>& loop : geometry::marchingSquares(shape.grid())) {
      for (const Vec<2>& x : loop) {
        c.connectivity.push_back(std::int64_t(c.vertices.size()));
        c.vertices.push_back(bodyToGrid.applyInverse(x));
      }
      c.offsets.push_back(std::int64_t(c.connectivity.size()));
    }
  } else {
    // Triangles with shared vertices.
    const geometry::TriangleMesh mesh = geometry::marchingCubes(shape.grid());
    c.vertices.reserve(mesh.vertices.size());
    c.normals.reserve(mesh.vertices.size());
    for (const Vec<3>& x : mesh.vertices) {
      c.vertices.push_back(bodyToGrid.applyInverse(x));
      Vec<3> g;
      shape.valueAndGradient(c.vertices.back(), g);
      const double length = g.norm();
      c.normals.push_back(length > 0.0 ? Vec<3>(g / length) : Vec<3>::UnitZ());
    }
    c.connectivity.reserve(3 * mesh.faces.size());
    for (const auto& f : mesh.faces) {
      c.connectivity.insert(c.connectivity.end(), {f[0], f[1], f[2]});
      c.offsets.push_back(std::int64_t(c.connectivity.size()));
    }
  }
  return c;
}

template <int D>
const BodyContour<D>& SurfaceCache<D>::contour(const std::shared_ptr<const geometry::Shape<D>>& shape) {
  if (!shape) throw std::invalid_argument("surface cache: null shape");
  // The cache holds every shape it keys, so a hit is the same live shape.
  auto it = entries_.find(shape.get());
  if (it == entries_.end()) it = entries_.emplace(shape.get(), Entry{shape, bodyContour(*shape)}).first;
  return it->second.contour;
}

template <int D>
void SurfaceCache<D>::prune() {
  std::erase_if(entries_, [](const auto& kv) { return kv.second.shape.use_count() == 1; });
}

// ---------------------------------------------------------------------------
// Frames

template <int D>
StressInvariants stressInvariants(const geometry::Mat<D>& sigma) {
  StressInvariants out;
  const Vec<3> s = breakage::principalStressTriple<D>(sigma);
  out.principal = {s[0], s[1], s[2]};
  out.mean = (s[0] + s[1] + s[2]) / 3.0;
  out.vonMises = std::sqrt(0.5 * ((s[0] - s[1]) * (s[0] - s[1]) + (s[1] - s[2]) * (s[1] - s[2]) +
                                  (s[2] - s[0]) * (s[2] - s[0])));
  return out;
}

namespace {
// The indices of the particles `world` owns (all but its ghosts: World::setGhost), in store order.
template <int D>
std::vector<std::size_t> ownParticles(const dynamics::World<D>& world) {
  std::vector<std::size_t> own;
  own.reserve(world.particles().size());
  for (std::size_t i = 0; i < world.particles().size(); ++i) {
    if (!world.isGhost(i)) own.push_back(i);
  }
  return own;
}
}  // namespace

template <int D>
VtpPiece writeParticleFrame(const std::filesystem::path& file, const dynamics::World<D>& world,
                        std::span<const double> stressMeasure, VtkEncoding encoding,
                        std::span<const geometry::Mat<D>> stressTensors) {
  const dynamics::Particles<D>& p = world.particles();
  const std::size_t n = p.size();
  checkStressMeasure("particle", stressMeasure, n);
  if (!stressTensors.empty() && stressTensors.size() != n) {
    throw std::invalid_argument("particle frame: " + std::to_string(stressTensors.size()) + " stress tensors for " +
                                std::to_string(n) + " particles");
  }
  // Per-particle columns, of the world's own particles (a distributed run's
  // piece leaves its ghosts to their owners' pieces).
  const std::vector<std::size_t> own = ownParticles(world);
  const std::size_t m = own.size();
  VtpPiece piece;
  std::vector<std::uint64_t> id(m);
  std::vector<std::int64_t> parent(m);
  std::vector<std::int32_t> generation(m);
  std::vector<double> radius(m), diameter(m), mass(m), stress(m, 0.0), strength(m), ratio(m);
  std::vector<double> meanStress(m, 0.0), vonMises(m, 0.0), principal(3 * m, 0.0);
  std::vector<double> velocity, spin, orientation;
  std::array<std::vector<double>, 3> axes;  // the body axes in the world (glyph orientation)
  velocity.reserve(3 * m);
  spin.reserve(3 * m);
  orientation.reserve(4 * m);
  for (auto& a : axes) a.reserve(3 * m);
  piece.points.reserve(3 * m);
  for (std::size_t k = 0; k < m; ++k) {
    const std::size_t i = own[k];
    push3<D>(piece.points, p.position[i]);
    const std::int64_t index = std::int64_t(k);
    piece.verts.add(std::span<const std::int64_t>(&index, 1));
    id[k] = p.id[i];
    parent[k] = p.parentId[i] == dynamics::kNoParent ? -1 : std::int64_t(p.parentId[i]);
    generation[k] = p.generation[i];
    radius[k] = p.shape[i]->boundingRadius();
    diameter[k] = p.shape[i]->descriptors().equivalentDiameter;
    mass[k] = p.mass[i];
    if (!stressMeasure.empty()) stress[k] = stressMeasure[i];
    strength[k] = shownStrength(p.strength[i]);
    ratio[k] = criterionRatio(stress[k], p.strength[i]);
    if (!stressTensors.empty()) {
      const StressInvariants s = stressInvariants<D>(stressTensors[i]);
      meanStress[k] = s.mean;
      vonMises[k] = s.vonMises;
      std::copy(s.principal.begin(), s.principal.end(), principal.begin() + std::ptrdiff_t(3 * k));
    }
    push3<D>(velocity, p.velocity[i]);
    pushSpin<D>(spin, p.angularVelocity[i]);
    pushQuaternion<D>(orientation, p.orientation[i]);
    const geometry::Mat<D> r = p.rotation(i);
    for (int a = 0; a < 3; ++a) {
      if (a < D) {
        push3<D>(axes[std::size_t(a)], Vec<D>(r.col(a)));
      } else {
        axes[std::size_t(a)].insert(axes[std::size_t(a)].end(), {0.0, 0.0, 1.0});  // 2D: the z axis
      }
    }
  }
  // Point data, in the order ParaView lists them.
  piece.pointData.push_back({"id", 1, std::move(id)});
  piece.pointData.push_back({"parent_id", 1, std::move(parent)});
  piece.pointData.push_back({"generation", 1, std::move(generation)});
  piece.pointData.push_back({"radius", 1, std::move(radius)});
  piece.pointData.push_back({"equivalent_diameter", 1, std::move(diameter)});
  piece.pointData.push_back({"mass", 1, std::move(mass)});
  piece.pointData.push_back({"velocity", 3, std::move(velocity)});
  piece.pointData.push_back({"angular_velocity", 3, std::move(spin)});
  piece.pointData.push_back({"orientation", 4, std::move(orientation)});
  piece.pointData.push_back({"axis_x", 3, std::move(axes[0])});
  piece.pointData.push_back({"axis_y", 3, std::move(axes[1])});
  piece.pointData.push_back({"axis_z", 3, std::move(axes[2])});
  piece.pointData.push_back({"stress", 1, std::move(stress)});
  piece.pointData.push_back({"strength", 1, std::move(strength)});
  piece.pointData.push_back({"criterion_ratio", 1, std::move(ratio)});
  piece.pointData.push_back({"mean_stress", 1, std::move(meanStress)});
  piece.pointData.push_back({"von_mises_stress", 1, std::move(vonMises)});
  piece.pointData.push_back({"principal_stress", 3, std::move(principal)});
  piece.time = world.time();
  writeVtp(file, piece, encoding);
  return layoutOf(piece);
}

template <int D>
VtpPiece writeSurfaceFrame(const std::filesystem::path& file, const dynamics::World<D>& world, SurfaceCache<D>& cache,
                       VtkEncoding encoding, std::span<const double> stressMeasure) {
  const dynamics::Particles<D>& p = world.particles();
  checkStressMeasure("surface", stressMeasure, p.size());
  cache.prune();
  VtpPiece piece;
  VtkCells& cells = piece.polys;
  std::vector<std::uint64_t> id;
  std::vector<std::int32_t> generation;
  // The particles' fields on their cells as Float32: for colouring (the
  // particle frame has them in full precision), half the bytes to build and
  // compress on surfaces of a million triangles.
  std::vector<float> velocity, stress, strength, ratio;
  std::vector<float> normals;
  // Room for every point, cell and field first (a frame can hold millions).
  std::size_t totalPoints = 0, totalCells = 0, totalIndices = 0;
  const std::vector<std::size_t> own = ownParticles(world);
  for (const std::size_t i : own) {
    const BodyContour<D>& contour = cache.contour(p.shape[i]);
    totalPoints += contour.vertices.size();
    totalCells += contour.cellCount();
    totalIndices += contour.connectivity.size();
  }
  piece.points.reserve(3 * totalPoints);
  normals.reserve(D == 3 ? 3 * totalPoints : 0);
  cells.connectivity.reserve(totalIndices);
  cells.offsets.reserve(totalCells);
  id.reserve(totalCells);
  generation.reserve(totalCells);
  velocity.reserve(3 * totalCells);
  stress.reserve(totalCells);
  strength.reserve(totalCells);
  ratio.reserve(totalCells);
  // Each particle's body contour at its pose, with the particle's fields on its cells.
  for (const std::size_t i : own) {
    const BodyContour<D>& contour = cache.contour(p.shape[i]);
    appendPlaced<D>(piece, cells, contour, p.rotation(i), p.position[i], &normals);
    const std::size_t count = contour.cellCount();
    const double s = stressMeasure.empty() ? 0.0 : stressMeasure[i];
    id.insert(id.end(), count, p.id[i]);
    generation.insert(generation.end(), count, std::int32_t(p.generation[i]));
    const Vec<D>& v = p.velocity[i];
    const std::array<float, 3> v3{float(v[0]), float(v[1]), D == 3 ? float(v[D - 1]) : 0.0f};
    for (std::size_t c = 0; c < count; ++c) velocity.insert(velocity.end(), v3.begin(), v3.end());
    stress.insert(stress.end(), count, float(s));
    strength.insert(strength.end(), count, float(shownStrength(p.strength[i])));
    ratio.insert(ratio.end(), count, float(criterionRatio(s, p.strength[i])));
  }
  piece.cellData.push_back({"id", 1, std::move(id)});
  piece.cellData.push_back({"generation", 1, std::move(generation)});
  piece.cellData.push_back({"velocity", 3, std::move(velocity)});
  piece.cellData.push_back({"stress", 1, std::move(stress)});
  piece.cellData.push_back({"strength", 1, std::move(strength)});
  piece.cellData.push_back({"criterion_ratio", 1, std::move(ratio)});
  if (D == 3) piece.pointData.push_back({"Normals", 3, std::move(normals)});
  piece.singlePrecisionPoints = true;
  piece.time = world.time();
  writeVtp(file, piece, encoding);
  return layoutOf(piece);
}

template <int D>
std::vector<VtpPiece> boundaryPieces(const dynamics::World<D>& world, SurfaceCache<D>& cache,
                                     const geometry::Box<D>& extent) {
  if (!((extent.upper - extent.lower).array() > 0.0).all() || !extent.lower.allFinite() ||
      !extent.upper.allFinite()) {
    std::ostringstream msg;
    msg << "boundary frame: the extent box must have positive size, got lower (" << extent.lower.transpose()
        << ") upper (" << extent.upper.transpose() << ")";
    throw std::invalid_argument(msg.str());
  }
  std::vector<VtpPiece> pieces(1 + world.tools().size());
  // Piece 0: the planes clipped to the extent (segments in 2D, polygons in 3D).
  {
    VtpPiece& piece = pieces[0];
    VtkCells& cells = D == 2 ? piece.lines : piece.polys;
    std::vector<std::int32_t> kind, index;
    for (std::size_t k = 0; k < world.planes().size(); ++k) {
      std::vector<std::int64_t> ids;
      for (const Vec<D>& x : clipPlane<D>(world.planes()[k], extent)) {
        ids.push_back(std::int64_t(piece.pointCount()));
        push3<D>(piece.points, x);
      }
      cells.add(ids);
      kind.push_back(0);
      index.push_back(std::int32_t(k));
    }
    piece.cellData.push_back({"kind", 1, std::move(kind)});
    piece.cellData.push_back({"index", 1, std::move(index)});
  }
  // Piece 1 + k: tool k at its pose (polygons in 2D, triangles in 3D).
  for (std::size_t k = 0; k < world.tools().size(); ++k) {
    VtpPiece& piece = pieces[1 + k];
    const BodyContour<D>& contour = cache.contour(world.tools()[k].shape);
    const dynamics::ToolPose<D>& pose = world.toolPoses()[k];
    appendPlaced<D>(piece, piece.polys, contour, dynamics::Rotation<D>::matrix(pose.orientation), pose.position);
    piece.cellData.push_back({"kind", 1, std::vector<std::int32_t>(contour.cellCount(), 1)});
    piece.cellData.push_back({"index", 1, std::vector<std::int32_t>(contour.cellCount(), std::int32_t(k))});
  }
  for (VtpPiece& piece : pieces) piece.singlePrecisionPoints = true;
  return pieces;
}

template <int D>
void writeBoundaryFrame(const std::filesystem::path& file, const dynamics::World<D>& world, SurfaceCache<D>& cache,
                        const geometry::Box<D>& extent, VtkEncoding encoding) {
  VtpPiece all = joinPieces(boundaryPieces<D>(world, cache, extent));
  all.singlePrecisionPoints = true;
  all.time = world.time();
  writeVtp(file, all, encoding);
}

template <int D>
VtpPiece writeContactFrame(const std::filesystem::path& file, const dynamics::World<D>& world, VtkEncoding encoding) {
  const dynamics::Particles<D>& p = world.particles();
  const auto& nodes = world.contacts().nodeContacts();
  VtpPiece piece;
  // One line per touching pair, between two points of its own at the two
  // centroids: the pair's values are point data too (at both ends), so a
  // Tube filter can vary its radius by them.
  std::vector<std::uint64_t> pointId;
  std::vector<double> pointMagnitude, pointNormalForce;
  std::vector<double> force, magnitude, normalForce, tangentialForce;
  std::vector<std::int32_t> nodeCount;
  std::vector<std::uint64_t> idA, idB;
  // Right after a breakage or removal the records name old indices: no chains then.
  const std::span<const dynamics::PairContact<D>> pairs =
      world.contactsCurrent() ? world.contacts().particleContacts() : std::span<const dynamics::PairContact<D>>();
  for (const dynamics::PairContact<D>& c : pairs) {
    // (A pair with a ghost is shown by the owner of its lower-id particle, a.)
    if (c.nodeCount == 0 || c.a >= p.size() || c.b >= p.size() || world.isGhost(c.a)) continue;
    const std::int64_t first = std::int64_t(pointId.size());
    const std::array<std::int64_t, 2> ends{first, first + 1};
    piece.lines.add(ends);
    for (const std::uint32_t i : {c.a, c.b}) {
      push3<D>(piece.points, p.position[i]);
      pointId.push_back(p.id[i]);
    }
    // The overlap-weighted mean node normal (eq. 4, from b towards a) splits
    // the force: with per-node springs it is the direction of the total
    // normal force, so the rest is friction.
    Vec<D> normal = Vec<D>::Zero();
    for (std::uint32_t k = c.firstNode; k < c.firstNode + c.nodeCount && k < nodes.size(); ++k) {
      normal += nodes[k].overlap * nodes[k].normal;
    }
    if (normal.norm() > 0.0) normal.normalize();
    const double fn = c.force.dot(normal);
    const double size = c.force.norm();
    push3<D>(force, c.force);
    magnitude.push_back(size);
    normalForce.push_back(fn);
    pointMagnitude.insert(pointMagnitude.end(), 2, size);
    pointNormalForce.insert(pointNormalForce.end(), 2, fn);
    tangentialForce.push_back((c.force - fn * normal).norm());
    nodeCount.push_back(std::int32_t(c.nodeCount));
    idA.push_back(p.id[c.a]);
    idB.push_back(p.id[c.b]);
  }
  piece.pointData.push_back({"id", 1, std::move(pointId)});
  piece.pointData.push_back({"force_magnitude", 1, std::move(pointMagnitude)});
  piece.pointData.push_back({"normal_force", 1, std::move(pointNormalForce)});
  piece.cellData.push_back({"force", 3, std::move(force)});
  piece.cellData.push_back({"force_magnitude", 1, std::move(magnitude)});
  piece.cellData.push_back({"normal_force", 1, std::move(normalForce)});
  piece.cellData.push_back({"tangential_force", 1, std::move(tangentialForce)});
  piece.cellData.push_back({"node_contacts", 1, std::move(nodeCount)});
  piece.cellData.push_back({"id_a", 1, std::move(idA)});
  piece.cellData.push_back({"id_b", 1, std::move(idB)});
  piece.time = world.time();
  writeVtp(file, piece, encoding);
  return layoutOf(piece);
}

// ---------------------------------------------------------------------------
// PVD series

namespace {

// The value of attribute `name` in the tag text `tag`, or nullopt.
std::optional<std::string> attribute(const std::string& tag, const std::string& name) {
  std::size_t at = 0;
  while ((at = tag.find(name + "=\"", at)) != std::string::npos) {
    // Only a whole attribute name (preceded by a blank).
    if (at > 0 && std::isspace(static_cast<unsigned char>(tag[at - 1]))) {
      const std::size_t begin = at + name.size() + 2;
      const std::size_t end = tag.find('"', begin);
      if (end == std::string::npos) return std::nullopt;
      return xmlUnescape(tag.substr(begin, end - begin));
    }
    at += name.size();
  }
  return std::nullopt;
}

// 1-based line of character offset `at`.
int lineOf(const std::string& text, std::size_t at) {
  return 1 + int(std::count(text.begin(), text.begin() + std::ptrdiff_t(std::min(at, text.size())), '\n'));
}

}  // namespace

PvdSeries::PvdSeries(std::filesystem::path pvdFile, bool resume) : path_(std::move(pvdFile)) {
  if (resume && std::filesystem::exists(path_)) {
    // Read the existing series.
    std::ifstream in(path_, std::ios::binary);
    if (!in) throw InputError(path_.string(), 0, "", "cannot open the series for reading");
    std::stringstream buffer;
    buffer << in.rdbuf();
    const std::string text = buffer.str();
    if (text.find("<VTKFile") == std::string::npos || text.find("type=\"Collection\"") == std::string::npos) {
      throw InputError(path_.string(), 1, "", "not a ParaView series (no <VTKFile type=\"Collection\">)");
    }
    if (text.find("</VTKFile>") == std::string::npos) {
      throw InputError(path_.string(), lineOf(text, text.size()), "", "the series ends before </VTKFile>");
    }
    // One entry per <DataSet .../>.
    std::size_t at = 0;
    while ((at = text.find("<DataSet", at)) != std::string::npos) {
      const std::size_t end = text.find('>', at);
      if (end == std::string::npos) throw InputError(path_.string(), lineOf(text, at), "DataSet", "unterminated tag");
      const std::string tag = text.substr(at, end - at);
      const auto time = attribute(tag, "timestep");
      const auto file = attribute(tag, "file");
      if (!time) throw InputError(path_.string(), lineOf(text, at), "timestep", "missing");
      if (!file || file->empty()) throw InputError(path_.string(), lineOf(text, at), "file", "missing");
      Entry e;
      const auto r = std::from_chars(time->data(), time->data() + time->size(), e.time);
      if (r.ec != std::errc() || r.ptr != time->data() + time->size() || !std::isfinite(e.time)) {
        throw InputError(path_.string(), lineOf(text, at), "timestep", "not a number: '" + *time + "'");
      }
      e.file = *file;
      if (const auto part = attribute(tag, "part"); part && !part->empty()) {
        const auto rp = std::from_chars(part->data(), part->data() + part->size(), e.part);
        if (rp.ec != std::errc() || rp.ptr != part->data() + part->size() || e.part < 0) {
          throw InputError(path_.string(), lineOf(text, at), "part", "not a part number: '" + *part + "'");
        }
      }
      entries_.push_back(std::move(e));
      at = end;
    }
  }
  save();
}

void PvdSeries::add(double time, const std::string& relativeFile) {
  entries_.push_back({time, relativeFile, 0});
  save();
}

void PvdSeries::add(double time, std::span<const std::string> partFiles) {
  for (std::size_t k = 0; k < partFiles.size(); ++k) entries_.push_back({time, partFiles[k], int(k)});
  save();
}

std::size_t PvdSeries::frameCount() const {
  return std::size_t(std::count_if(entries_.begin(), entries_.end(), [](const Entry& e) { return e.part == 0; }));
}

void PvdSeries::truncateAfter(double time) {
  std::erase_if(entries_, [&](const Entry& e) { return e.time > time; });
  save();
}

void PvdSeries::save() const {
  std::string out = "<?xml version=\"1.0\"?>\n";
  out += "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n";
  out += "  <Collection>\n";
  for (const Entry& e : entries_) {
    out += "    <DataSet timestep=\"" + numberText(e.time) + "\" group=\"\" part=\"" + std::to_string(e.part) +
           "\" file=\"" + xmlEscape(e.file) + "\"/>\n";
  }
  out += "  </Collection>\n";
  out += "</VTKFile>\n";
  writeFileAtomically(path_, out);
}

// ---------------------------------------------------------------------------
// Frame writer

template <int D>
FrameWriter<D>::FrameWriter(FrameWriterDef<D> def) : def_(std::move(def)) {
  // Directories.
  const std::filesystem::path frames = def_.directory / "frames";
  std::error_code ec;
  std::filesystem::create_directories(frames, ec);
  if (ec || !std::filesystem::is_directory(frames)) {
    throw std::runtime_error("cannot create the output directory '" + frames.string() + "': " +
                             (ec ? ec.message() : std::string("not a directory")));
  }
  // Series.
  const auto pvd = [&](const char* series) { return def_.directory / (std::string(series) + ".pvd"); };
  if (def_.particles) particles_.emplace(pvd(outputs::kParticles), def_.resume);
  if (def_.surfaces) surfaces_.emplace(pvd(outputs::kSurfaces), def_.resume);
  if (def_.boundaries) boundaries_.emplace(pvd(outputs::kBoundaries), def_.resume);
  if (def_.contacts) contacts_.emplace(pvd(outputs::kContacts), def_.resume);
  updateNextFrame();
}

template <int D>
void FrameWriter<D>::updateNextFrame() {
  nextFrame_ = 0;
  for (const auto* s : {&particles_, &surfaces_, &boundaries_, &contacts_}) {
    if (*s) nextFrame_ = std::max(nextFrame_, (*s)->frameCount());
  }
}

template <int D>
void frameStresses(const dynamics::World<D>& world, std::vector<geometry::Mat<D>>& out) {
  out.clear();
  if (world.contactsCurrent()) breakage::grainStresses(world.particles(), world.contacts(), out);
  if (out.size() != world.particles().size()) out.assign(world.particles().size(), geometry::Mat<D>::Zero());
}

namespace {

// `stress` when it holds one tensor per particle; else frameStresses into `scratch`.
template <int D>
std::span<const geometry::Mat<D>> stressesOf(const dynamics::World<D>& world, std::span<const geometry::Mat<D>> stress,
                                             std::vector<geometry::Mat<D>>& scratch) {
  if (stress.size() == world.particles().size()) return stress;
  frameStresses(world, scratch);
  return scratch;
}

// A frame's number as its files spell it.
std::string frameNumber(std::size_t number) {
  char text[32];
  std::snprintf(text, sizeof(text), "%06zu", number);
  return text;
}

// The file of rank `rank`'s piece of a frame of `series`, relative to frames/.
std::string pieceName(const char* series, const std::string& number, int rank) {
  char text[16];
  std::snprintf(text, sizeof(text), "_r%05d.vtp", rank);
  return std::string(series) + "_" + number + text;
}

}  // namespace

template <int D>
std::array<VtpPiece, 3> writeFramePieces(const FrameWriterDef<D>& def, std::size_t number, int rank,
                                         const dynamics::World<D>& world, SurfaceCache<D>& cache,
                                         std::span<const double> stressMeasure,
                                         std::span<const geometry::Mat<D>> stress) {
  const std::string n = frameNumber(number);
  const std::filesystem::path frames = def.directory / "frames";
  std::array<VtpPiece, 3> layouts;
  if (def.particles) {
    std::vector<geometry::Mat<D>> scratch;
    layouts[0] = writeParticleFrame<D>(frames / pieceName(outputs::kParticles, n, rank), world, stressMeasure,
                                       def.encoding, stressesOf<D>(world, stress, scratch));
  }
  if (def.surfaces) {
    layouts[1] = writeSurfaceFrame<D>(frames / pieceName(outputs::kSurfaces, n, rank), world, cache, def.encoding,
                                      stressMeasure);
  }
  if (def.contacts) {
    layouts[2] = writeContactFrame<D>(frames / pieceName(outputs::kContacts, n, rank), world, def.encoding);
  }
  return layouts;
}

template <int D>
void FrameWriter<D>::write(const dynamics::World<D>& world, std::span<const double> stressMeasure,
                           std::span<const geometry::Mat<D>> stress) {
  const std::string number = frameNumber(nextFrame_);
  const double time = world.time();
  if (def_.pieces > 0 && !pieceLayouts_) {
    throw std::logic_error("FrameWriter: a frame in pieces needs the pieces' layouts (setPieceLayouts)");
  }
  // One frame of a series: the file (or the index of the ranks' pieces), then its entry.
  auto frame = [&](std::optional<PvdSeries>& series, const char* name, std::size_t layout, const auto& writeFile) {
    if (!series) return;
    if (def_.pieces > 0) {
      const std::string relative = std::string("frames/") + name + "_" + number + ".pvtp";
      std::vector<std::string> pieces;
      for (int r = 0; r < def_.pieces; ++r) pieces.push_back(pieceName(name, number, r));
      writePvtp(def_.directory / relative, (*pieceLayouts_)[layout], pieces);
      series->add(time, relative);
      return;
    }
    const std::string relative = std::string("frames/") + name + "_" + number + ".vtp";
    writeFile(def_.directory / relative);
    series->add(time, relative);
  };
  frame(particles_, outputs::kParticles, 0, [&](const std::filesystem::path& f) {
    writeParticleFrame<D>(f, world, stressMeasure, def_.encoding, stressesOf<D>(world, stress, stress_));
  });
  frame(surfaces_, outputs::kSurfaces, 1,
        [&](const std::filesystem::path& f) { writeSurfaceFrame<D>(f, world, cache_, def_.encoding, stressMeasure); });
  if (boundaries_) writeBoundaries(world, number);
  frame(contacts_, outputs::kContacts, 2,
        [&](const std::filesystem::path& f) { writeContactFrame<D>(f, world, def_.encoding); });
  pieceLayouts_.reset();
  ++nextFrame_;
}

template <int D>
void FrameWriter<D>::writeBoundaries(const dynamics::World<D>& world, const std::string& number) {
  // The extent: given, or the particles' bounding spheres grown by 10%.
  geometry::Box<D> extent = def_.extent;
  if (!((extent.upper - extent.lower).array() > 0.0).all()) {
    const auto& p = world.particles();
    extent.lower = Vec<D>::Constant(-0.5);
    extent.upper = Vec<D>::Constant(0.5);
    for (std::size_t i = 0; i < p.size(); ++i) {
      const Vec<D> r = Vec<D>::Constant(p.shape[i]->boundingRadius());
      const Vec<D> lo = p.position[i] - r, hi = p.position[i] + r;
      extent.lower = i == 0 ? lo : extent.lower.cwiseMin(lo).eval();
      extent.upper = i == 0 ? hi : extent.upper.cwiseMax(hi).eval();
    }
    const Vec<D> grow = 0.1 * (extent.upper - extent.lower);
    extent.lower -= grow;
    extent.upper += grow;
  }
  const std::vector<VtpPiece> pieces = boundaryPieces<D>(world, cache_, extent);
  recallBoundaries(pieces.size());
  // Each piece: its last file again when nothing in it moved, else a new file.
  std::vector<std::string> files(pieces.size());
  for (std::size_t k = 0; k < pieces.size(); ++k) {
    const VtpPiece& piece = pieces[k];
    WrittenPiece& last = boundaryFiles_[k];
    std::vector<float> points(piece.points.begin(), piece.points.end());
    const bool same = !last.file.empty() && points == last.points &&
                      piece.lines.connectivity == last.lines.connectivity &&
                      piece.lines.offsets == last.lines.offsets &&
                      piece.polys.connectivity == last.polys.connectivity && piece.polys.offsets == last.polys.offsets;
    if (!same) {
      const std::string relative = std::string("frames/") + outputs::kBoundaries + "_" + number +
                                   (k == 0 ? std::string("_planes") : "_tool" + std::to_string(k - 1)) + ".vtp";
      writeVtp(def_.directory / relative, piece, def_.encoding);
      last = {relative, std::move(points), piece.lines, piece.polys};
    }
    files[k] = last.file;
  }
  boundaries_->add(world.time(), files);
}

template <int D>
void FrameWriter<D>::recallBoundaries(std::size_t pieces) {
  if (boundariesRecalled_) return;
  boundariesRecalled_ = true;
  boundaryFiles_.assign(pieces, WrittenPiece{});
  // A resumed series: the files its last frame names, as they were written
  // (a file that cannot be read is written again).
  const std::vector<PvdSeries::Entry>& entries = boundaries_->entries();
  std::size_t first = entries.size();
  while (first > 0 && entries[first - 1].part != 0) --first;
  if (first == 0) return;
  for (std::size_t e = first - 1; e < entries.size(); ++e) {
    const std::size_t k = std::size_t(entries[e].part);
    if (k >= pieces) continue;
    try {
      const VtpPiece piece = readVtp(def_.directory / entries[e].file);
      boundaryFiles_[k] = {entries[e].file, std::vector<float>(piece.points.begin(), piece.points.end()), piece.lines,
                           piece.polys};
    } catch (const std::exception&) {
      boundaryFiles_[k] = WrittenPiece{};
    }
  }
}

template <int D>
void FrameWriter<D>::truncateAfter(double time) {
  for (auto* s : {&particles_, &surfaces_, &boundaries_, &contacts_}) {
    if (*s) (*s)->truncateAfter(time);
  }
  // The boundaries' last files are read again from what the series keeps.
  boundariesRecalled_ = false;
  updateNextFrame();
}

// ---------------------------------------------------------------------------
// Instantiations

template struct BodyContour<2>;
template struct BodyContour<3>;
template BodyContour<2> bodyContour<2>(const geometry::Shape<2>&);
template BodyContour<3> bodyContour<3>(const geometry::Shape<3>&);
template class SurfaceCache<2>;
template class SurfaceCache<3>;
template VtpPiece writeParticleFrame<2>(const std::filesystem::path&, const dynamics::World<2>&, std::span<const double>,
                                    VtkEncoding, std::span<const geometry::Mat<2>>);
template VtpPiece writeParticleFrame<3>(const std::filesystem::path&, const dynamics::World<3>&, std::span<const double>,
                                    VtkEncoding, std::span<const geometry::Mat<3>>);
template StressInvariants stressInvariants<2>(const geometry::Mat<2>&);
template StressInvariants stressInvariants<3>(const geometry::Mat<3>&);
template std::vector<VtpPiece> boundaryPieces<2>(const dynamics::World<2>&, SurfaceCache<2>&, const geometry::Box<2>&);
template std::vector<VtpPiece> boundaryPieces<3>(const dynamics::World<3>&, SurfaceCache<3>&, const geometry::Box<3>&);
template VtpPiece writeSurfaceFrame<2>(const std::filesystem::path&, const dynamics::World<2>&, SurfaceCache<2>&,
                                   VtkEncoding, std::span<const double>);
template VtpPiece writeSurfaceFrame<3>(const std::filesystem::path&, const dynamics::World<3>&, SurfaceCache<3>&,
                                   VtkEncoding, std::span<const double>);
template void writeBoundaryFrame<2>(const std::filesystem::path&, const dynamics::World<2>&, SurfaceCache<2>&,
                                    const geometry::Box<2>&, VtkEncoding);
template void writeBoundaryFrame<3>(const std::filesystem::path&, const dynamics::World<3>&, SurfaceCache<3>&,
                                    const geometry::Box<3>&, VtkEncoding);
template VtpPiece writeContactFrame<2>(const std::filesystem::path&, const dynamics::World<2>&, VtkEncoding);
template VtpPiece writeContactFrame<3>(const std::filesystem::path&, const dynamics::World<3>&, VtkEncoding);
template void frameStresses<2>(const dynamics::World<2>&, std::vector<geometry::Mat<2>>&);
template void frameStresses<3>(const dynamics::World<3>&, std::vector<geometry::Mat<3>>&);
template std::array<VtpPiece, 3> writeFramePieces<2>(const FrameWriterDef<2>&, std::size_t, int,
                                                       const dynamics::World<2>&, SurfaceCache<2>&,
                                                       std::span<const double>, std::span<const geometry::Mat<2>>);
template std::array<VtpPiece, 3> writeFramePieces<3>(const FrameWriterDef<3>&, std::size_t, int,
                                                       const dynamics::World<3>&, SurfaceCache<3>&,
                                                       std::span<const double>, std::span<const geometry::Mat<3>>);
template class FrameWriter<2>;
template class FrameWriter<3>;

}  // namespace lsdem::io
