#include "lsdem/io/VolumeFile.h"

#include "NumberText.h"

#include "lsdem/io/InputError.h"

#include <tiffio.h>
#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fnmatch.h>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace lsdem::io {

namespace fs = std::filesystem;
using geometry::Index;
using geometry::LabelVolume;
using geometry::Vec;

std::size_t voxelBytes(VoxelType type) {
  switch (type) {
    case VoxelType::UInt8:
    case VoxelType::Int8:
      return 1;
    case VoxelType::UInt16:
    case VoxelType::Int16:
      return 2;
    case VoxelType::UInt32:
    case VoxelType::Int32:
      return 4;
  }
  return 1;
}

std::optional<VoxelType> voxelTypeNamed(const std::string& name) {
  if (name == "uint8") return VoxelType::UInt8;
  if (name == "uint16") return VoxelType::UInt16;
  if (name == "uint32") return VoxelType::UInt32;
  if (name == "int8") return VoxelType::Int8;
  if (name == "int16") return VoxelType::Int16;
  if (name == "int32") return VoxelType::Int32;
  return std::nullopt;
}

namespace {

bool isSigned(VoxelType t) { return t == VoxelType::Int8 || t == VoxelType::Int16 || t == VoxelType::Int32; }

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string trim(const std::string& s) {
  std::size_t a = 0, b = s.size();
  while (a < b && std::isspace(static_cast<unsigned char>(s[a]))) ++a;
  while (b > a && std::isspace(static_cast<unsigned char>(s[b - 1]))) --b;
  return s.substr(a, b - a);
}

std::string megabytes(double bytes) {
  char buf[32];
  const double mb = bytes / 1048576.0;
  std::snprintf(buf, sizeof buf, mb >= 100.0 ? "%.0f MB" : "%.3g MB", mb);
  return buf;
}

// The voxel count of `dims`, refused (before anything is allocated) when a
// dimension is not positive or the labels and a decoding buffer of
// `fileBytesPerVoxel` would pass the cap.
std::size_t checkedVoxelCount(const std::string& file, const Index<3>& dims, std::size_t fileBytesPerVoxel,
                              const VolumeReadOptions& options) {
  if ((dims < 1).any()) {
    throw InputError(file, 0, "",
                     "volume size " + std::to_string(dims[0]) + " x " + std::to_string(dims[1]) + " x " +
                         std::to_string(dims[2]) + " is empty");
  }
  const double count = double(dims[0]) * double(dims[1]) * double(dims[2]);
  const double bytes = count * double(4 + fileBytesPerVoxel);
  if (bytes > double(options.maxBytes)) {
    throw InputError(file, 0, "",
                     "volume of " + std::to_string(dims[0]) + " x " + std::to_string(dims[1]) + " x " +
                         std::to_string(dims[2]) + " voxels needs " + megabytes(bytes) + " to read, over the cap of " +
                         megabytes(double(options.maxBytes)) + " (--max-memory)");
  }
  return std::size_t(dims[0]) * std::size_t(dims[1]) * std::size_t(dims[2]);
}

// Decodes `count` voxels of `type` from `bytes` into labels; a negative
// signed value is refused with its voxel index.
void decodeVoxels(const std::string& file, const unsigned char* bytes, std::size_t count, VoxelType type,
                  bool bigEndian, const Index<3>& dims, std::vector<std::uint32_t>& labels) {
  const std::size_t b = voxelBytes(type);
  labels.resize(count);
  for (std::size_t v = 0; v < count; ++v) {
    const unsigned char* p = bytes + v * b;
    std::uint32_t u = 0;
    for (std::size_t i = 0; i < b; ++i) {
      const std::size_t byte = bigEndian ? b - 1 - i : i;
      u |= std::uint32_t(p[byte]) << (8 * i);
    }
    if (isSigned(type) && (u >> (8 * b - 1)) != 0) {
      const std::size_t nx = std::size_t(dims[0]), ny = std::size_t(dims[1]);
      const long long value = (long long)u - (1LL << (8 * b));
      throw InputError(file, 0, "",
                       "voxel (" + std::to_string(v % nx) + ", " + std::to_string(v / nx % ny) + ", " +
                           std::to_string(v / (nx * ny)) + ") holds the negative label " + std::to_string(value) +
                           "; labels must be >= 0");
    }
    labels[v] = u;
  }
}

std::uintmax_t fileSize(const std::string& file) {
  std::error_code ec;
  const std::uintmax_t size = fs::file_size(file, ec);
  if (ec) throw InputError(file, 0, "", "cannot read: " + ec.message());
  return size;
}

// Reads `length` bytes at `offset` of a file.
std::vector<unsigned char> readBytes(const std::string& file, std::uintmax_t offset, std::size_t length) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw InputError(file, 0, "", "cannot open");
  std::vector<unsigned char> data(length);
  in.seekg(std::streamoff(offset));
  in.read(reinterpret_cast<char*>(data.data()), std::streamsize(length));
  if (std::size_t(in.gcount()) != length) {
    throw InputError(
        file, 0, "",
        "truncated: expected " + std::to_string(length) + " bytes of voxels, read " + std::to_string(in.gcount()));
  }
  return data;
}

