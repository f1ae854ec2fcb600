#pragma once
/// @file VtpReader.h
/// @brief Test helper: a small, strict reader of the XML files lsdem writes
/// for ParaView (`.vtp` PolyData pieces and `.pvd` collections). It checks
/// that the XML is well formed (every element closed in order), decodes
/// `format="binary"` arrays (base64 of a UInt64 byte count followed by the
/// little-endian data, checked against each other) and `format="ascii"` arrays,
/// and checks every array's size against the piece's point / cell counts.
/// Any violation throws std::runtime_error.

#include <cctype>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace lsdem::test {

/// One XML element: name, attributes, text and children.
struct XmlElement {
  std::string name;
  std::map<std::string, std::string> attributes;
  std::string text;  ///< character data directly inside the element
  std::vector<std::unique_ptr<XmlElement>> children;

  /// @brief The attribute `key`; throws when absent.
  const std::string& attr(const std::string& key) const {
    auto it = attributes.find(key);
    if (it == attributes.end()) throw std::runtime_error("<" + name + "> has no attribute " + key);
    return it->second;
  }
  /// @brief The first child named `n`, or nullptr.
  const XmlElement* child(const std::string& n) const {
    for (const auto& c : children) {
      if (c->name == n) return c.get();
    }
    return nullptr;
  }
};

namespace detail {

inline std::string unescape(const std::string& s) {
  std::string out;
  for (std::size_t k = 0; k < s.size();) {
    if (s[k] == '&') {
      const std::size_t semi = s.find(';', k);
      if (semi == std::string::npos) throw std::runtime_error("bad entity in '" + s + "'");
      const std::string e = s.substr(k, semi - k + 1);
      if (e == "&amp;") out += '&';
      else if (e == "&lt;") out += '<';
      else if (e == "&gt;") out += '>';
      else if (e == "&quot;") out += '"';
      else if (e == "&apos;") out += '\'';
      else throw std::runtime_error("unknown entity " + e);
      k = semi + 1;
    } else {
      out += s[k++];
    }
  }
  return out;
}

}  // namespace detail

/// @brief Parses a whole XML document (prolog, comments, elements with
/// double-quoted attributes) and returns its root element.
inline std::unique_ptr<XmlElement> parseXml(const std::string& text) {
  std::vector<XmlElement*> stack;
  std::unique_ptr<XmlElement> root;
  std::size_t at = 0;
  while (at < text.size()) {
    const std::size_t open = text.find('<', at);
    // Character data up to the next tag.
    const std::string chunk = text.substr(at, (open == std::string::npos ? text.size() : open) - at);
    if (!stack.empty()) {
      stack.back()->text += chunk;
    } else if (chunk.find_first_not_of(" \t\r\n") != std::string::npos) {
      throw std::runtime_error("text outside the root element");
    }
    if (open == std::string::npos) break;
    // Prolog and comments.
    if (text.compare(open, 5, "<?xml") == 0) {
      const std::size_t end = text.find("?>", open);
      if (end == std::string::npos || open != text.find_first_not_of(" \t\r\n")) {
        throw std::runtime_error("bad XML prolog");
      }
      at = end + 2;
      continue;
    }
    if (text.compare(open, 4, "<!--") == 0) {
      const std::size_t end = text.find("-->", open);
      if (end == std::string::npos) throw std::runtime_error("unterminated comment");
      at = end + 3;
      continue;
    }
    const std::size_t close = text.find('>', open);
    if (close == std::string::npos) throw std::runtime_error("unterminated tag");
    std::string tag = text.substr(open + 1, close - open - 1);
    at = close + 1;
    // End tag: must close the innermost open element.
    if (!tag.empty() && tag[0] == '/') {
      const std::string name = tag.substr(1);
      if (stack.empty() || stack.back()->name != name) throw std::runtime_error("unexpected </" + name + ">");
      stack.pop_back();
      continue;
    }
    // Start or empty-element tag.
    const bool selfClosing = !tag.empty() && tag.back() == '/';
    if (selfClosing) tag.pop_back();
    auto element = std::make_unique<XmlElement>();
    std::size_t k = 0;
    while (k < tag.size() && !std::isspace(static_cast<unsigned char>(tag[k]))) ++k;
    element->name = tag.substr(0, k);
    if (element->name.empty()) throw std::runtime_error("empty tag name");
    while (true) {
      while (k < tag.size() && std::isspace(static_cast<unsigned char>(tag[k]))) ++k;
      if (k >= tag.size()) break;
      const std::size_t eq = tag.find('=', k);
      if (eq == std::string::npos || eq + 1 >= tag.size() || tag[eq + 1] != '"') {
        throw std::runtime_error("bad attribute in <" + element->name + ">");
      }
      const std::size_t end = tag.find('"', eq + 2);
      if (end == std::string::npos) throw std::runtime_error("unterminated attribute in <" + element->name + ">");
      const std::string key = tag.substr(k, eq - k);
      if (!element->attributes.emplace(key, detail::unescape(tag.substr(eq + 2, end - eq - 2))).second) {
        throw std::runtime_error("repeated attribute " + key);
      }
      k = end + 1;
    }
    XmlElement* raw = element.get();
    if (stack.empty()) {
      if (root) throw std::runtime_error("two root elements");
      root = std::move(element);
    } else {
      stack.back()->children.push_back(std::move(element));
    }
    if (!selfClosing) stack.push_back(raw);
  }
  if (!stack.empty()) throw std::runtime_error("<" + stack.back()->name + "> is never closed");
  if (!root) throw std::runtime_error("no root element");
  return root;
}

