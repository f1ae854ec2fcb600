#pragma once
/// @file FuzzFolder.h
/// @brief A scratch folder of the fuzz target's process, for targets whose
/// input is a file (scenes, meshes).

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>

namespace lsdem::fuzz {

/// @brief TMPDIR/lsdem-fuzz-NAME-XXXXXX, made on the first call (one per
/// process; aborts when it cannot be made) and removed with its contents
/// when the process exits normally. After an abort it stays, with the input
/// that broke an invariant in it.
inline const std::filesystem::path& scratchFolder(const char* name) {
  struct Folder {
    std::filesystem::path path;
    ~Folder() {
      std::error_code ignored;
      std::filesystem::remove_all(path, ignored);
    }
  };
  static const Folder folder{[name] {
    std::string pattern =
        (std::filesystem::temp_directory_path() / (std::string("lsdem-fuzz-") + name + "-XXXXXX")).string();
    if (::mkdtemp(pattern.data()) == nullptr) {
      std::fprintf(stderr, "fuzz: cannot make a temporary folder %s\n", pattern.c_str());
      std::abort();
    }
    return std::filesystem::path(pattern);
  }()};
  return folder.path;
}

}  // namespace lsdem::fuzz
