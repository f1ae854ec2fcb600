#pragma once
/// @file SceneOverride.h
/// @brief Scene files with some keys replaced: the text of a scene with
/// `section.key = value` settings applied, so a study (or a user) can run a
/// shipped scene at another grid resolution, contact law or seed through
/// exactly the path `lsdem run` takes.

#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace lsdem::io {

/// One replaced key.
struct SceneSetting {
  /// Dotted path of the key ("effects.breakage.seed"). A `*` segment stands
  /// for every table under its parent ("shapes.*.cells_across": the key in
  /// each shape); tables on the path must exist, the last key is added when
  /// missing. Array-of-tables entries (`[[particles]]`) are not addressed.
  std::string key;
  /// The value as TOML text: `20`, `0.5`, `"area_weighted"`, `[]`.
  std::string value;
};

/// @brief The scene `text` with every setting applied, in order, written
/// back as TOML (comments are not kept; keys and values are).
/// @param file name of the scene for messages.
/// @note Throws InputError naming `file` and the key for a syntax error in
/// the text or a value, a table on the path that is missing or is not a
/// table, or a `*` that matches no table.
std::string overrideScene(const std::string& text, const std::vector<SceneSetting>& settings,
                          const std::string& file = "scene");

/// @brief What a forced resume may not change (`lsdem run --resume --force`):
/// the first of the scene texts' shapes and materials (by name), particle
/// groups but feeds, and planes but their own contact materials that differ
/// between `before` (the run's copy) and `after`, compared as data (comments,
/// layout and key order aside; 10 and 10.0 alike), with its key and its line
/// in `after` (0 where it is absent there); nullopt when none differs or a
/// text does not parse (its reader then says why).
std::optional<std::pair<std::string, int>> forcedResumeEdit(const std::string& before, const std::string& after);

}  // namespace lsdem::io