// Inflates a gzip (or zlib) stream into exactly `expected` bytes.
std::vector<unsigned char> inflateExactly(const std::string& file, const std::vector<unsigned char>& compressed,
                                          std::size_t expected) {
  std::vector<unsigned char> out(expected);
  z_stream z{};
  if (inflateInit2(&z, 15 + 32) != Z_OK) throw std::runtime_error("zlib: inflateInit2 failed");
  z.next_in = const_cast<unsigned char*>(compressed.data());
  std::size_t inLeft = compressed.size(), outDone = 0;
  int rc = Z_OK;
  // zlib counts in 32-bit units: feed and drain in chunks.
  while (rc == Z_OK) {
    const uInt inChunk = uInt(std::min<std::size_t>(inLeft, 1u << 30));
    const uInt outChunk = uInt(std::min<std::size_t>(expected - outDone, 1u << 30));
    if (outChunk == 0) {
      // Every expected byte is out; the stream must end here.
      unsigned char probe;
      z.next_out = &probe;
      z.avail_out = 1;
      z.avail_in = inChunk;
      rc = inflate(&z, Z_NO_FLUSH);
      inLeft -= inChunk - z.avail_in;
      if (rc == Z_OK && z.avail_out == 0) {
        inflateEnd(&z);
        throw InputError(
            file, 0, "",
            "gzip data holds more than the " + std::to_string(expected) + " bytes the header's sizes and type give");
      }
      break;
    }
    z.next_out = out.data() + outDone;
    z.avail_out = outChunk;
    z.avail_in = inChunk;
    rc = inflate(&z, Z_NO_FLUSH);
    inLeft -= inChunk - z.avail_in;
    outDone += outChunk - z.avail_out;
    if (rc == Z_BUF_ERROR && inLeft == 0) break;  // input ran out
    if (rc == Z_BUF_ERROR) rc = Z_OK;
  }
  inflateEnd(&z);
  if (rc != Z_STREAM_END && rc != Z_OK && rc != Z_BUF_ERROR) {
    throw InputError(file, 0, "", std::string("gzip data is corrupt (") + (z.msg ? z.msg : "zlib error") + ")");
  }
  if (outDone < expected) {
    throw InputError(file, 0, "",
                     "truncated: gzip data holds " + std::to_string(outDone) +
                         " bytes, the header's sizes and type give " + std::to_string(expected));
  }
  if (rc != Z_STREAM_END) throw InputError(file, 0, "", "truncated: gzip stream does not end");
  return out;
}

// ---- NRRD ----------------------------------------------------------------------

std::optional<VoxelType> nrrdType(const std::string& name) {
  const std::string t = lower(trim(name));
  if (t == "uchar" || t == "unsigned char" || t == "uint8" || t == "uint8_t") return VoxelType::UInt8;
  if (t == "signed char" || t == "int8" || t == "int8_t") return VoxelType::Int8;
  if (t == "ushort" || t == "unsigned short" || t == "unsigned short int" || t == "uint16" || t == "uint16_t") {
    return VoxelType::UInt16;
  }
  if (t == "short" || t == "short int" || t == "signed short" || t == "signed short int" || t == "int16" ||
      t == "int16_t") {
    return VoxelType::Int16;
  }
  if (t == "uint" || t == "unsigned int" || t == "uint32" || t == "uint32_t") return VoxelType::UInt32;
  if (t == "int" || t == "signed int" || t == "int32" || t == "int32_t") return VoxelType::Int32;
  return std::nullopt;
}

// Numbers of a field ("sizes: 10 20 30"); each must parse.
std::vector<double> numbers(const std::string& file, int line, const std::string& key, const std::string& text) {
  std::istringstream in(text);
  std::vector<double> out;
  std::string word;
  while (in >> word) {
    char* end = nullptr;
    const double v = std::strtod(word.c_str(), &end);
    if (end == word.c_str() || *end != '\0') throw InputError(file, line, key, "'" + word + "' is not a number");
    out.push_back(v);
  }
  return out;
}

// Vectors of a field ("(1,0,0) (0,1,0) (0,0,1)"); "none" gives an empty one.
std::vector<std::vector<double>> vectors(const std::string& file, int line, const std::string& key,
                                         const std::string& text) {
  std::vector<std::vector<double>> out;
  std::size_t i = 0;
  while (true) {
    while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    if (i >= text.size()) break;
    if (text.compare(i, 4, "none") == 0) {
      out.emplace_back();
      i += 4;
      continue;
    }
    if (text[i] != '(') throw InputError(file, line, key, "expected a vector '(x,y,z)' or 'none'");
    const std::size_t close = text.find(')', i);
    if (close == std::string::npos) throw InputError(file, line, key, "vector without ')'");
    std::string inner = text.substr(i + 1, close - i - 1);
    std::replace(inner.begin(), inner.end(), ',', ' ');
    out.push_back(numbers(file, line, key, inner));
    i = close + 1;
  }
  return out;
}

