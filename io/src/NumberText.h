#pragma once
/// @file NumberText.h
/// @brief The text of a number in every file lsdem writes (internal to io):
/// the shortest form that reads back as the same value (std::to_chars), so
/// outputs carry full precision and no more digits.

#include <charconv>
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

}  // namespace lsdem::io
