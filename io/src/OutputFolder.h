#pragma once
/// @file OutputFolder.h
/// @brief A run's claim on its output folder (internal to io): a lock that
/// stops two runs from writing into one folder at once, and the refusal to
/// write a new run over another run's outputs (docs/reliability.md).

#include <filesystem>
#include <string>
#include <vector>

namespace lsdem::io {

/// The name of the lock file in an output folder.
inline constexpr const char* kLockFile = "lsdem.lock";

/// @brief Exclusive use of an output folder while a run writes into it.
///
/// `DIR/lsdem.lock` holds the owner's pid and is locked with flock(2), so the
/// kernel releases it when the owner dies: a lock file left by a run that was
/// killed (SIGKILL, a crash) is stale and taken over. On a file system
/// without flock the pid decides: a lock whose pid is alive is held. The
/// destructor removes the lock file (also when a run ends by an exception or
/// after Ctrl-C / SIGTERM).
class OutputLock {
 public:
  /// @brief Takes the lock on `dir`, which must exist.
  /// @note Throws InputError naming the lock file when another live run holds
  /// it, std::runtime_error when it cannot be created.
  explicit OutputLock(const std::filesystem::path& dir);
  ~OutputLock();
  OutputLock(const OutputLock&) = delete;
  OutputLock& operator=(const OutputLock&) = delete;

 private:
  std::filesystem::path path_;
  int fd_ = -1;
};

/// @brief The outputs of a run that `dir` holds (file names relative to it:
/// summary.json, history.csv, checkpoint.lsc, the other CSV files, the .pvd
/// series, frames/...), empty when it holds none. The scene copy and the lock
/// file are not counted.
std::vector<std::string> runOutputsIn(const std::filesystem::path& dir);

/// @brief Refuses a new run into `dir` when it holds another run's outputs
/// and `overwrite` is false: InputError naming the folder, the files and the
/// way out (--overwrite, --resume). Refuses it also, `overwrite` or not, when
/// it holds a scene.toml but no run's outputs, other than `sceneText` (the
/// scene of the new run): the user's own file, which the run's copy of its
/// scene would replace.
void checkOutputFolder(const std::filesystem::path& dir, bool overwrite, const std::string& sceneText);

/// @brief Removes the outputs of a previous run from `dir` (those of
/// runOutputsIn and their temporary files, the frames in frames/); other files
/// stay.
void removeRunOutputs(const std::filesystem::path& dir);

}  // namespace lsdem::io
