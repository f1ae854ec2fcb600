/// @file VtpRead.cpp
/// @brief Reader of VTK XML PolyData (`.vtp`) and ParaView series (`.pvd`)
/// files (io/VtpRead.h): a small XML tag scanner, base64 and ASCII decoding of
/// DataArrays, and the consistency checks of a piece.

#include "lsdem/io/VtpRead.h"

#include "lsdem/io/InputError.h"

#include <algorithm>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>

#include <zlib.h>

namespace lsdem::io {

static_assert(std::endian::native == std::endian::little,
              "the VTP reader copies raw little-endian bytes; a big-endian build needs a byte swap here");

namespace {

// ---------------------------------------------------------------------------
// Whole-file text and positions

std::string readText(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw InputError(file.string(), 0, "", "cannot open the file for reading");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

// 1-based line of character offset `at`.
int lineAt(const std::string& text, std::size_t at) {
  return 1 + int(std::count(text.begin(), text.begin() + std::ptrdiff_t(std::min(at, text.size())), '\n'));
}

// The five predefined XML entities back to characters.
std::string xmlUnescape(std::string_view s) {
  static constexpr std::pair<std::string_view, char> kEntities[] = {
      {"&amp;", '&'}, {"&lt;", '<'}, {"&gt;", '>'}, {"&quot;", '"'}, {"&apos;", '\''}};
  std::string out;
  for (std::size_t k = 0; k < s.size();) {
    bool matched = false;
    if (s[k] == '&') {
      for (const auto& [name, c] : kEntities) {
        if (s.substr(k, name.size()) == name) {
          out += c;
          k += name.size();
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
// XML tags

/// One tag: `<name a="v" ...>`, `<name .../>` or `</name>`.
struct Tag {
  std::string name;
  std::map<std::string, std::string> attributes;
  bool closing = false;      ///< `</name>`
  bool selfClosing = false;  ///< `<name ... />`
  std::size_t begin = 0;     ///< offset of '<'
  std::size_t end = 0;       ///< offset just after '>'

  std::optional<std::string> attribute(const std::string& key) const {
    const auto it = attributes.find(key);
    if (it == attributes.end()) return std::nullopt;
    return it->second;
  }
};

/// Walks the tags of an XML text in order, skipping declarations, comments and text.
class TagScanner {
 public:
  TagScanner(const std::string& text, std::string file) : text_(text), file_(std::move(file)) {}

  /// The next tag, or nullopt at the end of the text.
  std::optional<Tag> next() {
    while (true) {
      const std::size_t lt = text_.find('<', at_);
      if (lt == std::string::npos) return std::nullopt;
      // Comments, declarations and processing instructions.
      if (text_.compare(lt, 4, "<!--") == 0) {
        at_ = skipPast(lt, "-->");
        continue;
      }
      if (text_.compare(lt, 2, "<?") == 0) {
        at_ = skipPast(lt, "?>");
        continue;
      }
      if (text_.compare(lt, 2, "<!") == 0) {
        at_ = skipPast(lt, ">");
        continue;
      }
      return parseTag(lt);
    }
  }

  /// The text from the current position up to the next '<' (an element's content).
  std::string_view content() {
    const std::size_t lt = text_.find('<', at_);
    if (lt == std::string::npos) fail(at_, "", "the file ends inside an element");
    const std::string_view s(text_.data() + at_, lt - at_);
    at_ = lt;
    return s;
  }

  /// Continues the walk at offset `at`.
  void skipTo(std::size_t at) { at_ = at; }

  [[noreturn]] void fail(std::size_t at, const std::string& key, const std::string& problem) const {
    throw InputError(file_, lineAt(text_, at), key, problem);
  }

 private:
  std::size_t skipPast(std::size_t from, const char* terminator) const {
    const std::size_t e = text_.find(terminator, from);
    if (e == std::string::npos) fail(from, "", "unterminated markup");
    return e + std::strlen(terminator);
  }

  Tag parseTag(std::size_t lt) {
    Tag tag;
    tag.begin = lt;
    std::size_t k = lt + 1;
    if (k < text_.size() && text_[k] == '/') {
      tag.closing = true;
      ++k;
    }
    // The element name.
    const std::size_t nameBegin = k;
    while (k < text_.size() && !std::isspace(static_cast<unsigned char>(text_[k])) && text_[k] != '>' &&
           text_[k] != '/')
      ++k;
    tag.name = text_.substr(nameBegin, k - nameBegin);
    if (tag.name.empty()) fail(lt, "", "a tag without a name");
    // Attributes up to '>' or '/>'.
    while (true) {
      while (k < text_.size() && std::isspace(static_cast<unsigned char>(text_[k]))) ++k;
      if (k >= text_.size()) fail(lt, tag.name, "the file ends inside the tag");
      if (text_[k] == '>') {
        ++k;
        break;
      }
      if (text_[k] == '/' && k + 1 < text_.size() && text_[k + 1] == '>') {
        tag.selfClosing = true;
        k += 2;
        break;
      }
      const std::size_t keyBegin = k;
      while (k < text_.size() && text_[k] != '=' && !std::isspace(static_cast<unsigned char>(text_[k])) &&
             text_[k] != '>')
        ++k;
      const std::string key = text_.substr(keyBegin, k - keyBegin);
      if (k >= text_.size()) fail(lt, tag.name, "the file ends inside the tag");
      while (k < text_.size() && std::isspace(static_cast<unsigned char>(text_[k]))) ++k;
      if (k >= text_.size() || text_[k] != '=') fail(lt, tag.name, "attribute '" + key + "' has no value");
      ++k;
      while (k < text_.size() && std::isspace(static_cast<unsigned char>(text_[k]))) ++k;
      if (k >= text_.size() || (text_[k] != '"' && text_[k] != '\'')) {
        fail(lt, tag.name, "attribute '" + key + "' is not quoted");
      }
      const char quote = text_[k++];
      const std::size_t valueEnd = text_.find(quote, k);
      if (valueEnd == std::string::npos) fail(lt, tag.name, "attribute '" + key + "' is not terminated");
      tag.attributes[key] = xmlUnescape(std::string_view(text_).substr(k, valueEnd - k));
      k = valueEnd + 1;
    }
    tag.end = k;
    at_ = k;
    return tag;
  }

  const std::string& text_;
  std::string file_;
  std::size_t at_ = 0;
};

// ---------------------------------------------------------------------------
// Numbers

// A non-negative integer attribute.
std::uint64_t countAttribute(const TagScanner& scan, const Tag& tag, const std::string& key) {
  const auto text = tag.attribute(key);
  if (!text) return 0;
  std::uint64_t v = 0;
  const auto r = std::from_chars(text->data(), text->data() + text->size(), v);
  if (r.ec != std::errc() || r.ptr != text->data() + text->size()) {
    scan.fail(tag.begin, tag.name + "." + key, "not a count: '" + *text + "'");
  }
  return v;
}

// Base64 (RFC 4648) to bytes. Blanks are skipped; '=' padding may end a
// quadruple anywhere (VTK encodes its header and its data as two streams).
std::optional<std::string> decodeBase64(std::string_view text) {
  auto value = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    return -1;
  };
  std::string bytes;
  bytes.reserve(text.size() * 3 / 4);
  char quad[4];
  int filled = 0;
  for (char c : text) {
    if (std::isspace(static_cast<unsigned char>(c))) continue;
    quad[filled++] = c;
    if (filled < 4) continue;
    filled = 0;
    // One quadruple: 4 symbols, the last one or two may be padding.
    const int pad = (quad[3] == '=') + (quad[2] == '=' && quad[3] == '=');
    unsigned v = 0;
    for (int i = 0; i < 4; ++i) {
      const int s = i >= 4 - pad ? 0 : value(quad[i]);
      if (s < 0) return std::nullopt;
      v = (v << 6) | unsigned(s);
    }
    bytes += char((v >> 16) & 0xff);
    if (pad < 2) bytes += char((v >> 8) & 0xff);
    if (pad < 1) bytes += char(v & 0xff);
  }
  if (filled != 0) return std::nullopt;
  return bytes;
}

/// The VTK value types the reader knows.
enum class ValueType { Float64, Float32, Int64, UInt64, Int32, UInt32, Int16, UInt16, Int8, UInt8 };

std::optional<ValueType> valueType(const std::string& name) {
  static const std::map<std::string, ValueType> kTypes{
      {"Float64", ValueType::Float64}, {"Float32", ValueType::Float32}, {"Int64", ValueType::Int64},
      {"UInt64", ValueType::UInt64},   {"Int32", ValueType::Int32},     {"UInt32", ValueType::UInt32},
      {"Int16", ValueType::Int16},     {"UInt16", ValueType::UInt16},   {"Int8", ValueType::Int8},
      {"UInt8", ValueType::UInt8}};
  const auto it = kTypes.find(name);
  if (it == kTypes.end()) return std::nullopt;
  return it->second;
}

// Raw little-endian values of type In, converted to Out.
template <class In, class Out>
std::vector<Out> fromBytes(std::string_view bytes) {
  std::vector<Out> out(bytes.size() / sizeof(In));
  for (std::size_t i = 0; i < out.size(); ++i) {
    In v;
    std::memcpy(&v, bytes.data() + i * sizeof(In), sizeof(In));
    out[i] = Out(v);
  }
  return out;
}

// Blank-separated numbers parsed as In, converted to Out; nullopt on the first bad token.
template <class In, class Out>
std::optional<std::vector<Out>> fromAscii(std::string_view text, std::string& badToken) {
  std::vector<Out> out;
  std::size_t k = 0;
  while (true) {
    while (k < text.size() && std::isspace(static_cast<unsigned char>(text[k]))) ++k;
    if (k >= text.size()) return out;
    std::size_t e = k;
    while (e < text.size() && !std::isspace(static_cast<unsigned char>(text[e]))) ++e;
    In v{};
    const char* first = text.data() + k;
    if (*first == '+' && e > k + 1) ++first;
    const auto r = std::from_chars(first, text.data() + e, v);
    if (r.ec != std::errc() || r.ptr != text.data() + e) {
      badToken = std::string(text.substr(k, e - k));
      return std::nullopt;
    }
    out.push_back(Out(v));
    k = e;
  }
}

/// What the file's root says about binary data, and the appended block.
struct Encoding {
  bool header64 = false;    ///< header_type UInt64 (else UInt32)
  bool compressed = false;  ///< compressor="vtkZLibDataCompressor"
  bool hasAppended = false;  ///< the file has <AppendedData encoding="raw">
  std::string_view appended;  ///< its bytes after the '_' mark (to the end of the file)
};

// A header word of `bytes` at `at`.
std::uint64_t headerWord(std::string_view bytes, std::size_t at, bool header64) {
  if (header64) {
    std::uint64_t v = 0;
    std::memcpy(&v, bytes.data() + at, 8);
    return v;
  }
  std::uint32_t v = 0;
  std::memcpy(&v, bytes.data() + at, 4);
  return v;
}

// The raw bytes of a compressed array at the start of `bytes` (VTK's layout:
// header [blocks, block size, last block's size (0: full), compressed size
// of each block], then the zlib streams). nullopt and `problem` when the
// data is inconsistent.
std::optional<std::string> decompress(std::string_view bytes, bool header64, std::string& problem) {
  const std::size_t word = header64 ? 8 : 4;
  if (bytes.size() < 3 * word) {
    problem = "the compressed data has no header";
    return std::nullopt;
  }
  const std::uint64_t blocks = headerWord(bytes, 0, header64);
  const std::uint64_t blockSize = headerWord(bytes, word, header64);
  const std::uint64_t last = headerWord(bytes, 2 * word, header64);
  if (blocks > (bytes.size() - 3 * word) / word || (blocks > 0 && blockSize == 0) || last > blockSize) {
    problem = "the compression header is inconsistent (" + std::to_string(blocks) + " blocks of " +
              std::to_string(blockSize) + " bytes, the last " + std::to_string(last) + ")";
    return std::nullopt;
  }
  std::size_t at = (3 + std::size_t(blocks)) * word;
  std::string out;
  for (std::uint64_t k = 0; k < blocks; ++k) {
    const std::uint64_t size = headerWord(bytes, (3 + std::size_t(k)) * word, header64);
    const std::uint64_t raw = k + 1 == blocks && last != 0 ? last : blockSize;
    if (size > bytes.size() - at) {
      problem = "block " + std::to_string(k) + " of the compressed data runs past the end of the file";
      return std::nullopt;
    }
    const std::size_t before = out.size();
    out.resize(before + std::size_t(raw));
    uLongf length = uLongf(raw);
    if (uncompress(reinterpret_cast<Bytef*>(out.data() + before), &length,
                   reinterpret_cast<const Bytef*>(bytes.data() + at), uLong(size)) != Z_OK ||
        length != raw) {
      problem = "block " + std::to_string(k) + " of the compressed data does not decompress to " +
                std::to_string(raw) + " bytes";
      return std::nullopt;
    }
    at += std::size_t(size);
  }
  return out;
}

// The values of one DataArray element (the scanner sits just after its opening tag).
VtkArray readDataArray(TagScanner& scan, const Tag& tag, const Encoding& encoding) {
  VtkArray array;
  array.name = tag.attribute("Name").value_or("");
  const std::string key = "DataArray " + (array.name.empty() ? std::string("(unnamed)") : array.name);
  // Attributes: type, components, format.
  const std::string typeName = tag.attribute("type").value_or("");
  const std::optional<ValueType> type = valueType(typeName);
  if (!type) scan.fail(tag.begin, key, "unsupported value type '" + typeName + "'");
  const std::uint64_t components = tag.attribute("NumberOfComponents") ? countAttribute(scan, tag, "NumberOfComponents") : 1;
  if (components < 1) scan.fail(tag.begin, key, "NumberOfComponents must be at least 1");
  array.components = int(components);
  const std::string format = tag.attribute("format").value_or("ascii");
  if (format != "ascii" && format != "binary" && format != "appended") {
    scan.fail(tag.begin, key, "format '" + format + "' is not one of ascii, binary, appended");
  }
  // The raw bytes of a binary or appended array.
  std::string bytes;
  const std::size_t headerSize = encoding.header64 ? 8 : 4;
  // Its bytes after a byte-count header (uncompressed data).
  const auto counted = [&](std::string_view data) {
    if (data.size() < headerSize) scan.fail(tag.begin, key, "the binary data has no byte-count header");
    const std::uint64_t count = headerWord(data, 0, encoding.header64);
    if (count > data.size() - headerSize) {
      scan.fail(tag.begin, key,
                "the header announces " + std::to_string(count) + " bytes but " +
                    std::to_string(data.size() - headerSize) + " follow");
    }
    return std::string(data.substr(headerSize, std::size_t(count)));
  };
  const auto compressed = [&](std::string_view data) {
    std::string problem;
    std::optional<std::string> raw = decompress(data, encoding.header64, problem);
    if (!raw) scan.fail(tag.begin, key, problem);
    return std::move(*raw);
  };
  if (format == "appended") {
    if (!encoding.hasAppended) scan.fail(tag.begin, key, "format 'appended' but the file has no <AppendedData>");
    if (!tag.attribute("offset")) scan.fail(tag.begin, key + ".offset", "missing");
    const std::uint64_t offset = countAttribute(scan, tag, "offset");
    if (offset > encoding.appended.size()) {
      scan.fail(tag.begin, key + ".offset", std::to_string(offset) + " is past the end of the appended data");
    }
    const std::string_view data = encoding.appended.substr(std::size_t(offset));
    bytes = encoding.compressed ? compressed(data) : counted(data);
    if (!tag.selfClosing) {
      // <DataArray ...></DataArray> with nothing between.
      scan.content();
      const std::optional<Tag> close = scan.next();
      if (!close || !close->closing || close->name != "DataArray") scan.fail(tag.begin, key, "no </DataArray>");
    }
  } else if (tag.selfClosing) {
    // An empty array.
    array.values = std::vector<double>();
    return array;
  }
  const std::string_view text = format == "appended" ? std::string_view() : scan.content();

  if (format == "binary") {
    // Uncompressed: one base64 stream of the byte count and the values (or
    // two, as VTK writes them). Compressed: the header, then the blocks,
    // each its own base64 stream (VTK's layout).
    std::string symbols;
    for (char c : text) {
      if (!std::isspace(static_cast<unsigned char>(c))) symbols += c;
    }
    const auto decoded = [&](std::string_view part) {
      const std::optional<std::string> b = decodeBase64(part);
      if (!b) scan.fail(tag.begin, key, "the base64 data is malformed");
      return *b;
    };
    if (!encoding.compressed) {
      const std::string all = decoded(symbols);
      bytes = counted(all);
      if (bytes.size() != all.size() - headerSize) {
        scan.fail(tag.begin, key,
                  "the header announces " + std::to_string(bytes.size()) + " bytes but " +
                      std::to_string(all.size() - headerSize) + " follow");
      }
    } else {
      // The header's length comes from its first word (the block count).
      const auto symbolsOf = [](std::size_t n) { return (n + 2) / 3 * 4; };
      if (symbols.size() < symbolsOf(3 * headerSize)) scan.fail(tag.begin, key, "the compressed data has no header");
      const std::string first = decoded(std::string_view(symbols).substr(0, symbolsOf(3 * headerSize)));
      const std::uint64_t blocks = headerWord(first, 0, encoding.header64);
      if (blocks > symbols.size()) scan.fail(tag.begin, key, "the compression header is inconsistent");
      const std::size_t headerSymbols = symbolsOf((3 + std::size_t(blocks)) * headerSize);
      if (symbols.size() < headerSymbols) scan.fail(tag.begin, key, "the compressed data has no header");
      std::string all = decoded(std::string_view(symbols).substr(0, headerSymbols));
      all += decoded(std::string_view(symbols).substr(headerSymbols));
      bytes = compressed(all);
    }
  }
  if (format != "ascii") {
    const std::string_view data(bytes);
    const std::size_t count = data.size();
    auto check = [&](std::size_t size) {
      if (count % size != 0) {
        scan.fail(tag.begin, key, std::to_string(count) + " bytes are not a whole number of " + typeName + " values");
      }
    };
    switch (*type) {
      case ValueType::Float64: check(8); array.values = fromBytes<double, double>(data); break;
      case ValueType::Float32: check(4); array.values = fromBytes<float, double>(data); break;
      case ValueType::Int64: check(8); array.values = fromBytes<std::int64_t, std::int64_t>(data); break;
      case ValueType::UInt64: check(8); array.values = fromBytes<std::uint64_t, std::uint64_t>(data); break;
      case ValueType::Int32: check(4); array.values = fromBytes<std::int32_t, std::int32_t>(data); break;
      case ValueType::UInt32: check(4); array.values = fromBytes<std::uint32_t, std::int64_t>(data); break;
      case ValueType::Int16: check(2); array.values = fromBytes<std::int16_t, std::int64_t>(data); break;
      case ValueType::UInt16: check(2); array.values = fromBytes<std::uint16_t, std::int64_t>(data); break;
      case ValueType::Int8: array.values = fromBytes<std::int8_t, std::int64_t>(data); break;
      case ValueType::UInt8: array.values = fromBytes<std::uint8_t, std::int64_t>(data); break;
    }
  } else {
    // Blank-separated numbers.
    std::string bad;
    bool ok = true;
    auto take = [&](auto parsed) {
      if (!parsed) {
        ok = false;
        return;
      }
      array.values = std::move(*parsed);
    };
    switch (*type) {
      case ValueType::Float64: take(fromAscii<double, double>(text, bad)); break;
      case ValueType::Float32: take(fromAscii<float, double>(text, bad)); break;  // as the binary encodings read it
      case ValueType::Int64: take(fromAscii<std::int64_t, std::int64_t>(text, bad)); break;
      case ValueType::UInt64: take(fromAscii<std::uint64_t, std::uint64_t>(text, bad)); break;
      case ValueType::Int32: take(fromAscii<std::int32_t, std::int32_t>(text, bad)); break;
      default: take(fromAscii<std::int64_t, std::int64_t>(text, bad)); break;
    }
    if (!ok) scan.fail(tag.begin, key, "'" + bad + "' is not a " + typeName + " value");
  }
  // The closing tag of an inline array.
  if (format != "appended") {
    const std::optional<Tag> close = scan.next();
    if (!close || !close->closing || close->name != "DataArray") scan.fail(tag.begin, key, "no </DataArray> after the values");
  }
  if (array.valueCount() % components != 0) {
    scan.fail(tag.begin, key,
              std::to_string(array.valueCount()) + " values are not a whole number of " + std::to_string(components) +
                  "-component tuples");
  }
  return array;
}

// Values of any integer array as int64 (cell arrays).
std::vector<std::int64_t> asInt64(const VtkArray& a) {
  return std::visit(
      [](const auto& v) {
        std::vector<std::int64_t> out(v.size());
        for (std::size_t i = 0; i < v.size(); ++i) out[i] = std::int64_t(v[i]);
        return out;
      },
      a.values);
}

/// One cell block of the piece being read, with where it was declared.
struct CellBlock {
  VtkCells* cells = nullptr;
  std::uint64_t declared = 0;  ///< the Piece's NumberOf... attribute
  std::size_t at = 0;          ///< offset of the block's tag
  bool seen = false;
  const char* name = "";
};

}  // namespace

// ---------------------------------------------------------------------------
// Public

const VtkArray* findArray(const std::vector<VtkArray>& arrays, std::string_view name) {
  for (const VtkArray& a : arrays) {
    if (a.name == name) return &a;
  }
  return nullptr;
}

std::vector<double> arrayAsDoubles(const VtkArray& array) {
  return std::visit(
      [](const auto& v) {
        std::vector<double> out(v.size());
        for (std::size_t i = 0; i < v.size(); ++i) out[i] = double(v[i]);
        return out;
      },
      array.values);
}

VtpPiece readVtp(const std::filesystem::path& file) {
  const std::string text = readText(file);
  TagScanner scan(text, file.string());

  // The root: PolyData, little-endian, uncompressed.
  const std::optional<Tag> root = scan.next();
  if (!root || root->closing || root->name != "VTKFile") scan.fail(0, "VTKFile", "not a VTK XML file (no <VTKFile>)");
  // A parallel index (.pvtp): its pieces, joined.
  if (root->attribute("type").value_or("") == "PPolyData") {
    std::vector<VtpPiece> pieces;
    while (const std::optional<Tag> tag = scan.next()) {
      if (tag->closing || tag->name != "Piece") continue;
      const auto source = tag->attribute("Source");
      if (!source || source->empty()) scan.fail(tag->begin, "Piece.Source", "missing");
      if (source->ends_with(".pvtp")) scan.fail(tag->begin, "Piece.Source", "'" + *source + "' is an index, not a piece");
      pieces.push_back(readVtp(file.parent_path() / *source));
    }
    if (pieces.empty()) scan.fail(root->begin, "PPolyData", "names no piece");
    return joinPieces(pieces);
  }
  if (root->attribute("type").value_or("") != "PolyData") {
    scan.fail(root->begin, "VTKFile.type", "'" + root->attribute("type").value_or("") + "' is not PolyData");
  }
  if (root->attribute("byte_order").value_or("LittleEndian") != "LittleEndian") {
    scan.fail(root->begin, "VTKFile.byte_order", "big-endian files are not read");
  }
  Encoding encoding;
  const std::string compressor = root->attribute("compressor").value_or("");
  if (!compressor.empty() && compressor != "vtkZLibDataCompressor") {
    scan.fail(root->begin, "VTKFile.compressor", "'" + compressor + "' is not read (vtkZLibDataCompressor only)");
  }
  encoding.compressed = !compressor.empty();
  // The appended block: raw bytes from its '_' mark to the end of the file
  // (the XML before it has no '<' but in tags: names and values are escaped).
  const std::size_t appendedAt = text.find("<AppendedData");
  if (appendedAt != std::string::npos) {
    TagScanner at(text, file.string());
    at.skipTo(appendedAt);
    const std::optional<Tag> tag = at.next();
    if (tag->attribute("encoding").value_or("") != "raw") {
      scan.fail(appendedAt, "AppendedData.encoding",
                "'" + tag->attribute("encoding").value_or("") + "' is not read (raw only)");
    }
    const std::size_t mark = text.find('_', tag->end);
    if (mark == std::string::npos) scan.fail(appendedAt, "AppendedData", "no '_' before the data");
    encoding.hasAppended = true;
    encoding.appended = std::string_view(text).substr(mark + 1);
  }
  const std::string headerType = root->attribute("header_type").value_or("UInt32");
  if (headerType != "UInt64" && headerType != "UInt32") {
    scan.fail(root->begin, "VTKFile.header_type", "'" + headerType + "' is neither UInt64 nor UInt32");
  }
  encoding.header64 = headerType == "UInt64";

  VtpPiece piece;
  std::uint64_t declaredPoints = 0;
  std::size_t pieceAt = 0;
  int pieces = 0;
  bool pointsSeen = false;
  CellBlock verts{&piece.verts, 0, 0, false, "Verts"}, lines{&piece.lines, 0, 0, false, "Lines"},
      polys{&piece.polys, 0, 0, false, "Polys"};
  // Where the DataArrays being read go.
  enum class Section { None, PointData, CellData, Points, Cells, FieldData, Skip } section = Section::None;
  CellBlock* block = nullptr;
  bool closed = false;

  // Walk the elements.
  while (const std::optional<Tag> tag = scan.next()) {
    if (tag->closing) {
      if (tag->name == "VTKFile") {
        closed = true;
        break;
      }
      if (tag->name == "PointData" || tag->name == "CellData" || tag->name == "Points" || tag->name == "Verts" ||
          tag->name == "Lines" || tag->name == "Polys" || tag->name == "Strips" || tag->name == "FieldData") {
        section = Section::None;
        block = nullptr;
      }
      continue;
    }
    const std::string& name = tag->name;
    if (name == "PolyData") continue;
    if (name == "Piece") {
      // Counts the piece declares.
      if (++pieces > 1) scan.fail(tag->begin, "Piece", "more than one piece; lsdem frames hold one");
      pieceAt = tag->begin;
      declaredPoints = countAttribute(scan, *tag, "NumberOfPoints");
      verts.declared = countAttribute(scan, *tag, "NumberOfVerts");
      lines.declared = countAttribute(scan, *tag, "NumberOfLines");
      polys.declared = countAttribute(scan, *tag, "NumberOfPolys");
      if (countAttribute(scan, *tag, "NumberOfStrips") > 0) scan.fail(tag->begin, "Piece", "triangle strips are not read");
      continue;
    }
    if (name == "AppendedData") {
      // The binary block ends the XML part; the file must end with its closing tags.
      const std::size_t tail = text.rfind("</AppendedData>");
      if (tail == std::string::npos || tail < tag->end || text.find("</VTKFile>", tail) == std::string::npos) {
        scan.fail(tag->begin, "AppendedData", "the file ends before </AppendedData> and </VTKFile>");
      }
      closed = true;
      break;
    }
    if (pieces == 0 && name != "DataArray" && name != "FieldData") scan.fail(tag->begin, name, "outside a <Piece>");
    // Sections of the piece (field data: of the data set, before the piece, or of the piece).
    if (name == "PointData" || name == "CellData" || name == "Points" || name == "FieldData" || name == "Strips") {
      section = name == "PointData" ? Section::PointData
                : name == "CellData" ? Section::CellData
                : name == "Points"   ? Section::Points
                : name == "FieldData" ? Section::FieldData
                                     : Section::Skip;
      if (tag->selfClosing) section = Section::None;
      continue;
    }
    if (name == "Verts" || name == "Lines" || name == "Polys") {
      block = name == "Verts" ? &verts : name == "Lines" ? &lines : &polys;
      block->seen = true;
      block->at = tag->begin;
      section = tag->selfClosing ? Section::None : Section::Cells;
      continue;
    }
    if (name != "DataArray") scan.fail(tag->begin, name, "unexpected element in a PolyData file");

    // One DataArray, filed by its section.
    if (section == Section::None) scan.fail(tag->begin, "DataArray", "outside PointData, CellData, Points or cells");
    if (section == Section::Skip) {
      // Strips: skip the content and the closing tag.
      if (!tag->selfClosing) {
        scan.content();
        scan.next();
      }
      continue;
    }
    VtkArray array = readDataArray(scan, *tag, encoding);
    if (section == Section::FieldData) {
      // The simulated time (VTK's TimeValue); other field data is not kept.
      if (array.name == "TimeValue") {
        const std::vector<double> t = arrayAsDoubles(array);
        if (t.size() != 1 || !std::isfinite(t[0])) scan.fail(tag->begin, "FieldData.TimeValue", "must be one finite number");
        piece.time = t[0];
      }
      continue;
    }
    switch (section) {
      case Section::PointData: piece.pointData.push_back(std::move(array)); break;
      case Section::CellData: piece.cellData.push_back(std::move(array)); break;
      case Section::Points:
        if (pointsSeen) scan.fail(tag->begin, "Points", "more than one points array");
        if (array.components != 3) scan.fail(tag->begin, "Points", "points need 3 components, got " + std::to_string(array.components));
        pointsSeen = true;
        piece.points = arrayAsDoubles(array);
        break;
      case Section::Cells:
        if (std::holds_alternative<std::vector<double>>(array.values) && array.valueCount() > 0) {
          scan.fail(tag->begin, std::string(block->name) + "." + array.name, "cell arrays must be integers");
        }
        if (array.name == "connectivity") {
          block->cells->connectivity = asInt64(array);
        } else if (array.name == "offsets") {
          block->cells->offsets = asInt64(array);
        } else {
          scan.fail(tag->begin, std::string(block->name) + "." + array.name, "cells hold 'connectivity' and 'offsets' only");
        }
        break;
      default: break;
    }
  }
  if (!closed) scan.fail(text.size(), "VTKFile", "the file ends before </VTKFile>");
  if (pieces == 0) scan.fail(root->begin, "Piece", "no <Piece>");

  // Points: as many as declared.
  if (piece.pointCount() != declaredPoints) {
    scan.fail(pieceAt, "Points",
              "the piece declares " + std::to_string(declaredPoints) + " points but holds " +
                  std::to_string(piece.pointCount()));
  }
  // Cells: a leading 0 dropped, counts as declared, offsets increasing, indices valid.
  for (CellBlock* b : {&verts, &lines, &polys}) {
    VtkCells& c = *b->cells;
    const std::string key = b->name;
    if (c.offsets.size() == b->declared + 1 && !c.offsets.empty() && c.offsets.front() == 0) c.offsets.erase(c.offsets.begin());
    if (c.offsets.size() != b->declared) {
      scan.fail(b->seen ? b->at : pieceAt, key,
                "the piece declares " + std::to_string(b->declared) + " cells but the offsets hold " +
                    std::to_string(c.offsets.size()));
    }
    std::int64_t previous = 0;
    for (std::int64_t o : c.offsets) {
      if (o < previous) scan.fail(b->at, key + ".offsets", "offsets decrease at " + std::to_string(o));
      previous = o;
    }
    if (std::size_t(previous) != c.connectivity.size()) {
      scan.fail(b->at, key + ".offsets",
                "offsets end at " + std::to_string(previous) + " but the connectivity holds " +
                    std::to_string(c.connectivity.size()) + " indices");
    }
    for (std::int64_t i : c.connectivity) {
      if (i < 0 || std::uint64_t(i) >= declaredPoints) {
        scan.fail(b->at, key + ".connectivity",
                  "a cell names point " + std::to_string(i) + " of " + std::to_string(declaredPoints));
      }
    }
  }
  // Attributes: one tuple per point / cell.
  auto checkTuples = [&](const std::vector<VtkArray>& arrays, std::size_t tuples, const char* what) {
    for (const VtkArray& a : arrays) {
      if (a.valueCount() != tuples * std::size_t(a.components)) {
        scan.fail(pieceAt, std::string(what) + "." + a.name,
                  std::to_string(a.valueCount() / std::size_t(a.components)) + " tuples for " +
                      std::to_string(tuples) + (what[0] == 'P' ? " points" : " cells"));
      }
    }
  };
  checkTuples(piece.pointData, piece.pointCount(), "PointData");
  checkTuples(piece.cellData, piece.cellCount(), "CellData");
  return piece;
}

std::vector<PvdSeries::Entry> readPvd(const std::filesystem::path& file) {
  const std::string text = readText(file);
  TagScanner scan(text, file.string());
  // The root must be a collection.
  const std::optional<Tag> root = scan.next();
  if (!root || root->name != "VTKFile" || root->attribute("type").value_or("") != "Collection") {
    scan.fail(0, "VTKFile", "not a ParaView series (no <VTKFile type=\"Collection\">)");
  }
  // One entry per DataSet.
  std::vector<PvdSeries::Entry> entries;
  bool closed = false;
  while (const std::optional<Tag> tag = scan.next()) {
    if (tag->closing && tag->name == "VTKFile") {
      closed = true;
      break;
    }
    if (tag->closing || tag->name != "DataSet") continue;
    const auto time = tag->attribute("timestep");
    const auto name = tag->attribute("file");
    if (!time) scan.fail(tag->begin, "DataSet.timestep", "missing");
    if (!name || name->empty()) scan.fail(tag->begin, "DataSet.file", "missing");
    PvdSeries::Entry e;
    const auto r = std::from_chars(time->data(), time->data() + time->size(), e.time);
    if (r.ec != std::errc() || r.ptr != time->data() + time->size() || !std::isfinite(e.time)) {
      scan.fail(tag->begin, "DataSet.timestep", "not a finite number: '" + *time + "'");
    }
    e.file = *name;
    if (const auto part = tag->attribute("part"); part && !part->empty()) {
      const auto rp = std::from_chars(part->data(), part->data() + part->size(), e.part);
      if (rp.ec != std::errc() || rp.ptr != part->data() + part->size() || e.part < 0) {
        scan.fail(tag->begin, "DataSet.part", "not a part number: '" + *part + "'");
      }
    }
    entries.push_back(std::move(e));
  }
  if (!closed) scan.fail(text.size(), "VTKFile", "the series ends before </VTKFile>");
  return entries;
}

std::vector<PvdSeries::Entry> frameEntries(const std::vector<PvdSeries::Entry>& entries, std::size_t frame) {
  std::vector<PvdSeries::Entry> out;
  std::size_t seen = 0;
  for (const PvdSeries::Entry& e : entries) {
    if (e.part == 0) ++seen;
    if (seen == frame + 1) out.push_back(e);
    if (seen > frame + 1) break;
  }
  return out;
}

std::size_t frameCount(const std::vector<PvdSeries::Entry>& entries) {
  return std::size_t(std::count_if(entries.begin(), entries.end(), [](const PvdSeries::Entry& e) { return e.part == 0; }));
}

}  // namespace lsdem::io