VolumeRead readNrrd(const std::string& file, const VolumeReadOptions& options) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw InputError(file, 0, "", "cannot open");
  std::string line;
  if (!std::getline(in, line) || line.rfind("NRRD000", 0) != 0) {
    throw InputError(file, 1, "", "not a NRRD file (no 'NRRD000X' magic)");
  }

  // The header: "key: value" lines up to a blank line (or the end of a detached header).
  std::optional<VoxelType> type;
  std::string typeName, encoding = "", endian, dataFile, units;
  int dimension = 0, lineNo = 1, keyLine[8] = {};
  long long byteSkip = 0, lineSkip = 0;
  std::vector<double> sizes, spacings;
  std::vector<std::vector<double>> directions;
  std::vector<double> origin;
  bool ended = false;
  std::map<std::string, int> seenAt;  // each field's line
  while (std::getline(in, line)) {
    ++lineNo;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) {
      ended = true;
      break;
    }
    if (line[0] == '#') continue;
    if (line.find(":=") != std::string::npos && line.find(":=") < line.find(": ")) continue;  // key/value pair
    const std::size_t colon = line.find(": ");
    if (colon == std::string::npos) throw InputError(file, lineNo, "", "header line is not 'field: value'");
    const std::string key = lower(trim(line.substr(0, colon)));
    const std::string value = trim(line.substr(colon + 2));
    // (A field given twice was read as its last: "type" twice then asked
    // for an endian the first did not need.)
    if (const auto [at, added] = seenAt.try_emplace(key == "datafile" ? "data file" : key, lineNo); !added) {
      throw InputError(file, lineNo, key, "given twice (first on line " + std::to_string(at->second) + ")");
    }
    if (key == "type") {
      typeName = value;
      type = nrrdType(value);
      if (!type) {
        throw InputError(
            file, lineNo, key,
            "unsupported type '" + value + "': labels must be 8, 16 or 32-bit integers (uchar, ushort, uint, ...)");
      }
    } else if (key == "dimension") {
      const std::vector<double> d = numbers(file, lineNo, key, value);
      if (d.size() != 1 || d[0] != 3.0)
        throw InputError(file, lineNo, key, "must be 3 (a 3D volume), got '" + value + "'");
      dimension = 3;
    } else if (key == "sizes") {
      sizes = numbers(file, lineNo, key, value);
      keyLine[0] = lineNo;
    } else if (key == "spacings") {
      spacings = numbers(file, lineNo, key, value);
      keyLine[1] = lineNo;
    } else if (key == "space directions") {
      directions = vectors(file, lineNo, key, value);
      keyLine[2] = lineNo;
    } else if (key == "space origin") {
      const auto v = vectors(file, lineNo, key, value);
      if (v.size() != 1 || v[0].size() != 3) throw InputError(file, lineNo, key, "must be one vector (x,y,z)");
      origin = v[0];
      keyLine[3] = lineNo;
    } else if (key == "encoding") {
      encoding = lower(value);
      if (encoding != "raw" && encoding != "gzip" && encoding != "gz") {
        throw InputError(file, lineNo, key, "unsupported encoding '" + value + "' (raw and gzip are read)");
      }
    } else if (key == "endian") {
      endian = lower(value);
      if (endian != "little" && endian != "big") throw InputError(file, lineNo, key, "must be little or big");
    } else if (key == "data file" || key == "datafile") {
      dataFile = value;
      if (dataFile.rfind("LIST", 0) == 0 || dataFile.find('%') != std::string::npos) {
        throw InputError(file, lineNo, key, "only a single data file is supported");
      }
    } else if (key == "byte skip") {
      const auto v = numbers(file, lineNo, key, value);
      if (v.size() != 1 || v[0] < -1 || v[0] != std::floor(v[0]))
        throw InputError(file, lineNo, key, "must be -1 or >= 0");
      byteSkip = (long long)v[0];
    } else if (key == "line skip") {
      const auto v = numbers(file, lineNo, key, value);
      if (v.size() != 1 || v[0] < 0 || v[0] != std::floor(v[0])) throw InputError(file, lineNo, key, "must be >= 0");
      lineSkip = (long long)v[0];
    } else if (key == "space units") {
      // Quoted names, one per axis: "mm" "mm" "mm".
      std::vector<std::string> names;
      for (std::size_t q = value.find('"'); q != std::string::npos; q = value.find('"', q + 1)) {
        const std::size_t close = value.find('"', q + 1);
        if (close == std::string::npos) throw InputError(file, lineNo, key, "unterminated quoted unit");
        names.push_back(value.substr(q + 1, close - q - 1));
        q = close;
      }
      if (names.size() != 3) throw InputError(file, lineNo, key, "must name 3 quoted units");
      if (names[1] != names[0] || names[2] != names[0]) {
        throw InputError(file, lineNo, key, "axes in different units are not supported");
      }
      units = names[0];
    } else if (key == "space") {
      // Named spaces (left-posterior-superior, ...) are 3D; their axes are used as given.
    } else if (key == "space dimension") {
      const auto v = numbers(file, lineNo, key, value);
      if (v.size() != 1 || v[0] != 3.0) throw InputError(file, lineNo, key, "must be 3");
    }
    // Other fields (kinds, units, labels, centers, content, ...) do not change the voxels.
  }
  const std::uintmax_t headerEnd = ended ? std::uintmax_t(in.tellg()) : fileSize(file);

  // The required fields and their agreement.
  if (!type) throw InputError(file, 0, "type", "missing");
  if (dimension != 3) throw InputError(file, 0, "dimension", "missing");
  if (encoding.empty()) throw InputError(file, 0, "encoding", "missing");
  if (sizes.size() != 3) throw InputError(file, keyLine[0], "sizes", "must give 3 sizes");
  Index<3> dims;
  for (int a = 0; a < 3; ++a) {
    if (!(sizes[std::size_t(a)] >= 1.0) || sizes[std::size_t(a)] != std::floor(sizes[std::size_t(a)]) ||
        sizes[std::size_t(a)] > 1e9) {
      throw InputError(file, keyLine[0], "sizes",
                       "must be whole numbers from 1 to 1e9 (voxels per axis), got '" + numberText(sizes[std::size_t(a)]) +
                           "'");
    }
    dims[a] = int(sizes[std::size_t(a)]);
  }
  const std::size_t b = voxelBytes(*type);
  if (b > 1 && endian.empty()) throw InputError(file, 0, "endian", "missing (needed for " + typeName + " data)");

  VolumeRead r;
  r.format = "nrrd";
  r.volume.dims = dims;
  r.units = units;
  if (!spacings.empty() && !directions.empty()) {
    throw InputError(file, keyLine[1], "spacings", "give either spacings or space directions, not both");
  }
  if (!spacings.empty()) {
    if (spacings.size() != 3) throw InputError(file, keyLine[1], "spacings", "must give 3 spacings");
    for (int a = 0; a < 3; ++a) r.volume.spacing[a] = spacings[std::size_t(a)];
    r.hasSpacing = true;
  }
  if (!directions.empty()) {
    if (directions.size() != 3) throw InputError(file, keyLine[2], "space directions", "must give 3 vectors");
    for (int a = 0; a < 3; ++a) {
      const std::vector<double>& d = directions[std::size_t(a)];
      if (d.size() != 3) throw InputError(file, keyLine[2], "space directions", "every axis needs a vector (x,y,z)");
      for (int c = 0; c < 3; ++c) {
        if (c != a && d[std::size_t(c)] != 0.0) {
          throw InputError(
              file, keyLine[2], "space directions",
              "axes are not along x, y, z (a rotated or sheared scan); resample it to axis-aligned voxels");
        }
      }
      r.volume.spacing[a] = std::abs(d[std::size_t(a)]);
      if (d[std::size_t(a)] < 0.0) {
        throw InputError(file, keyLine[2], "space directions",
                         "axis " + std::to_string(a) + " points backwards; flip the volume to positive directions");
      }
    }
    r.hasSpacing = true;
  }
  if (r.hasSpacing && (!(r.volume.spacing.array() > 0.0).all() || !r.volume.spacing.allFinite())) {
    throw InputError(file, keyLine[spacings.empty() ? 2 : 1], spacings.empty() ? "space directions" : "spacings",
                     "voxel spacings must be positive");
  }
  if (!origin.empty()) {
    for (int a = 0; a < 3; ++a) r.volume.origin[a] = origin[std::size_t(a)];
    if (!r.volume.origin.allFinite()) throw InputError(file, keyLine[3], "space origin", "must be finite");
    r.hasOrigin = true;
  }

  // The data: in this file after the header, or in the data file beside it.
  std::string dataPath = file;
  std::uintmax_t offset = headerEnd;
  if (!dataFile.empty()) {
    dataPath = (fs::path(file).parent_path() / dataFile).string();
    offset = 0;
    if (!fs::is_regular_file(dataPath)) throw InputError(file, 0, "data file", "no such file '" + dataPath + "'");
  } else if (!ended) {
    throw InputError(file, lineNo, "", "header does not end with a blank line before the data");
  }
  const std::size_t count = checkedVoxelCount(file, dims, b, options);
  const std::size_t expected = count * b;
  const std::uintmax_t total = fileSize(dataPath);
  if (lineSkip > 0) {
    std::ifstream data(dataPath, std::ios::binary);
    data.seekg(std::streamoff(offset));
    for (long long i = 0; i < lineSkip; ++i) {
      if (!std::getline(data, line)) throw InputError(dataPath, 0, "", "fewer lines than 'line skip'");
    }
    offset = std::uintmax_t(data.tellg());
  }
  std::vector<unsigned char> bytes;
  if (encoding == "raw") {
    if (byteSkip == -1) {
      if (total < offset + expected) {
        throw InputError(dataPath, 0, "",
                         "truncated: holds " + std::to_string(total - std::min(total, offset)) +
                             " bytes of data, the header's sizes and type give " + std::to_string(expected));
      }
      offset = total - expected;
    } else {
      offset += std::uintmax_t(byteSkip);
    }
    const std::uintmax_t have = total > offset ? total - offset : 0;
    if (have != expected) {
      throw InputError(dataPath, 0, "",
                       std::string(have < expected ? "truncated" : "inconsistent") + ": holds " + std::to_string(have) +
                           " bytes of data, the header's sizes " + std::to_string(dims[0]) + " x " +
                           std::to_string(dims[1]) + " x " + std::to_string(dims[2]) + " of " + typeName + " give " +
                           std::to_string(expected));
    }
    bytes = readBytes(dataPath, offset, expected);
  } else {
    if (byteSkip != 0) throw InputError(file, 0, "byte skip", "not supported with gzip encoding");
    if (total <= offset) throw InputError(dataPath, 0, "", "truncated: no gzip data after the header");
    const std::vector<unsigned char> compressed = readBytes(dataPath, offset, std::size_t(total - offset));
    bytes = inflateExactly(dataPath, compressed, expected);
  }
  decodeVoxels(dataPath, bytes.data(), count, *type, endian == "big", dims, r.volume.labels);
  return r;
}

