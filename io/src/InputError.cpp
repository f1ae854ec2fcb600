#include "lsdem/io/InputError.h"

namespace lsdem::io {
namespace {

std::string format(const std::string& file, int line, const std::string& key, const std::string& what) {
  std::string s = file;
  if (line > 0) s.append(":").append(std::to_string(line));
  s.append(": ");
  if (!key.empty()) s.append(key).append(": ");
  return s.append(what);
}

}  // namespace

InputError::InputError(std::string file, int line, std::string key, const std::string& what)
    : std::runtime_error(format(file, line, key, what)),
      file_(std::move(file)),
      line_(line),
      key_(std::move(key)),
      problem_(what) {}

}  // namespace lsdem::io
