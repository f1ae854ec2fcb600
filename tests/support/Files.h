#pragma once
/// @file Files.h
/// @brief Test helper: a file's whole content.

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace lsdem::test {

/// The bytes of file `p` (empty when it cannot be read).
inline std::string readFile(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace lsdem::test