// ---- raw -------------------------------------------------------------------------

VolumeRead readRaw(const std::string& file, const RawLayout& layout, const VolumeReadOptions& options) {
  const std::size_t b = voxelBytes(layout.type);
  const std::size_t count = checkedVoxelCount(file, layout.dims, b, options);
  const std::uintmax_t total = fileSize(file);
  const std::uintmax_t expected = std::uintmax_t(count) * b + layout.headerBytes;
  if (total != expected) {
    throw InputError(file, 0, "",
                     std::string(total < expected ? "truncated" : "inconsistent") + ": holds " + std::to_string(total) +
                         " bytes, " + std::to_string(layout.headerBytes) + " header bytes and " +
                         std::to_string(layout.dims[0]) + " x " + std::to_string(layout.dims[1]) + " x " +
                         std::to_string(layout.dims[2]) + " voxels of " + std::to_string(b) + " bytes give " +
                         std::to_string(expected));
  }
  VolumeRead r;
  r.format = "raw";
  r.volume.dims = layout.dims;
  const std::vector<unsigned char> bytes = readBytes(file, layout.headerBytes, count * b);
  decodeVoxels(file, bytes.data(), count, layout.type, layout.bigEndian, layout.dims, r.volume.labels);
  return r;
}

// ---- TIFF ------------------------------------------------------------------------

