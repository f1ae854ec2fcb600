/// @file OptionChecks.cpp
/// @brief Checks of option values the subcommands share (Commands.h).

#include "Commands.h"

#include "lsdem/io/InputError.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <system_error>

namespace lsdem::apps {

void requirePositive(const std::string& option, double v) {
  if (!(v > 0.0) || !std::isfinite(v)) {
    char buf[64];
    std::snprintf(buf, sizeof(buf), "%g", v);
    throw io::InputError(option, 0, "", std::string("must be positive, got ") + buf);
  }
}

void requireWritableFolder(const std::string& option, const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir, ec)) {
    throw io::InputError(option, 0, "", "cannot make the folder " + dir + (ec ? " (" + ec.message() + ")" : ""));
  }
  // (A probe file, removed again: a folder that exists can still refuse writes.)
  const fs::path probe = fs::path(dir) / ".lsdem_write_probe";
  const bool writable = bool(std::ofstream(probe));
  fs::remove(probe, ec);
  if (!writable) throw io::InputError(option, 0, "", "cannot write in the folder " + dir);
}

}  // namespace lsdem::apps