/// @brief The whole content of a file.
inline std::string readText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open " + path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// @brief Decodes RFC 4648 base64 (blanks ignored; '=' only at the end).
inline std::vector<unsigned char> decodeBase64(const std::string& text) {
  std::vector<unsigned char> out;
  unsigned value = 0;
  int bits = 0, padding = 0;
  for (char c : text) {
    if (std::isspace(static_cast<unsigned char>(c))) continue;
    if (c == '=') {
      ++padding;
      continue;
    }
    if (padding) throw std::runtime_error("base64: data after padding");
    int v;
    if (c >= 'A' && c <= 'Z') v = c - 'A';
    else if (c >= 'a' && c <= 'z') v = c - 'a' + 26;
    else if (c >= '0' && c <= '9') v = c - '0' + 52;
    else if (c == '+') v = 62;
    else if (c == '/') v = 63;
    else throw std::runtime_error(std::string("base64: bad character '") + c + "'");
    value = (value << 6) | unsigned(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<unsigned char>((value >> bits) & 0xff));
    }
  }
  if (padding > 2) throw std::runtime_error("base64: too much padding");
  return out;
}

/// One decoded DataArray; the values are in the vector matching `type`.
struct VtpArray {
  std::string type;  ///< Float64, Int64, UInt64, Int32
  std::string name;
  std::string format;  ///< binary or ascii
  int components = 1;
  std::vector<double> f64;
  std::vector<std::int64_t> i64;
  std::vector<std::uint64_t> u64;
  std::vector<std::int32_t> i32;

  /// @brief Number of values of any type.
  std::size_t size() const { return f64.size() + i64.size() + u64.size() + i32.size(); }
  /// @brief Number of tuples.
  std::size_t tuples() const { return size() / std::size_t(components); }
  /// @brief Value k as a double (any type).
  double asDouble(std::size_t k) const {
    if (!f64.empty()) return f64.at(k);
    if (!i64.empty()) return double(i64.at(k));
    if (!u64.empty()) return double(u64.at(k));
    return double(i32.at(k));
  }
};

