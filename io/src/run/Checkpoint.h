#pragma once
/// @file Checkpoint.h
/// @brief The checkpoint file of a run, `checkpoint.lsc` (internal to io;
/// docs/reliability.md): magic, format version, dimension, the scene's path
/// and hash, the particles' shapes (binary grain files), the world's state,
/// the run's own state (its basis, every recorder's and schedule's), and a
/// CRC-32 of all of it.

#include "lsdem/dynamics/World.h"
#include "lsdem/io/InputError.h"
#include "lsdem/io/Run.h"

#include <cstdint>
#include <filesystem>
#include <span>
#include <stdexcept>
#include <string>

namespace lsdem::io {

/// @brief Runs `read` (reading a checkpoint's fields or state) and turns a
/// std::runtime_error it throws (a field past the end, a corrupt state) into
/// an InputError naming the checkpoint `path`; InputErrors pass as they are.
template <class F>
auto asCheckpointError(const std::string& path, F&& read) -> decltype(read()) {
  try {
    return read();
  } catch (const InputError&) {
    throw;
  } catch (const std::runtime_error& e) {
    throw InputError(path, 0, "", e.what());
  }
}

/// @brief A hash of a scene file's text: the run's identity in its checkpoints.
std::uint64_t sceneHash(const std::string& text);

/// @brief A file's bytes; a file that cannot be read is an InputError, or
/// empty when it need not exist.
std::string readWholeFile(const std::string& path, bool mustExist = true);

/// @brief Writes the checkpoint of `world` and the run's state `runState` to
/// `file`, atomically.
template <int D>
void writeCheckpoint(const std::filesystem::path& file, const std::string& scenePath, std::uint64_t hash,
                     const dynamics::World<D>& world, const std::string& runState);

/// @brief Restores each of `worlds` from the checkpoint `file` (read and
/// checked once; the worlds share its shapes: a distributed run's part and
/// view) and returns the run's state as writeCheckpoint took it.
/// @note Throws InputError naming the file when it is not a checkpoint of
/// this lsdem and dimension, or is damaged.
template <int D>
std::string loadCheckpoint(const std::filesystem::path& file, std::span<dynamics::World<D>* const> worlds);

/// @brief The scene a resumed run uses: the one given, else the one the
/// checkpoint names, else (it moved) the copy in the output folder. It must be
/// the checkpoint's scene, and the folder's copy too (a checkpoint copied in
/// from another run is not this folder's), unless `options.force`. A forced
/// resume's note goes to `forcedNote` where given (the run says it once its
/// own checks pass), else to `options.note`.
std::string resumeScene(const RunOptions& options, std::string* forcedNote = nullptr);

extern template void writeCheckpoint<2>(const std::filesystem::path&, const std::string&, std::uint64_t,
                                        const dynamics::World<2>&, const std::string&);
extern template void writeCheckpoint<3>(const std::filesystem::path&, const std::string&, std::uint64_t,
                                        const dynamics::World<3>&, const std::string&);
extern template std::string loadCheckpoint<2>(const std::filesystem::path&, std::span<dynamics::World<2>* const>);
extern template std::string loadCheckpoint<3>(const std::filesystem::path&, std::span<dynamics::World<3>* const>);

}  // namespace lsdem::io
