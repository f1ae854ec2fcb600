#pragma once
/// @file JsonWriter.h
/// @brief A small streaming JSON writer (summaries, `--json` outputs). Numbers
/// are written in their shortest round-trip form; non-finite numbers, which
/// JSON cannot hold, are written as null.

#include <Eigen/Core>

#include <ostream>
#include <string>
#include <string_view>
#include <vector>

namespace lsdem::io {

class JsonWriter {
 public:
  /// @param indent  spaces per level; 0 writes one line
  explicit JsonWriter(std::ostream& out, int indent = 2) : out_(out), indent_(indent) {}

  JsonWriter& beginObject();
  JsonWriter& endObject();
  JsonWriter& beginArray();
  JsonWriter& endArray();
  /// @brief The key of the next value inside an object.
  JsonWriter& key(std::string_view k);

  JsonWriter& value(double v);
  JsonWriter& value(long long v);
  JsonWriter& value(int v) { return value(static_cast<long long>(v)); }
  JsonWriter& value(std::size_t v) { return value(static_cast<long long>(v)); }
  JsonWriter& value(bool v);
  JsonWriter& value(std::string_view v);
  JsonWriter& value(const char* v) { return value(std::string_view(v)); }
  /// @brief A vector as an array of numbers.
  template <class Derived>
  JsonWriter& value(const Eigen::MatrixBase<Derived>& v) {
    beginArray();
    for (Eigen::Index i = 0; i < v.size(); ++i) value(double(v(i)));
    return endArray();
  }

  /// @brief key(k).value(v) in one call.
  template <class T>
  JsonWriter& field(std::string_view k, const T& v) {
    key(k);
    return value(v);
  }

 private:
  void beforeValue();
  void newline();
  void writeString(std::string_view v);

  std::ostream& out_;
  int indent_;
  struct Level {
    bool isObject;
    int count;
  };
  std::vector<Level> stack_;
  bool afterKey_ = false;
};

}  // namespace lsdem::io