// libtiff reports through handlers: the last error is kept for the
// InputError, warnings (unknown tags and such) are dropped.
thread_local std::string tiffLastError;

void tiffError(const char* module, const char* fmt, va_list ap) {
  char buf[512];
  std::vsnprintf(buf, sizeof buf, fmt, ap);
  tiffLastError = (module ? std::string(module) + ": " : std::string()) + buf;
}
void tiffWarning(const char*, const char*, va_list) {}

struct TiffCloser {
  void operator()(TIFF* t) const { TIFFClose(t); }
};
using TiffPtr = std::unique_ptr<TIFF, TiffCloser>;

TiffPtr openTiff(const std::string& file, const char* mode) {
  TIFFSetErrorHandler(tiffError);
  TIFFSetWarningHandler(tiffWarning);
  tiffLastError.clear();
  TIFF* t = TIFFOpen(file.c_str(), mode);
  if (!t) {
    throw InputError(file, 0, "", "cannot open as TIFF" + (tiffLastError.empty() ? "" : " (" + tiffLastError + ")"));
  }
  return TiffPtr(t);
}

std::string tiffWhere(int page) { return "page " + std::to_string(page + 1); }

// The size and voxel type of the current page.
struct TiffPage {
  int width = 0, height = 0;
  VoxelType type = VoxelType::UInt8;
};

TiffPage tiffPage(TIFF* t, const std::string& file, int page) {
  std::uint32_t w = 0, h = 0;
  std::uint16_t bits = 1, samples = 1, format = SAMPLEFORMAT_UINT;
  TIFFGetField(t, TIFFTAG_IMAGEWIDTH, &w);
  TIFFGetField(t, TIFFTAG_IMAGELENGTH, &h);
  TIFFGetFieldDefaulted(t, TIFFTAG_BITSPERSAMPLE, &bits);
  TIFFGetFieldDefaulted(t, TIFFTAG_SAMPLESPERPIXEL, &samples);
  TIFFGetFieldDefaulted(t, TIFFTAG_SAMPLEFORMAT, &format);
  const std::string where = tiffWhere(page);
  if (w == 0 || h == 0 || w > 1u << 30 || h > 1u << 30) {
    throw InputError(file, 0, where, "image size " + std::to_string(w) + " x " + std::to_string(h) + " is not usable");
  }
  if (samples != 1) {
    throw InputError(file, 0, where,
                     std::to_string(samples) + " samples per pixel: a label image has one (grey, not colour)");
  }
  if (format != SAMPLEFORMAT_UINT && format != SAMPLEFORMAT_INT) {
    throw InputError(file, 0, where,
                     "pixels are not integers (sample format " + std::to_string(format) +
                         "): labels must be 8, 16 or 32-bit integers");
  }
  TiffPage p;
  p.width = int(w);
  p.height = int(h);
  const bool s = format == SAMPLEFORMAT_INT;
  switch (bits) {
    case 8:
      p.type = s ? VoxelType::Int8 : VoxelType::UInt8;
      break;
    case 16:
      p.type = s ? VoxelType::Int16 : VoxelType::UInt16;
      break;
    case 32:
      p.type = s ? VoxelType::Int32 : VoxelType::UInt32;
      break;
    default:
      throw InputError(file, 0, where,
                       "unsupported " + std::to_string(bits) + "-bit pixels: labels must be 8, 16 or 32-bit");
  }
  return p;
}

