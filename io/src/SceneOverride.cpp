/// @file SceneOverride.cpp
/// @brief overrideScene (SceneOverride.h): the scene parsed with toml++, the
/// settings written into its tables, the table printed back as TOML.

#include "lsdem/io/SceneOverride.h"

#include "lsdem/io/InputError.h"

#include <toml++/toml.h>

#include <algorithm>
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

namespace {

// Whether two TOML nodes hold the same scene data: numbers by value (10 and
// 10.0 are one value to a scene), tables by key, arrays entry by entry; a
// table's keys in `ignored` are left out.
bool sameData(const toml::node& a, const toml::node& b, const std::vector<std::string>& ignored = {}) {
  if (a.is_number() && b.is_number()) return a.value<double>() == b.value<double>();
  if (a.type() != b.type()) return false;
  if (const toml::table* x = a.as_table()) {
    const toml::table& y = *b.as_table();
    const auto counted = [&](const toml::table& t) {
      std::size_t n = 0;
      for (auto&& [key, node] : t) n += std::find(ignored.begin(), ignored.end(), std::string(key.str())) == ignored.end();
      return n;
    };
    if (counted(*x) != counted(y)) return false;
    for (auto&& [key, node] : *x) {
      if (std::find(ignored.begin(), ignored.end(), std::string(key.str())) != ignored.end()) continue;
      const toml::node* other = y.get(key.str());
      if (!other || !sameData(node, *other)) return false;
    }
    return true;
  }
  if (const toml::array* x = a.as_array()) {
    const toml::array& y = *b.as_array();
    if (x->size() != y.size()) return false;
    for (std::size_t k = 0; k < x->size(); ++k) {
      if (!sameData(*x->get(k), *y.get(k))) return false;
    }
    return true;
  }
  if (a.is_string()) return a.value<std::string>() == b.value<std::string>();
  if (a.is_boolean()) return a.value<bool>() == b.value<bool>();
  std::ostringstream x, y;  // dates and times: as written
  x << toml::toml_formatter(a);
  y << toml::toml_formatter(b);
  return x.str() == y.str();
}

// The entries of an array of tables (`[[particles]]`), but feeds (`placement
// = "feed"`) where `skipFeeds`.
std::vector<const toml::node*> entries(const toml::node* array, bool skipFeeds) {
  std::vector<const toml::node*> out;
  if (const toml::array* a = array ? array->as_array() : nullptr) {
    for (const toml::node& n : *a) {
      const toml::table* t = n.as_table();
      const auto* placement = t ? t->get_as<std::string>("placement") : nullptr;
      if (!(skipFeeds && placement && placement->get() == "feed")) out.push_back(&n);
    }
  }
  return out;
}

}  // namespace

std::optional<std::pair<std::string, int>> forcedResumeEdit(const std::string& before, const std::string& after) {
  toml::table a, b;
  try {
    a = toml::parse(before);
    b = toml::parse(after);
  } catch (const toml::parse_error&) {
    return std::nullopt;
  }
  const auto lineOf = [](const toml::node* n) { return n ? int(n->source().begin.line) : 0; };
  // Shapes and materials: each named table.
  for (const char* key : {"shapes", "materials"}) {
    const toml::table* x = a.get_as<toml::table>(key);
    const toml::table* y = b.get_as<toml::table>(key);
    if (!x && !y) continue;
    if (!x || !y) return std::pair(std::string(key), lineOf(y));
    for (auto&& [name, node] : *y) {
      const toml::node* old = x->get(name.str());
      if (!old || !sameData(*old, node)) return std::pair(std::string(key) + "." + std::string(name.str()), lineOf(&node));
    }
    for (auto&& [name, node] : *x) {
      if (!y->get(name.str())) return std::pair(std::string(key) + "." + std::string(name.str()), lineOf(y));
    }
  }
  // The particle groups but feeds (a feed may be given more grains to come),
  // and the planes but their own contact materials (as [contact] may change).
  struct Entries {
    std::string key;
    bool skipFeeds;
    std::vector<std::string> ignored;
  };
  for (const Entries& e : {Entries{"particles", true, {}}, Entries{"planes", false, {"material"}}}) {
    const std::string& key = e.key;
    const std::vector<std::string>& ignored = e.ignored;
    const std::vector<const toml::node*> x = entries(a.get(key), e.skipFeeds);
    const std::vector<const toml::node*> y = entries(b.get(key), e.skipFeeds);
    for (std::size_t k = 0; k < std::max(x.size(), y.size()); ++k) {
      if (k < x.size() && k < y.size() && sameData(*x[k], *y[k], ignored)) continue;
      return std::pair(key, k < y.size() ? lineOf(y[k]) : lineOf(b.get(key)));
    }
  }
  return std::nullopt;
}

}  // namespace lsdem::io
