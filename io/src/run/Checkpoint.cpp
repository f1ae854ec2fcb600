/// @file Checkpoint.cpp
/// @brief The checkpoint file (Checkpoint.h).

#include "run/Checkpoint.h"

#include "Checksum.h"
#include "OutputNames.h"

#include "lsdem/io/GrainFile.h"
#include "lsdem/io/InputError.h"
#include "lsdem/io/SceneOverride.h"
#include "lsdem/io/Vtk.h"

#include <cstring>
#include <fstream>
#include <array>
#include <map>
#include <optional>
#include <sstream>

namespace lsdem::io {

namespace fs = std::filesystem;

namespace {

constexpr char kMagic[8] = {'L', 'S', 'D', 'E', 'M', 'C', 'K', 'P'};
// 2: a CRC-32 of everything before it closes the file.
// 3: the run's state is its basis and one section per recorder.
constexpr std::uint32_t kVersion = 3;

// A checkpoint's bytes, its magic, format version and CRC-32 checked, the
// checksum removed.
std::string readCheckpointFile(const std::string& path) {
  std::string bytes = readWholeFile(path);
  if (bytes.size() < 8 || std::memcmp(bytes.data(), kMagic, 8) != 0) {
    throw InputError(path, 0, "", "not an lsdem checkpoint");
  }
  if (bytes.size() < 8 + 4 + 4) throw InputError(path, 0, "", "truncated checkpoint");
  std::uint32_t version = 0;
  std::memcpy(&version, bytes.data() + 8, 4);
  if (version != kVersion) {
    throw InputError(path, 0, "", "checkpoint of another lsdem version (format " + std::to_string(version) +
                                      ", this lsdem reads " + std::to_string(kVersion) + ")");
  }
  std::uint32_t stored = 0;
  std::memcpy(&stored, bytes.data() + bytes.size() - 4, 4);
  if (crc32Of(bytes.data(), bytes.size() - 4) != stored) {
    throw InputError(path, 0, "",
                     "damaged checkpoint: its checksum does not match its contents (a partial copy, a bit flip or an edit)");
  }
  bytes.resize(bytes.size() - 4);
  return bytes;
}

// Reads past a checkpoint's magic and format version (readCheckpointFile
// checked both) and returns its dimension.
std::int32_t readHeader(dynamics::StateReader& in) {
  in.get<std::array<char, 8>>();
  in.get<std::uint32_t>();
  return in.get<std::int32_t>();
}

}  // namespace

std::uint64_t sceneHash(const std::string& text) {
  std::uint64_t h = 1469598103934665603ull;  // FNV-1a
  for (unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  return h;
}

std::string readWholeFile(const std::string& path, bool mustExist) {
  std::ifstream in(path, std::ios::binary);
  if (!in && !mustExist) return {};
  if (!in) throw InputError(path, 0, "", "cannot read the file");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

template <int D>
void writeCheckpoint(const fs::path& file, const std::string& scenePath, std::uint64_t hash,
                     const dynamics::World<D>& world, const std::string& runState) {
  // World state, numbering the particles' shapes as they come.
  std::map<const geometry::Shape<D>*, std::uint32_t> index;
  std::vector<const geometry::Shape<D>*> shapes;
  dynamics::StateWriter state;
  world.saveState(state, [&](const std::shared_ptr<const geometry::Shape<D>>& s) {
    const auto [it, added] = index.emplace(s.get(), std::uint32_t(shapes.size()));
    if (added) shapes.push_back(s.get());
    return it->second;
  });
  // The fields in order; a byte string is its length (uint64) and its bytes.
  dynamics::StateWriter out;
  out.put(kMagic);
  out.put(kVersion);
  out.put(std::int32_t(D));
  out.putString(fs::absolute(scenePath).string());
  out.put(hash);
  out.put(std::uint64_t(shapes.size()));
  for (const geometry::Shape<D>* s : shapes) {
    std::ostringstream g(std::ios::binary);
    writeGrain<D>(g, *s, GrainFormat::Binary);
    out.putString(g.str());
  }
  out.putVector(state.bytes());
  out.putString(runState);
  std::string bytes(out.bytes().begin(), out.bytes().end());
  const std::uint32_t crc = crc32Of(bytes.data(), bytes.size());
  bytes.append(reinterpret_cast<const char*>(&crc), 4);
  writeFileAtomically(file, bytes);
}

template <int D>
std::string loadCheckpoint(const fs::path& file, std::span<dynamics::World<D>* const> worlds) {
  const std::string path = file.string();
  const std::string bytes = readCheckpointFile(path);
  return asCheckpointError(path, [&] {
    dynamics::StateReader in(bytes.data(), bytes.size());
    if (readHeader(in) != D) throw InputError(path, 0, "", "checkpoint of another dimension");
    in.getString();          // scene path, read by resumeScene
    in.get<std::uint64_t>();  // scene hash, checked by resumeScene
    std::vector<std::shared_ptr<const geometry::Shape<D>>> shapes(std::size_t(in.get<std::uint64_t>()));
    for (auto& s : shapes) {
      std::istringstream g(in.getString(), std::ios::binary);
      s = readGrain<D>(g, path);
    }
    const std::string state = in.getString();
    std::string runState = in.getString();
    // Every world from the same bytes and shapes (read and checked once).
    for (dynamics::World<D>* world : worlds) {
      dynamics::StateReader r(state.data(), state.size());
      world->loadState(r, [&](std::uint32_t k) {
        if (k >= shapes.size()) throw std::runtime_error("shape " + std::to_string(k) + " is not in the checkpoint");
        return shapes[k];
      });
    }
    return runState;
  });
}

std::string resumeScene(const RunOptions& options, std::string* forcedNote) {
  const std::string& dir = options.resumeDir;
  const std::string path = (fs::path(dir) / outputs::kCheckpoint).string();
  if (!fs::exists(path)) throw InputError(path, 0, "", "no checkpoint to resume from (is this a run's output folder?)");
  const std::string bytes = readCheckpointFile(path);
  const auto [named, hash] = asCheckpointError(path, [&] {
    dynamics::StateReader in(bytes.data(), bytes.size());
    readHeader(in);
    std::string scenePath = in.getString();
    return std::pair(std::move(scenePath), in.get<std::uint64_t>());
  });

  const fs::path copy = fs::path(dir) / "scene.toml";
  const bool haveCopy = fs::exists(copy);
  const bool copyMatches = haveCopy && sceneHash(readWholeFile(copy.string())) == hash;
  std::string scene = options.scene;
  if (scene.empty()) {
    if (fs::exists(named)) {
      scene = named;
    } else if (haveCopy) {
      scene = copy.string();
    } else {
      throw InputError(path, 0, "", "its scene file " + named + " no longer exists (nor does a copy in " + dir + ")");
    }
  }
  std::optional<InputError> mismatch;
  if (haveCopy && !copyMatches) {
    mismatch.emplace(path, 0, "",
                     "written by a run of another scene than " + copy.string() +
                         " (a checkpoint copied from another run, or an edited copy)");
  } else if (sceneHash(readWholeFile(scene)) != hash) {
    // (The file the checkpoint names, given again: edited, not another scene.)
    std::error_code ec;
    const bool sameFile = options.scene.empty() || fs::equivalent(options.scene, named, ec);
    mismatch.emplace(scene, 0, "",
                     sameFile ? "the scene file changed since the checkpoint in " + dir + " was written"
                              : "not the scene of the run in " + dir + " (its checkpoint names " + named + ")");
  }
  if (!mismatch) return scene;
  if (!options.force) {
    throw InputError(mismatch->file(), 0, "", mismatch->problem() + "; give --force to resume with it anyway");
  }
  // What the checkpoint holds, or runs from the start, must be the run's:
  // the particles (the checkpoint's are restored: an edited list was
  // ignored), their shapes and materials, and the planes, whose positions
  // are functions of time from the start (a new velocity moved a platen 1.2
  // mm into the grains in one step). (A feed may be given more grains, a
  // tool key frames past the checkpoint, as unloading added after a
  // loading: docs/outputs.md; Run checks the tools' poses at the
  // checkpoint against its own, checkToolPoses.)
  if (copyMatches) {
    if (const auto edit = forcedResumeEdit(readWholeFile(copy.string()), readWholeFile(scene))) {
      throw InputError(scene, edit->second, edit->first,
                       "differs from the run's (" + copy.string() +
                           "): a forced resume takes the scene's output, end, contact law, effects, feeds and "
                           "tools as they are now, but its particles, shapes, materials and planes must be the run's");
    }
  }
  const std::string note = std::string(mismatch->what()) + ": resumed with " + scene + " anyway (--force)";
  if (forcedNote) {
    *forcedNote = note;
  } else if (options.note) {
    options.note(note);
  }
  return scene;
}

template void writeCheckpoint<2>(const fs::path&, const std::string&, std::uint64_t, const dynamics::World<2>&,
                                 const std::string&);
template void writeCheckpoint<3>(const fs::path&, const std::string&, std::uint64_t, const dynamics::World<3>&,
                                 const std::string&);
template std::string loadCheckpoint<2>(const fs::path&, std::span<dynamics::World<2>* const>);
template std::string loadCheckpoint<3>(const fs::path&, std::span<dynamics::World<3>* const>);

}  // namespace lsdem::io