// Reads the current page into slice z of `labels` (width x height labels).
void readTiffPage(TIFF* t, const std::string& file, int page, const TiffPage& p, const Index<3>& dims, int z,
                  std::vector<std::uint32_t>& labels) {
  const std::string where = tiffWhere(page);
  const std::size_t b = voxelBytes(p.type);
  // libtiff hands samples over in the host's byte order.
  const bool hostBig = [] {
    const std::uint16_t one = 1;
    unsigned char c;
    std::memcpy(&c, &one, 1);
    return c == 0;
  }();
  std::vector<std::uint32_t> row;
  const std::size_t sliceOffset = std::size_t(z) * std::size_t(dims[0]) * std::size_t(dims[1]);
  auto store = [&](const unsigned char* bytes, int x0, int y, int n) {
    Index<3> d(n, 1, 1);
    decodeVoxels(file, bytes, std::size_t(n), p.type, hostBig, d, row);
    std::copy(row.begin(), row.end(),
              labels.begin() + std::ptrdiff_t(sliceOffset + std::size_t(y) * std::size_t(dims[0]) + std::size_t(x0)));
  };
  tiffLastError.clear();
  if (TIFFIsTiled(t)) {
    std::uint32_t tw = 0, th = 0;
    TIFFGetField(t, TIFFTAG_TILEWIDTH, &tw);
    TIFFGetField(t, TIFFTAG_TILELENGTH, &th);
    if (tw == 0 || th == 0) throw InputError(file, 0, where, "tiled image without a tile size");
    std::vector<unsigned char> tile(std::size_t(TIFFTileSize(t)));
    if (tile.size() < std::size_t(tw) * th * b) throw InputError(file, 0, where, "tile size is inconsistent");
    for (std::uint32_t y0 = 0; y0 < std::uint32_t(p.height); y0 += th) {
      for (std::uint32_t x0 = 0; x0 < std::uint32_t(p.width); x0 += tw) {
        if (TIFFReadTile(t, tile.data(), x0, y0, 0, 0) < 0) {
          throw InputError(file, 0, where,
                           "cannot read a tile" + (tiffLastError.empty() ? "" : " (" + tiffLastError + ")"));
        }
        const int n = int(std::min<std::uint32_t>(tw, std::uint32_t(p.width) - x0));
        for (std::uint32_t y = y0; y < std::min<std::uint32_t>(y0 + th, std::uint32_t(p.height)); ++y) {
          store(tile.data() + std::size_t(y - y0) * tw * b, int(x0), int(y), n);
        }
      }
    }
  } else {
    const tmsize_t lineBytes = TIFFScanlineSize(t);
    if (lineBytes < tmsize_t(std::size_t(p.width) * b))
      throw InputError(file, 0, where, "scanline size is inconsistent");
    std::vector<unsigned char> line(static_cast<std::size_t>(lineBytes));
    for (int y = 0; y < p.height; ++y) {
      if (TIFFReadScanline(t, line.data(), std::uint32_t(y), 0) < 0) {
        throw InputError(file, 0, where,
                         "truncated or corrupt at row " + std::to_string(y) +
                             (tiffLastError.empty() ? "" : " (" + tiffLastError + ")"));
      }
      store(line.data(), 0, y, p.width);
    }
  }
}

VolumeRead readTiffStack(const std::string& file, const VolumeReadOptions& options) {
  TiffPtr t = openTiff(file, "r");
  tiffLastError.clear();
  const int pages = int(TIFFNumberOfDirectories(t.get()));
  // A page's directory past the end of the file (a partial copy) ends the
  // chain early: libtiff says so, and counts the pages before it.
  if (!tiffLastError.empty()) {
    throw InputError(file, 0, tiffWhere(pages),
                     "truncated or corrupt: the chain of pages breaks after page " + std::to_string(pages) + " (" +
                         tiffLastError + ")");
  }
  if (pages < 1) throw InputError(file, 0, "", "TIFF holds no image");
  TIFFSetDirectory(t.get(), 0);
  const TiffPage first = tiffPage(t.get(), file, 0);
  VolumeRead r;
  r.format = "tiff";
  r.volume.dims = Index<3>(first.width, first.height, pages);
  const std::size_t count = checkedVoxelCount(file, r.volume.dims, 0, options);
  r.volume.labels.resize(count);
  for (int z = 0; z < pages; ++z) {
    if (!TIFFSetDirectory(t.get(), tdir_t(z))) throw InputError(file, 0, tiffWhere(z), "cannot read the page");
    const TiffPage p = tiffPage(t.get(), file, z);
    if (p.width != first.width || p.height != first.height) {
      throw InputError(file, 0, tiffWhere(z),
                       "is " + std::to_string(p.width) + " x " + std::to_string(p.height) + " pixels, page 1 is " +
                           std::to_string(first.width) + " x " + std::to_string(first.height));
    }
    readTiffPage(t.get(), file, z, p, r.volume.dims, z, r.volume.labels);
  }
  return r;
}

// Natural order of file names: digit runs compare as numbers (slice2 < slice10).
bool naturalLess(const std::string& a, const std::string& b) {
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (std::isdigit(static_cast<unsigned char>(a[i])) && std::isdigit(static_cast<unsigned char>(b[j]))) {
      std::size_t ie = i, je = j;
      while (ie < a.size() && std::isdigit(static_cast<unsigned char>(a[ie]))) ++ie;
      while (je < b.size() && std::isdigit(static_cast<unsigned char>(b[je]))) ++je;
      std::string da = a.substr(i, ie - i), db = b.substr(j, je - j);
      da.erase(0, std::min(da.find_first_not_of('0'), da.size()));
      db.erase(0, std::min(db.find_first_not_of('0'), db.size()));
      if (da.size() != db.size()) return da.size() < db.size();
      if (da != db) return da < db;
      i = ie;
      j = je;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i;
      ++j;
    }
  }
  if (a.size() - i != b.size() - j) return a.size() - i < b.size() - j;
  return a < b;
}