namespace detail {

template <class T>
void decodeValues(const XmlElement& e, const std::string& format, std::vector<T>& out) {
  if (format == "binary") {
    const std::vector<unsigned char> bytes = decodeBase64(e.text);
    if (bytes.size() < 8) throw std::runtime_error("binary array '" + e.attr("Name") + "' has no header");
    std::uint64_t count = 0;
    std::memcpy(&count, bytes.data(), 8);
    if (count != bytes.size() - 8 || count % sizeof(T) != 0) {
      throw std::runtime_error("binary array '" + e.attr("Name") + "': header says " + std::to_string(count) +
                               " bytes, data has " + std::to_string(bytes.size() - 8));
    }
    out.resize(count / sizeof(T));
    if (count) std::memcpy(out.data(), bytes.data() + 8, count);
  } else if (format == "ascii") {
    const std::string& s = e.text;
    std::size_t k = 0;
    while (true) {
      while (k < s.size() && std::isspace(static_cast<unsigned char>(s[k]))) ++k;
      if (k >= s.size()) break;
      std::size_t end = k;
      while (end < s.size() && !std::isspace(static_cast<unsigned char>(s[end]))) ++end;
      T v{};
      const auto r = std::from_chars(s.data() + k, s.data() + end, v);
      if (r.ec != std::errc() || r.ptr != s.data() + end) {
        throw std::runtime_error("ascii array '" + e.attr("Name") + "': bad number '" + s.substr(k, end - k) + "'");
      }
      out.push_back(v);
      k = end;
    }
  } else {
    throw std::runtime_error("unknown format '" + format + "'");
  }
}

inline VtpArray readArray(const XmlElement& e) {
  if (e.name != "DataArray") throw std::runtime_error("expected <DataArray>, got <" + e.name + ">");
  VtpArray a;
  a.type = e.attr("type");
  a.name = e.attr("Name");
  a.format = e.attr("format");
  auto it = e.attributes.find("NumberOfComponents");
  if (it != e.attributes.end()) a.components = std::stoi(it->second);
  if (a.type == "Float64") decodeValues(e, a.format, a.f64);
  else if (a.type == "Int64") decodeValues(e, a.format, a.i64);
  else if (a.type == "UInt64") decodeValues(e, a.format, a.u64);
  else if (a.type == "Int32") decodeValues(e, a.format, a.i32);
  else throw std::runtime_error("unsupported type " + a.type);
  if (a.components < 1 || a.size() % std::size_t(a.components) != 0) {
    throw std::runtime_error("array '" + a.name + "' size does not match its components");
  }
  return a;
}

}  // namespace detail

/// Cells of one kind, decoded.
struct VtpCells {
  std::vector<std::int64_t> connectivity;
  std::vector<std::int64_t> offsets;
  /// @brief Point indices of cell c.
  std::vector<std::int64_t> cell(std::size_t c) const {
    const std::int64_t begin = c == 0 ? 0 : offsets.at(c - 1);
    return {connectivity.begin() + begin, connectivity.begin() + offsets.at(c)};
  }
};

/// A decoded PolyData file.
struct VtpFile {
  std::size_t points = 0, verts = 0, lines = 0, polys = 0;
  std::vector<double> coordinates;  ///< 3 per point
  VtpCells vertCells, lineCells, polyCells;
  std::map<std::string, VtpArray> pointData, cellData;

  std::size_t cells() const { return verts + lines + polys; }
  const VtpArray& pointArray(const std::string& n) const {
    auto it = pointData.find(n);
    if (it == pointData.end()) throw std::runtime_error("no point array " + n);
    return it->second;
  }
  const VtpArray& cellArray(const std::string& n) const {
    auto it = cellData.find(n);
    if (it == cellData.end()) throw std::runtime_error("no cell array " + n);
    return it->second;
  }
};

