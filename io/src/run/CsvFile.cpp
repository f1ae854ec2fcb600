/// @file CsvFile.cpp
/// @brief CsvFile and keptCsvSize (CsvFile.h).

#include "run/CsvFile.h"

#include "lsdem/io/InputError.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string_view>

namespace lsdem::io {

namespace fs = std::filesystem;

namespace {

std::vector<std::string> cells(std::string_view line) {
  std::vector<std::string> out(1);
  for (const char c : line) {
    if (c == ',') {
      out.emplace_back();
    } else {
      out.back() += c;
    }
  }
  return out;
}

}  // namespace

std::string writeError() { return errno != 0 ? std::strerror(errno) : "write failed"; }

std::uint64_t keptCsvSize(const fs::path& path, std::uint64_t recorded, const std::string& header) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw InputError(path.string(), 0, "", "missing or unreadable: the run's outputs are incomplete, cannot resume");
  }
  // Rows are appended under the columns this scene writes.
  std::string first;
  if (std::getline(in, first) && !in.eof() && first != header) {
    throw InputError(path.string(), 1, "", "its columns are not those this scene writes (another scene's file?)");
  }
  in.clear();
  in.seekg(0);
  std::uint64_t read = 0, wholeRows = 0;
  std::string chunk(std::size_t(1) << 20, '\0');
  while (read < recorded) {
    in.read(chunk.data(), std::streamsize(std::min<std::uint64_t>(chunk.size(), recorded - read)));
    const std::size_t n = std::size_t(in.gcount());
    if (n == 0) break;
    const std::size_t nul = std::string_view(chunk.data(), n).find('\0');
    const std::size_t valid = nul == std::string_view::npos ? n : nul;
    const std::size_t lastBreak = std::string_view(chunk.data(), valid).rfind('\n');
    if (lastBreak != std::string_view::npos) wholeRows = read + lastBreak + 1;
    read += valid;
    if (valid < n) break;
  }
  return read == recorded ? recorded : wholeRows;
}

void CsvFile::create(const fs::path& path, const std::string& header) {
  path_ = path;
  columns_ = cells(header);
  out_.open(path, std::ios::trunc | std::ios::binary);
  if (!out_) throw std::runtime_error("cannot write " + path.string() + ": " + writeError());
  write(header + '\n');
}

void CsvFile::resume(const fs::path& path, const std::string& header, std::uint64_t size) {
  path_ = path;
  columns_ = cells(header);
  std::error_code ec;
  fs::resize_file(path, size, ec);
  if (ec) throw std::runtime_error("cannot cut " + path.string() + " back to the checkpoint: " + ec.message());
  out_.open(path, std::ios::app | std::ios::binary);
  if (!out_) throw std::runtime_error("cannot write " + path.string() + ": " + writeError());
  if (size == 0) write(header + '\n');
}

void CsvFile::write(const std::string& rows) {
  checkFinite(rows);
  errno = 0;
  out_ << rows;
  out_.flush();
  if (!out_) throw std::runtime_error("cannot write " + path_.string() + ": " + writeError());
}

std::uint64_t CsvFile::size() {
  out_.flush();
  return std::uint64_t(fs::file_size(path_));
}

// Numbers are written by std::to_chars: a non-finite one is a whole cell
// "inf", "-inf", "nan" or "-nan".
void CsvFile::checkFinite(const std::string& rows) const {
  std::size_t begin = 0;
  while (begin < rows.size()) {
    std::size_t end = rows.find('\n', begin);
    if (end == std::string::npos) end = rows.size();
    const std::vector<std::string> row = cells(std::string_view(rows).substr(begin, end - begin));
    for (std::size_t k = 0; k < row.size(); ++k) {
      const std::string& c = row[k];
      if (c != "inf" && c != "-inf" && c != "nan" && c != "-nan") continue;
      const std::string column = k < columns_.size() ? columns_[k] : "column " + std::to_string(k + 1);
      throw std::runtime_error(path_.string() + ": " + column + " = " + c + " in the row of " + columns_.front() +
                               " " + row.front() +
                               ": the simulation diverged (a non-finite value); the run stops here, the row is "
                               "not written");
    }
    begin = end + 1;
  }
}

}  // namespace lsdem::io
