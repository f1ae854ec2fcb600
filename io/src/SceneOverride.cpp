/// @file SceneOverride.cpp
/// @brief overrideScene (SceneOverride.h): the scene parsed with toml++, the
/// settings written into its tables, the table printed back as TOML.

#include "lsdem/io/SceneOverride.h"

#include "lsdem/io/InputError.h"

#include <toml++/toml.h>

#include <sstream>

namespace lsdem::io {
namespace {

std::vector<std::string> splitPath(const std::string& key) {
  std::vector<std::string> parts;
  std::string part;
  std::istringstream in(key);
  while (std::getline(in, part, '.')) parts.push_back(part);
  return parts;
}

// Sets parts[i..] under `table` to `value`; returns how many keys were set.
int setPath(toml::table& table, const std::vector<std::string>& parts, std::size_t i, const toml::node& value,
            const std::string& file, const std::string& key) {
  const std::string& part = parts[i];
  if (i + 1 == parts.size()) {
    if (part == "*") throw InputError(file, 0, key, "the last part of a setting cannot be '*'");
    table.insert_or_assign(part, value);
    return 1;
  }
  if (part == "*") {
    int set = 0;
    for (auto&& [name, node] : table) {
      if (toml::table* sub = node.as_table()) set += setPath(*sub, parts, i + 1, value, file, key);
    }
    if (set == 0) throw InputError(file, 0, key, "'*' matches no table");
    return set;
  }
  toml::node* node = table.get(part);
  if (!node) throw InputError(file, 0, key, "the scene has no table '" + part + "'");
  toml::table* sub = node->as_table();
  if (!sub) throw InputError(file, 0, key, "'" + part + "' is not a table");
  return setPath(*sub, parts, i + 1, value, file, key);
}

}  // namespace

std::string overrideScene(const std::string& text, const std::vector<SceneSetting>& settings, const std::string& file) {
  toml::table scene;
  try {
    scene = toml::parse(text, file);
  } catch (const toml::parse_error& e) {
    throw InputError(file, int(e.source().begin.line), "", "TOML syntax error: " + std::string(e.description()));
  }
  for (const SceneSetting& s : settings) {
    const std::vector<std::string> parts = splitPath(s.key);
    if (parts.empty()) throw InputError(file, 0, s.key, "empty setting key");
    for (const std::string& p : parts) {
      if (p.empty()) throw InputError(file, 0, s.key, "empty part in the dotted key");
    }
    toml::table holder;
    try {
      holder = toml::parse("v = " + s.value, file);
    } catch (const toml::parse_error& e) {
      throw InputError(file, 0, s.key, "bad value '" + s.value + "': " + std::string(e.description()));
    }
    const toml::node* value = holder.get("v");
    if (!value) throw InputError(file, 0, s.key, "bad value '" + s.value + "'");
    setPath(scene, parts, 0, *value, file, s.key);
  }
  std::ostringstream out;
  out << scene << '\n';
  return out.str();
}

std::optional<std::pair<std::string, int>> firstChangedKey(const std::string& before, const std::string& after,
                                                           const std::vector<std::string>& keys) {
  toml::table a, b;
  try {
    a = toml::parse(before);
    b = toml::parse(after);
  } catch (const toml::parse_error&) {
    return std::nullopt;
  }
  // A node as TOML text ("" when absent).
  const auto text = [](const toml::node* n) {
    std::ostringstream s;
    if (n) s << toml::toml_formatter(*n);
    return s.str();
  };
  for (const std::string& key : keys) {
    const toml::node* x = a.get(key);
    const toml::node* y = b.get(key);
    if (text(x) != text(y)) return std::pair(key, y ? int(y->source().begin.line) : 0);
  }
  return std::nullopt;
}

}  // namespace lsdem::io