/// @brief Reads and checks a `.vtp` file written by lsdem.
inline VtpFile readVtp(const std::string& path) {
  const auto root = parseXml(readText(path));
  if (root->name != "VTKFile" || root->attr("type") != "PolyData") throw std::runtime_error("not PolyData");
  if (root->attr("byte_order") != "LittleEndian" || root->attr("header_type") != "UInt64") {
    throw std::runtime_error("unexpected byte order or header type");
  }
  const XmlElement* poly = root->child("PolyData");
  if (!poly) throw std::runtime_error("no <PolyData>");
  const XmlElement* piece = poly->child("Piece");
  if (!piece) throw std::runtime_error("no <Piece>");
  VtpFile f;
  f.points = std::stoull(piece->attr("NumberOfPoints"));
  f.verts = std::stoull(piece->attr("NumberOfVerts"));
  f.lines = std::stoull(piece->attr("NumberOfLines"));
  f.polys = std::stoull(piece->attr("NumberOfPolys"));
  // Points.
  const XmlElement* points = piece->child("Points");
  if (!points || points->children.size() != 1) throw std::runtime_error("no <Points> array");
  const VtpArray p = detail::readArray(*points->children[0]);
  if (p.components != 3 || p.tuples() != f.points || p.f64.size() != 3 * f.points) {
    throw std::runtime_error("Points array does not match NumberOfPoints");
  }
  f.coordinates = p.f64;
  // Cells: connectivity + offsets, consistent with the counts.
  auto readCells = [&](const char* tag, std::size_t count, VtpCells& cells) {
    const XmlElement* e = piece->child(tag);
    if (!e) {
      if (count) throw std::runtime_error(std::string("missing <") + tag + ">");
      return;
    }
    for (const auto& c : e->children) {
      VtpArray a = detail::readArray(*c);
      if (a.type != "Int64") throw std::runtime_error("cell arrays must be Int64");
      if (a.name == "connectivity") cells.connectivity = a.i64;
      if (a.name == "offsets") cells.offsets = a.i64;
    }
    if (cells.offsets.size() != count) throw std::runtime_error(std::string(tag) + ": offsets do not match the count");
    std::int64_t last = 0;
    for (std::int64_t o : cells.offsets) {
      if (o < last) throw std::runtime_error(std::string(tag) + ": offsets decrease");
      last = o;
    }
    if (std::size_t(last) != cells.connectivity.size()) throw std::runtime_error(std::string(tag) + ": bad offsets");
    for (std::int64_t i : cells.connectivity) {
      if (i < 0 || std::size_t(i) >= f.points) throw std::runtime_error(std::string(tag) + ": index out of range");
    }
  };
  readCells("Verts", f.verts, f.vertCells);
  readCells("Lines", f.lines, f.lineCells);
  readCells("Polys", f.polys, f.polyCells);
  // Attributes, sized by points and cells.
  auto readData = [&](const char* tag, std::size_t tuples, std::map<std::string, VtpArray>& out) {
    const XmlElement* e = piece->child(tag);
    if (!e) return;
    for (const auto& c : e->children) {
      VtpArray a = detail::readArray(*c);
      if (a.tuples() != tuples) {
        throw std::runtime_error(std::string(tag) + " array '" + a.name + "' has " + std::to_string(a.tuples()) +
                                 " tuples, expected " + std::to_string(tuples));
      }
      out.emplace(a.name, std::move(a));
    }
  };
  readData("PointData", f.points, f.pointData);
  readData("CellData", f.cells(), f.cellData);
  return f;
}

/// One entry of a `.pvd` collection.
struct PvdEntry {
  double time = 0.0;
  std::string file;
};

/// @brief Reads and checks a `.pvd` collection.
inline std::vector<PvdEntry> readPvd(const std::string& path) {
  const auto root = parseXml(readText(path));
  if (root->name != "VTKFile" || root->attr("type") != "Collection") throw std::runtime_error("not a Collection");
  const XmlElement* collection = root->child("Collection");
  if (!collection) throw std::runtime_error("no <Collection>");
  std::vector<PvdEntry> entries;
  for (const auto& c : collection->children) {
    if (c->name != "DataSet") throw std::runtime_error("unexpected <" + c->name + ">");
    PvdEntry e;
    const std::string& t = c->attr("timestep");
    const auto r = std::from_chars(t.data(), t.data() + t.size(), e.time);
    if (r.ec != std::errc() || r.ptr != t.data() + t.size()) throw std::runtime_error("bad timestep " + t);
    e.file = c->attr("file");
    entries.push_back(e);
  }
  return entries;
}

}  // namespace lsdem::test
