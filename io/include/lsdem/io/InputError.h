#pragma once
/// @file InputError.h
/// @brief The one error type for bad user input (scene and shape files, grain
/// files, meshes): it carries where the problem is, so the command line can print
/// a single line "FILE:LINE: KEY: what is wrong" and exit non-zero.

#include <stdexcept>
#include <string>

namespace lsdem::io {

class InputError : public std::runtime_error {
 public:
  /// @param file  the input file as the user named it
  /// @param line  1-based line of the offending key, 0 when unknown
  /// @param key   dotted key path ("shape.radius"), empty when not about a key
  /// @param what  what is wrong, e.g. "must be positive, got -1"
  /// what() is always one line: control characters in the file name, key or
  /// problem (a newline a parser echoes from the file) are written as escapes
  /// ("\n", "\x00").
  InputError(std::string file, int line, std::string key, const std::string& what);

  const std::string& file() const { return file_; }
  int line() const { return line_; }
  const std::string& key() const { return key_; }
  /// @brief The problem alone, without the location.
  const std::string& problem() const { return problem_; }

 private:
  std::string file_;
  int line_;
  std::string key_;
  std::string problem_;
};

}  // namespace lsdem::io
