#pragma once
/// @file CsvFile.h
/// @brief One CSV output of a run (internal to io): appended row by row and
/// flushed, so a run that stops keeps every row written; cut back to a
/// checkpoint's size when a run resumes.

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace lsdem::io {

/// @brief Why the last write failed (a full disk: "No space left on device").
std::string writeError();

/// @brief How many bytes of a CSV file a resumed run keeps: the `recorded`
/// size the checkpoint saw (whole rows; the first is `header`), or, when the
/// file is shorter or holds NUL bytes before that size (cut by a kill or a
/// full disk, or a machine crash that left a block of zeros), what lies before
/// its last whole row. Reads and checks only.
/// @note Throws InputError when the file is missing or its header is not `header`.
std::uint64_t keptCsvSize(const std::filesystem::path& path, std::uint64_t recorded, const std::string& header);

/// @brief A CSV file of the run. Every row is checked before it is written: a
/// non-finite number (the simulation diverged) stops the run instead of
/// reaching the file. A write that fails (a full disk) stops the run, naming
/// the file (std::runtime_error).
class CsvFile {
 public:
  /// A new file holding the header.
  void create(const std::filesystem::path& path, const std::string& header);
  /// A resumed run's file, cut to its first `size` bytes (keptCsvSize) and
  /// appended to; the header again when nothing of it is kept.
  void resume(const std::filesystem::path& path, const std::string& header, std::uint64_t size);
  /// One row (no line break).
  void row(const std::string& line) { write(line + '\n'); }
  /// Whole rows, each ending in a line break.
  void write(const std::string& rows);
  /// Bytes written so far (flushed).
  std::uint64_t size();

 private:
  void checkFinite(const std::string& rows) const;

  std::filesystem::path path_;
  std::vector<std::string> columns_;
  std::ofstream out_;
};

}  // namespace lsdem::io