VolumeRead readTiffSlices(const std::string& path, const VolumeReadOptions& options) {
  // The slice files: every *.tif / *.tiff of a folder, or the names matching a pattern.
  fs::path dir = path;
  std::string pattern;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    dir = fs::path(path).parent_path();
    if (dir.empty()) dir = ".";
    pattern = fs::path(path).filename().string();
    if (!fs::is_directory(dir, ec)) throw InputError(path, 0, "", "no such folder '" + dir.string() + "'");
  }
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (!e.is_regular_file()) continue;
    const std::string name = e.path().filename().string();
    if (pattern.empty()) {
      const std::string ext = lower(e.path().extension().string());
      if (ext == ".tif" || ext == ".tiff") names.push_back(name);
    } else if (fnmatch(pattern.c_str(), name.c_str(), 0) == 0) {
      names.push_back(name);
    }
  }
  if (ec) throw InputError(path, 0, "", "cannot list the folder: " + ec.message());
  if (names.empty())
    throw InputError(path, 0, "",
                     pattern.empty() ? "folder holds no .tif or .tiff slice" : "no file matches the pattern");
  std::sort(names.begin(), names.end(), naturalLess);

  VolumeRead r;
  r.format = "tiff slices";
  r.files = int(names.size());
  TiffPage first;
  for (std::size_t z = 0; z < names.size(); ++z) {
    const std::string file = (dir / names[z]).string();
    TiffPtr t = openTiff(file, "r");
    const TiffPage p = tiffPage(t.get(), file, 0);
    if (z == 0) {
      first = p;
      r.volume.dims = Index<3>(p.width, p.height, int(names.size()));
      r.volume.labels.resize(checkedVoxelCount(path, r.volume.dims, 0, options));
    } else if (p.width != first.width || p.height != first.height) {
      throw InputError(file, 0, "",
                       "slice is " + std::to_string(p.width) + " x " + std::to_string(p.height) +
                           " pixels, the first (" + names[0] + ") is " + std::to_string(first.width) + " x " +
                           std::to_string(first.height));
    }
    if (TIFFNumberOfDirectories(t.get()) != 1) {
      throw InputError(file, 0, "",
                       "a slice file holds one page, this one " + std::to_string(TIFFNumberOfDirectories(t.get())));
    }
    readTiffPage(t.get(), file, 0, p, r.volume.dims, int(z), r.volume.labels);
  }
  return r;
}

// ---- writers -------------------------------------------------------------------------

std::uint32_t largestFor(VoxelType type) {
  switch (type) {
    case VoxelType::UInt8:
      return 0xFFu;
    case VoxelType::UInt16:
      return 0xFFFFu;
    case VoxelType::UInt32:
      return 0xFFFFFFFFu;
    case VoxelType::Int8:
      return 0x7Fu;
    case VoxelType::Int16:
      return 0x7FFFu;
    case VoxelType::Int32:
      return 0x7FFFFFFFu;
  }
  return 0;
}

// The labels as little-endian bytes of `type` (or host order, for libtiff).
std::vector<unsigned char> encodeVoxels(const std::string& path, const std::vector<std::uint32_t>& labels,
                                        std::size_t first, std::size_t count, VoxelType type, bool bigEndian) {
  const std::size_t b = voxelBytes(type);
  std::vector<unsigned char> out(count * b);
  for (std::size_t v = 0; v < count; ++v) {
    const std::uint32_t u = labels[first + v];
    if (u > largestFor(type)) {
      throw std::runtime_error("cannot write '" + path + "': label " + std::to_string(u) +
                               " does not fit the voxel type");
    }
    for (std::size_t i = 0; i < b; ++i) out[v * b + (bigEndian ? b - 1 - i : i)] = (unsigned char)(u >> (8 * i));
  }
  return out;
}

const char* nrrdTypeName(VoxelType type) {
  switch (type) {
    case VoxelType::UInt8:
      return "uint8";
    case VoxelType::UInt16:
      return "uint16";
    case VoxelType::UInt32:
      return "uint32";
    case VoxelType::Int8:
      return "int8";
    case VoxelType::Int16:
      return "int16";
    case VoxelType::Int32:
      return "int32";
  }
  return "uint8";
}

}  // namespace

VolumeRead readLabelVolume(const std::string& path, const VolumeReadOptions& options) {
  std::error_code ec;
  if (options.raw) {
    if (!fs::is_regular_file(path, ec)) throw InputError(path, 0, "", "no such file");
    return readRaw(path, *options.raw, options);
  }
  const std::string name = fs::path(path).filename().string();
  if (fs::is_directory(path, ec) || name.find_first_of("*?") != std::string::npos) return readTiffSlices(path, options);
  if (!fs::is_regular_file(path, ec)) throw InputError(path, 0, "", "no such file or folder");
  const std::string ext = lower(fs::path(path).extension().string());
  if (ext == ".nrrd" || ext == ".nhdr") return readNrrd(path, options);
  if (ext == ".tif" || ext == ".tiff") return readTiffStack(path, options);
  // Else by the first bytes.
  std::ifstream in(path, std::ios::binary);
  char magic[4] = {};
  in.read(magic, 4);
  if (in.gcount() == 4 && std::memcmp(magic, "NRRD", 4) == 0) return readNrrd(path, options);
  if (in.gcount() == 4 && (std::memcmp(magic, "II*\0", 4) == 0 || std::memcmp(magic, "MM\0*", 4) == 0 ||
                           std::memcmp(magic, "II+\0", 4) == 0 || std::memcmp(magic, "MM\0+", 4) == 0)) {
    return readTiffStack(path, options);
  }
  throw InputError(path, 0, "",
                   "unknown volume format (NRRD .nrrd/.nhdr, TIFF .tif/.tiff, a folder of TIFF slices, "
                   "or raw with --raw-dims)");
}

