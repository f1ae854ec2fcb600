#pragma once
/// @file Json.h
/// @brief Test helper: a number from a JSON text (summary.json, the command
/// line's --json output) without a JSON library.

#include <gtest/gtest.h>

#include <regex>
#include <string>

namespace lsdem::test {

/// The number after the first `"key": ` in `json`, or (`index` 0-2) an
/// entry of the first `"key": [x, y, z]`; a failure of the calling test, and
/// 0, when there is none.
inline double jsonNumber(const std::string& json, const std::string& key, int index = 0) {
  std::smatch m;
  const std::regex scalar("\"" + key + "\": ([-0-9.eE+]+)");
  const std::regex array("\"" + key + "\": \\[\\s*([-0-9.eE+]+),\\s*([-0-9.eE+]+),\\s*([-0-9.eE+]+)");
  if (index == 0 && std::regex_search(json, m, scalar)) return std::stod(m[1]);
  if (std::regex_search(json, m, array)) return std::stod(m[index + 1]);
  ADD_FAILURE() << "no key " << key << " in\n" << json;
  return 0.0;
}

}  // namespace lsdem::test
