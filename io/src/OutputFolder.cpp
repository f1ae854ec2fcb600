/// @file OutputFolder.cpp
/// @brief The output folder's lock and the check for another run's outputs
/// (OutputFolder.h).

#include "OutputFolder.h"
#include "OutputNames.h"
#include "run/Checkpoint.h"

#include "lsdem/io/InputError.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <stdexcept>

namespace lsdem::io {
namespace {

namespace fs = std::filesystem;

// The files a run writes into its folder, besides scene.toml and frames/
// (OutputNames.h): its files and its series' .pvd files.
std::vector<std::string> outputFiles() {
  std::vector<std::string> names(outputs::kFiles.begin(), outputs::kFiles.end());
  for (const char* series : outputs::kSeries) names.push_back(std::string(series) + ".pvd");
  return names;
}

// A frame of a ParaView series: frames/<series>_NNNNNN.vtp (or its temporary file).
bool isFrameFile(const std::string& name) {
  for (const char* series : outputs::kSeries) {
    if (name.rfind(std::string(series) + "_", 0) != 0) continue;
    // (.pvtp: a distributed run's index of the ranks' pieces.)
    return name.ends_with(".vtp") || name.ends_with(".vtp.tmp") || name.ends_with(".pvtp") ||
           name.ends_with(".pvtp.tmp");
  }
  return false;
}

// The pid written in the lock file open as `fd`; 0 when there is none.
long pidIn(int fd) {
  char buf[32] = {};
  const ssize_t n = ::pread(fd, buf, sizeof(buf) - 1, 0);
  long pid = 0;
  if (n > 0) std::from_chars(buf, buf + n, pid);
  return pid;
}

[[noreturn]] void refuseHeld(const fs::path& path, long pid) {
  throw InputError(path.string(), 0, "",
                   "another lsdem run" + (pid > 0 ? " (pid " + std::to_string(pid) + ")" : std::string()) +
                       " is writing into this folder; wait for it to end, or stop it");
}

}  // namespace

OutputLock::OutputLock(const fs::path& dir) : path_(dir / kLockFile) {
  // A run that ends removes its lock file: the file locked must still be the
  // one at the path, or the lock is taken again on the new file.
  for (int attempt = 0; attempt < 100; ++attempt) {
    const int fd = ::open(path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) throw std::runtime_error("cannot create the lock file " + path_.string() + ": " + std::strerror(errno));
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int error = errno;
      const long pid = pidIn(fd);
      // Without flock on this file system, a live pid holds the folder.
      const bool alive = pid > 0 && pid != long(::getpid()) && (::kill(pid_t(pid), 0) == 0 || errno == EPERM);
      if (error == EWOULDBLOCK || alive) {
        ::close(fd);
        refuseHeld(path_, pid);
      }
    }
    struct stat opened {}, named {};
    if (::fstat(fd, &opened) == 0 && ::stat(path_.c_str(), &named) == 0 && opened.st_ino == named.st_ino &&
        opened.st_dev == named.st_dev) {
      // Ours: the pid replaces whatever a dead owner left.
      const std::string pid = std::to_string(::getpid()) + "\n";
      if (::ftruncate(fd, 0) != 0 || ::pwrite(fd, pid.data(), pid.size(), 0) != ssize_t(pid.size())) {
        const std::string reason = std::strerror(errno);
        ::close(fd);
        throw std::runtime_error("cannot write the lock file " + path_.string() + ": " + reason);
      }
      fd_ = fd;
      return;
    }
    ::close(fd);
  }
  throw std::runtime_error("cannot lock " + path_.string() + ": other runs keep replacing it");
}

OutputLock::~OutputLock() {
  if (fd_ < 0) return;
  // Removed while still locked, and only if it is still ours.
  struct stat opened {}, named {};
  if (::fstat(fd_, &opened) == 0 && ::stat(path_.c_str(), &named) == 0 && opened.st_ino == named.st_ino &&
      opened.st_dev == named.st_dev) {
    ::unlink(path_.c_str());
  }
  ::close(fd_);
}

std::vector<std::string> runOutputsIn(const fs::path& dir) {
  std::vector<std::string> found;
  std::error_code ec;
  for (const std::string& name : outputFiles()) {
    if (fs::exists(dir / name, ec)) found.push_back(name);
  }
  if (fs::is_directory(dir / "frames", ec)) {
    for (const fs::directory_entry& e : fs::directory_iterator(dir / "frames", ec)) {
      if (!isFrameFile(e.path().filename().string())) continue;
      found.emplace_back("frames/");
      break;
    }
  }
  return found;
}

void checkOutputFolder(const fs::path& dir, bool overwrite, const std::string& sceneText) {
  const std::vector<std::string> found = runOutputsIn(dir);
  // A scene.toml in a folder without a run's outputs is the user's own file
  // (a run writes its scene's copy there): it is not replaced, --overwrite
  // or not, unless it is the very scene being run.
  std::error_code ec;
  const fs::path copy = dir / "scene.toml";
  if (found.empty() && fs::exists(copy, ec) && readWholeFile(copy.string(), false) != sceneText) {
    throw InputError(copy.string(), 0, "",
                     "is not a run's copy of its scene, and a run writes its scene's copy there; choose another "
                     "output folder (--out)");
  }
  if (overwrite || found.empty()) return;
  std::string files;
  for (std::size_t k = 0; k < found.size() && k < 3; ++k) files += (k > 0 ? ", " : "") + found[k];
  if (found.size() > 3) files += ", ...";
  throw InputError(dir.string(), 0, "",
                   "holds the outputs of another run (" + files +
                       "); give --overwrite to replace them, or continue that run with --resume " + dir.string());
}

void removeRunOutputs(const fs::path& dir) {
  const auto remove = [](const fs::path& file) {
    std::error_code ec;
    fs::remove(file, ec);
    if (ec) throw std::runtime_error("cannot remove the previous run's " + file.string() + ": " + ec.message());
  };
  for (const std::string& name : outputFiles()) {
    remove(dir / name);
    remove(dir / (name + ".tmp"));
  }
  std::error_code ec;
  if (!fs::is_directory(dir / "frames", ec)) return;
  std::vector<fs::path> frames;
  for (const fs::directory_entry& e : fs::directory_iterator(dir / "frames", ec)) {
    if (isFrameFile(e.path().filename().string())) frames.push_back(e.path());
  }
  for (const fs::path& f : frames) remove(f);
  if (fs::is_empty(dir / "frames", ec)) fs::remove(dir / "frames", ec);
}

}  // namespace lsdem::io