void writeNrrd(const std::string& path, const LabelVolume& volume, VoxelType type, bool gzip) {
  const std::size_t count = volume.voxelCount();
  if (volume.labels.size() != count) throw std::runtime_error("cannot write '" + path + "': labels do not match dims");
  std::vector<unsigned char> data = encodeVoxels(path, volume.labels, 0, count, type, false);
  // Header: one field per line, then a blank line.
  std::ostringstream h;
  h.precision(17);
  h << "NRRD0004\n# written by lsdem\ntype: " << nrrdTypeName(type) << "\ndimension: 3\nspace: 3D-right-handed\n"
    << "sizes: " << volume.dims[0] << ' ' << volume.dims[1] << ' ' << volume.dims[2] << "\nspace directions: ("
    << volume.spacing[0] << ",0,0) (0," << volume.spacing[1] << ",0) (0,0," << volume.spacing[2] << ")\n"
    << "kinds: domain domain domain\nendian: little\nencoding: " << (gzip ? "gzip" : "raw") << "\nspace origin: ("
    << volume.origin[0] << ',' << volume.origin[1] << ',' << volume.origin[2] << ")\n\n";
  if (gzip) {
    // A gzip stream (windowBits 15 + 16).
    z_stream z{};
    if (deflateInit2(&z, 9, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK) {
      throw std::runtime_error("zlib: deflateInit2 failed");
    }
    std::vector<unsigned char> out(deflateBound(&z, uLong(data.size())) + 64);
    z.next_in = data.data();
    z.avail_in = uInt(data.size());
    z.next_out = out.data();
    z.avail_out = uInt(out.size());
    const int rc = deflate(&z, Z_FINISH);
    out.resize(z.total_out);
    deflateEnd(&z);
    if (rc != Z_STREAM_END) throw std::runtime_error("cannot write '" + path + "': zlib deflate failed");
    data = std::move(out);
  }
  std::ofstream f(path, std::ios::binary);
  const std::string header = h.str();
  f.write(header.data(), std::streamsize(header.size()));
  f.write(reinterpret_cast<const char*>(data.data()), std::streamsize(data.size()));
  if (!f) throw std::runtime_error("cannot write '" + path + "'");
}

void writeTiff(const std::string& path, const LabelVolume& volume, VoxelType type, bool compress) {
  const std::size_t count = volume.voxelCount();
  if (volume.labels.size() != count) throw std::runtime_error("cannot write '" + path + "': labels do not match dims");
  TIFFSetErrorHandler(tiffError);
  TIFFSetWarningHandler(tiffWarning);
  TIFF* raw = TIFFOpen(path.c_str(), "w");
  if (!raw) throw std::runtime_error("cannot write '" + path + "': " + tiffLastError);
  TiffPtr t(raw);
  const bool hostBig = [] {
    const std::uint16_t one = 1;
    unsigned char c;
    std::memcpy(&c, &one, 1);
    return c == 0;
  }();
  const std::size_t nx = std::size_t(volume.dims[0]), ny = std::size_t(volume.dims[1]);
  for (int z = 0; z < volume.dims[2]; ++z) {
    TIFFSetField(raw, TIFFTAG_IMAGEWIDTH, std::uint32_t(nx));
    TIFFSetField(raw, TIFFTAG_IMAGELENGTH, std::uint32_t(ny));
    TIFFSetField(raw, TIFFTAG_BITSPERSAMPLE, std::uint16_t(8 * voxelBytes(type)));
    TIFFSetField(raw, TIFFTAG_SAMPLESPERPIXEL, std::uint16_t(1));
    TIFFSetField(raw, TIFFTAG_SAMPLEFORMAT, std::uint16_t(isSigned(type) ? SAMPLEFORMAT_INT : SAMPLEFORMAT_UINT));
    TIFFSetField(raw, TIFFTAG_PHOTOMETRIC, std::uint16_t(PHOTOMETRIC_MINISBLACK));
    TIFFSetField(raw, TIFFTAG_PLANARCONFIG, std::uint16_t(PLANARCONFIG_CONTIG));
    TIFFSetField(raw, TIFFTAG_COMPRESSION, std::uint16_t(compress ? COMPRESSION_ADOBE_DEFLATE : COMPRESSION_NONE));
    TIFFSetField(raw, TIFFTAG_ROWSPERSTRIP,
                 std::uint32_t(std::max<std::size_t>(1, 8192 / (nx * voxelBytes(type) + 1))));
    if (volume.dims[2] > 1) {
      TIFFSetField(raw, TIFFTAG_SUBFILETYPE, std::uint32_t(FILETYPE_PAGE));
      TIFFSetField(raw, TIFFTAG_PAGENUMBER, std::uint16_t(z), std::uint16_t(volume.dims[2]));
    }
    for (std::size_t y = 0; y < ny; ++y) {
      std::vector<unsigned char> row =
          encodeVoxels(path, volume.labels, (std::size_t(z) * ny + y) * nx, nx, type, hostBig);
      if (TIFFWriteScanline(raw, row.data(), std::uint32_t(y), 0) < 0) {
        throw std::runtime_error("cannot write '" + path + "': " + tiffLastError);
      }
    }
    if (!TIFFWriteDirectory(raw)) throw std::runtime_error("cannot write '" + path + "': " + tiffLastError);
  }
}

}  // namespace lsdem::io
