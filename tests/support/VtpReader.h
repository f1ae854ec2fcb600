#pragma once
/// @file VtpReader.h
/// @brief Test helper: the ParaView files lsdem writes, read back with the
/// project's own reader (io/VtpRead.h, which checks the structure, decodes
/// every encoding lsdem writes and checks every array against the piece's
/// point and cell counts), in a form the tests index by array name. Any
/// problem throws (io::InputError or std::runtime_error).

#include "lsdem/io/VtpRead.h"

#include <cstdint>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace lsdem::test {

/// @brief The whole file as bytes.
inline std::string readText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open " + path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// One decoded DataArray; the values are in the vector matching `type`.
struct VtpArray {
  std::string type;    ///< Float64, Int64, UInt64, Int32
  std::string name;
  std::string format;  ///< compressed / appended (format="appended"), binary or ascii
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

namespace detail {

// The format attribute of the DataArray named `name` in the file's XML part
// ("compressed" for an appended array of a compressed file).
inline std::string formatOf(const std::string& text, const std::string& name) {
  const std::size_t at = text.find("Name=\"" + name + "\"");
  if (at == std::string::npos) return "";
  const std::size_t f = text.find("format=\"", at);
  if (f == std::string::npos) return "";
  const std::string format = text.substr(f + 8, text.find('"', f + 8) - f - 8);
  if (format == "appended" && text.find("compressor=\"vtkZLibDataCompressor\"") != std::string::npos) return "compressed";
  return format;
}

inline VtpArray toArray(const io::VtkArray& a, const std::string& text) {
  VtpArray out;
  out.name = a.name;
  out.components = a.components;
  out.format = formatOf(text.substr(0, text.find("<AppendedData")), a.name);
  std::visit(
      [&](const auto& v) {
        using T = typename std::decay_t<decltype(v)>::value_type;
        if constexpr (std::is_same_v<T, double>) out.type = "Float64", out.f64 = v;
        if constexpr (std::is_same_v<T, std::int64_t>) out.type = "Int64", out.i64 = v;
        if constexpr (std::is_same_v<T, std::uint64_t>) out.type = "UInt64", out.u64 = v;
        if constexpr (std::is_same_v<T, std::int32_t>) out.type = "Int32", out.i32 = v;
        if constexpr (std::is_same_v<T, float>) out.type = "Float32", out.f64.assign(v.begin(), v.end());
      },
      a.values);
  return out;
}

}  // namespace detail

/// @brief Reads and checks a `.vtp` file written by lsdem.
inline VtpFile readVtp(const std::string& path) {
  const io::VtpPiece piece = io::readVtp(path);
  const std::string text = readText(path);
  VtpFile f;
  f.points = piece.pointCount();
  f.verts = piece.verts.size();
  f.lines = piece.lines.size();
  f.polys = piece.polys.size();
  f.coordinates = piece.points;
  f.vertCells = {piece.verts.connectivity, piece.verts.offsets};
  f.lineCells = {piece.lines.connectivity, piece.lines.offsets};
  f.polyCells = {piece.polys.connectivity, piece.polys.offsets};
  for (const io::VtkArray& a : piece.pointData) f.pointData.emplace(a.name, detail::toArray(a, text));
  for (const io::VtkArray& a : piece.cellData) f.cellData.emplace(a.name, detail::toArray(a, text));
  return f;
}

/// One entry of a `.pvd` collection.
struct PvdEntry {
  double time = 0.0;
  std::string file;
};

/// @brief Reads and checks a `.pvd` collection.
inline std::vector<PvdEntry> readPvd(const std::string& path) {
  std::vector<PvdEntry> entries;
  for (const auto& e : io::readPvd(path)) entries.push_back({e.time, e.file});
  return entries;
}

}  // namespace lsdem::test
