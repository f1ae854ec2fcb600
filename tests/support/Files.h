#pragma once
/// @file Files.h
/// @brief Test helpers: a file's whole content, and scratch paths of the test
/// process's own.

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <system_error>

namespace lsdem::test {

/// The bytes of file `p` (empty when it cannot be read).
inline std::string readFile(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// TMPDIR/lsdem_test_PID/`name`: a scratch path no other test process uses,
/// so two checkouts (or two ctest runs) on one machine never share files.
/// The folder TMPDIR/lsdem_test_PID is made on first use and removed, with
/// what the tests left in it, when the process exits.
inline std::filesystem::path tempPath(const std::string& name) {
  struct Folder {
    std::filesystem::path path;
    Folder() : path(std::filesystem::temp_directory_path() / ("lsdem_test_" + std::to_string(::getpid()))) {
      std::filesystem::create_directories(path);
    }
    ~Folder() {
      std::error_code ignored;
      std::filesystem::remove_all(path, ignored);
    }
  };
  static const Folder folder;
  return folder.path / name;
}

}  // namespace lsdem::test
