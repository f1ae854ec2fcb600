#pragma once
/// @file NumberText.h
/// @brief The text of a number in every file lsdem writes (internal to io):
/// the shortest form that reads back as the same value (std::to_chars), so
/// outputs carry full precision and no more digits.

#include <charconv>
#include <cstdio>
#include <string>

namespace lsdem::io {

/// @brief Appends the shortest round-trip text of `v` (an integer, float or double).
template <class T>
void appendNumber(std::string& out, T v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);
  out.append(buf, r.ptr);
}

/// @brief The shortest round-trip text of `v`.
template <class T>
std::string numberText(T v) {
  std::string s;
  appendNumber(s, v);
  return s;
}

/// @brief `v` to 3 significant digits ("%.3g"): a figure in a message, where
/// the exact value is not the point.
inline std::string roughText(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.3g", v);
  return buf;
}

}  // namespace lsdem::io
