#include "lsdem/io/JsonWriter.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace lsdem::io {

void JsonWriter::newline() {
  if (indent_ == 0) return;
  out_ << '\n' << std::string(stack_.size() * std::size_t(indent_), ' ');
}

void JsonWriter::beforeValue() {
  if (afterKey_) {
    afterKey_ = false;
    return;
  }
  if (stack_.empty()) return;
  if (stack_.back().isObject) throw std::logic_error("JsonWriter: a value inside an object needs a key");
  if (stack_.back().count++ > 0) out_ << ',';
  newline();
}

JsonWriter& JsonWriter::beginObject() {
  beforeValue();
  out_ << '{';
  stack_.push_back({true, 0});
  return *this;
}

JsonWriter& JsonWriter::endObject() {
  const bool any = stack_.back().count > 0;
  stack_.pop_back();
  if (any) newline();
  out_ << '}';
  if (stack_.empty() && indent_ > 0) out_ << '\n';
  return *this;
}

JsonWriter& JsonWriter::beginArray() {
  beforeValue();
  out_ << '[';
  stack_.push_back({false, 0});
  return *this;
}

JsonWriter& JsonWriter::endArray() {
  const bool any = stack_.back().count > 0;
  stack_.pop_back();
  if (any) newline();
  out_ << ']';
  return *this;
}

JsonWriter& JsonWriter::key(std::string_view k) {
  if (stack_.empty() || !stack_.back().isObject) throw std::logic_error("JsonWriter: a key outside an object");
  if (stack_.back().count++ > 0) out_ << ',';
  newline();
  writeString(k);
  out_ << (indent_ > 0 ? ": " : ":");
  afterKey_ = true;
  return *this;
}

JsonWriter& JsonWriter::value(double v) {
  beforeValue();
  if (!std::isfinite(v)) {
    out_ << "null";
    return *this;
  }
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof(buf), v);
  out_.write(buf, res.ptr - buf);
  return *this;
}

JsonWriter& JsonWriter::value(long long v) {
  beforeValue();
  out_ << v;
  return *this;
}

JsonWriter& JsonWriter::value(bool v) {
  beforeValue();
  out_ << (v ? "true" : "false");
  return *this;
}

JsonWriter& JsonWriter::value(std::string_view v) {
  beforeValue();
  writeString(v);
  return *this;
}

void JsonWriter::writeString(std::string_view v) {
  out_ << '"';
  for (const char c : v) {
    switch (c) {
      case '"': out_ << "\\\""; break;
      case '\\': out_ << "\\\\"; break;
      case '\n': out_ << "\\n"; break;
      case '\t': out_ << "\\t"; break;
      case '\r': out_ << "\\r"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof(buf), "\\u%04x", c);
          out_ << buf;
        } else {
          out_ << c;
        }
    }
  }
  out_ << '"';
}

}  // namespace lsdem::io
