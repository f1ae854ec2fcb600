#include "lsdem/io/InputError.h"

#include <cstdio>

namespace lsdem::io {
namespace {

// The text on one line: control characters (a newline or NUL the parser
// echoes from the file, a key named with one) written as escapes.
std::string oneLine(const std::string& text) {
  std::string s;
  s.reserve(text.size());
  for (const char c : text) {
    const unsigned char u = static_cast<unsigned char>(c);
    if (c == '\n') {
      s += "\\n";
    } else if (c == '\r') {
      s += "\\r";
    } else if (c == '\t') {
      s += "\\t";
    } else if (u < 0x20 || u == 0x7f) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", u);
      s += buf;
    } else {
      s += c;
    }
  }
  return s;
}

std::string format(const std::string& file, int line, const std::string& key, const std::string& what) {
  std::string s = oneLine(file);
  if (line > 0) s.append(":").append(std::to_string(line));
  s.append(": ");
  if (!key.empty()) s.append(oneLine(key)).append(": ");
  return s.append(oneLine(what));
}

}  // namespace

InputError::InputError(std::string file, int line, std::string key, const std::string& what)
    : std::runtime_error(format(file, line, key, what)),
      file_(std::move(file)),
      line_(line),
      key_(std::move(key)),
      problem_(oneLine(what)) {}

}  // namespace lsdem::io
