#pragma once
/// @file TomlReader.h
/// @brief Private to io: typed, validated access to one TOML table, with
/// errors that name the file, the line and the dotted key. Every key read is
/// remembered, so `finish()` can reject the keys nobody asked for (typos).

#include "NumberText.h"
#include "lsdem/io/InputError.h"

#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <initializer_list>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

namespace lsdem::io::detail {

class TomlReader {
 public:
  /// @param table  the table to read
  /// @param file   file name for messages
  /// @param path   dotted path of the table ("shape"), prefixed to keys in messages
  TomlReader(const toml::table& table, std::string file, std::string path)
      : table_(table), file_(std::move(file)), path_(std::move(path)) {}

  const std::string& file() const { return file_; }
  bool has(const std::string& key) const { return table_.contains(key); }
  /// @brief The line of each key of the table.
  std::map<std::string, int> keyLines() const {
    std::map<std::string, int> out;
    for (auto&& [key, node] : table_) out[std::string(key.str())] = int(node.source().begin.line);
    return out;
  }

  /// @brief An InputError at `key` (its line when present, the table's otherwise).
  [[noreturn]] void fail(const std::string& key, const std::string& what) const {
    const toml::node* n = table_.get(key);
    const int line = n ? int(n->source().begin.line) : int(table_.source().begin.line);
    throw InputError(file_, line, key.empty() ? path_ : dotted(key), what);
  }

  /// @brief The error for a required key that is absent; where the table
  /// has a key not read yet one typo away (keys of 5 characters or more),
  /// it is named as a likely misspelling.
  [[noreturn]] void missing(const std::string& key) const {
    std::string hint;
    if (key.size() >= 5) {
      for (const auto& [k, v] : table_) {
        const std::string other(k.str());
        if (!used_.count(other) && editDistance(other, key) <= 1) {
          hint = " ('" + other + "' on line " + std::to_string(k.source().begin.line) + ": misspelt?)";
          break;
        }
      }
    }
    fail("", "missing key '" + key + "'" + hint);
  }

  /// @brief A number (integers accepted), finite; `nullopt` when absent.
  std::optional<double> optionalNumber(const std::string& key) {
    const toml::node* n = take(key);
    if (!n) return std::nullopt;
    const std::optional<double> v = n->is_number() ? n->value<double>() : std::nullopt;
    if (!v) fail(key, "expected a number, got " + typeName(*n));
    if (!std::isfinite(*v)) fail(key, "must be finite, got " + toString(*v));
    return v;
  }
  double number(const std::string& key) {
    const auto v = optionalNumber(key);
    if (!v) missing(key);
    return *v;
  }
  double number(const std::string& key, double fallback) { return optionalNumber(key).value_or(fallback); }

  /// @brief A number > 0 (required, or with a default).
  double positive(const std::string& key) { return checkPositive(key, number(key)); }
  double positive(const std::string& key, double fallback) {
    return has(key) ? checkPositive(key, number(key)) : fallback;
  }
  /// @brief A number >= 0 (required, or with a default); `unit` names it in
  /// the message ("must be >= 0 s, got -1").
  double nonNegative(const std::string& key, const std::string& unit = "") {
    return checkNonNegative(key, number(key), unit);
  }
  double nonNegative(const std::string& key, double fallback, const std::string& unit) {
    return has(key) ? checkNonNegative(key, number(key), unit) : fallback;
  }
  /// @brief A number in [lo, hi].
  double inRange(const std::string& key, double lo, double hi, double fallback) {
    const double v = number(key, fallback);
    if (v < lo || v > hi) fail(key, "must be in [" + toString(lo) + ", " + toString(hi) + "], got " + toString(v));
    return v;
  }

  /// @brief An integer; `nullopt` when absent.
  std::optional<std::int64_t> optionalInteger(const std::string& key) {
    const toml::node* n = take(key);
    if (!n) return std::nullopt;
    if (!n->is_integer()) fail(key, "expected an integer, got " + typeName(*n));
    return n->value<std::int64_t>();
  }
  std::int64_t integer(const std::string& key) {
    const auto v = optionalInteger(key);
    if (!v) missing(key);
    return *v;
  }
  std::int64_t integer(const std::string& key, std::int64_t fallback) { return optionalInteger(key).value_or(fallback); }

  /// @brief A string; `nullopt` when absent.
  std::optional<std::string> optionalString(const std::string& key) {
    const toml::node* n = take(key);
    if (!n) return std::nullopt;
    if (!n->is_string()) fail(key, "expected a string, got " + typeName(*n));
    return n->value<std::string>();
  }
  std::string string(const std::string& key) {
    const auto v = optionalString(key);
    if (!v) missing(key);
    return *v;
  }
  std::string string(const std::string& key, const std::string& fallback) { return optionalString(key).value_or(fallback); }
  /// @brief A string that must be one of `choices` (`fallback` when the key is absent).
  std::string choice(const std::string& key, std::initializer_list<std::string_view> choices,
                     const std::string& fallback) {
    const std::string v = string(key, fallback);
    std::string list;
    for (const std::string_view c : choices) {
      if (c == v) return v;
      list += (list.empty() ? "" : ", ") + std::string(c);
    }
    fail(key, "unknown choice '" + v + "' (" + list + ")");
  }

  /// @brief An array of exactly `count` finite numbers (count < 0: any length >= 1).
  std::vector<double> numbers(const std::string& key, int count) {
    const toml::node* n = take(key);
    if (!n) missing(key);
    return numbersOf(key, *n, count);
  }

  /// @brief An array of arrays of `count` numbers each (polygon vertices).
  std::vector<std::vector<double>> numberRows(const std::string& key, int count) {
    const toml::node* n = take(key);
    if (!n) missing(key);
    const toml::array* a = n->as_array();
    if (!a || a->empty()) fail(key, "expected an array of [" + std::to_string(count) + " numbers] rows");
    std::vector<std::vector<double>> rows;
    for (std::size_t i = 0; i < a->size(); ++i) {
      rows.push_back(numbersOf(key + "[" + std::to_string(i) + "]", *a->get(i), count));
    }
    return rows;
  }

  /// @brief A boolean; `fallback` when absent.
  bool boolean(const std::string& key, bool fallback) {
    const toml::node* n = take(key);
    if (!n) return fallback;
    if (!n->is_boolean()) fail(key, "expected true or false, got " + typeName(*n));
    return *n->value<bool>();
  }

  /// @brief A sub-table; nullptr when absent.
  const toml::table* optionalTable(const std::string& key) {
    const toml::node* n = take(key);
    if (!n) return nullptr;
    if (!n->is_table()) fail(key, "expected a table, got " + typeName(*n));
    return n->as_table();
  }
  /// @brief An array of tables (`[[key]]`); empty when absent.
  std::vector<const toml::table*> tables(const std::string& key) {
    std::vector<const toml::table*> out;
    const toml::node* n = take(key);
    if (!n) return out;
    const toml::array* a = n->as_array();
    if (!a) fail(key, "expected an array of tables ([[" + key + "]]), got " + typeName(*n));
    for (const toml::node& e : *a) {
      if (!e.is_table()) fail(key, "expected tables ([[" + key + "]]), got " + typeName(e));
      out.push_back(e.as_table());
    }
    return out;
  }
  /// @brief An array of strings (a single string is accepted as a list of one).
  std::vector<std::string> strings(const std::string& key) {
    std::vector<std::string> out;
    const toml::node* n = take(key);
    if (!n) return out;
    if (n->is_string()) return {*n->value<std::string>()};
    const toml::array* a = n->as_array();
    if (!a) fail(key, "expected a string or an array of strings, got " + typeName(*n));
    for (const toml::node& e : *a) {
      if (!e.is_string()) fail(key, "expected strings, got " + typeName(e));
      out.push_back(*e.value<std::string>());
    }
    return out;
  }
  /// @brief The line of `key` (the table's line when absent).
  int lineOf(const std::string& key) const {
    const toml::node* n = table_.get(key);
    return n ? int(n->source().begin.line) : int(table_.source().begin.line);
  }
  /// @brief The dotted path of a key of this table.
  std::string pathOf(const std::string& key) const { return dotted(key); }

  /// @brief Rejects any key of the table that was not read: catches typos.
  void finish() const {
    for (const auto& [k, v] : table_) {
      const std::string key(k.str());
      if (!used_.count(key)) {
        throw InputError(file_, int(k.source().begin.line), dotted(key), "unknown key");
      }
    }
  }
  /// @brief Marks a key as read without reading it (it belongs to another reader).
  void skip(const std::string& key) { used_.insert(key); }

 private:
  const toml::node* take(const std::string& key) {
    used_.insert(key);
    return table_.get(key);
  }
  std::string dotted(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }
  // Edits (insert, delete, replace a character) from a to b.
  static std::size_t editDistance(const std::string& a, const std::string& b) {
    std::vector<std::size_t> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
      std::size_t diagonal = row[0];
      row[0] = i;
      for (std::size_t j = 1; j <= b.size(); ++j) {
        const std::size_t above = row[j];
        row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0u : 1u)});
        diagonal = above;
      }
    }
    return row[b.size()];
  }
  double checkNonNegative(const std::string& key, double v, const std::string& unit) const {
    if (!(v >= 0.0)) fail(key, "must be >= 0" + (unit.empty() ? "" : " " + unit) + ", got " + toString(v));
    return v;
  }
  double checkPositive(const std::string& key, double v) const {
    if (!(v > 0.0)) fail(key, "must be positive, got " + toString(v));
    return v;
  }
  std::vector<double> numbersOf(const std::string& key, const toml::node& n, int count) const {
    const toml::array* a = n.as_array();
    if (!a) {
      throw InputError(file_, int(n.source().begin.line), dotted(key), "expected an array of numbers, got " + typeName(n));
    }
    if ((count >= 0 && int(a->size()) != count) || a->empty()) {
      throw InputError(file_, int(n.source().begin.line), dotted(key),
                       "expected " + (count >= 0 ? std::to_string(count) : std::string("at least 1")) + " numbers, got " +
                           std::to_string(a->size()));
    }
    std::vector<double> out;
    for (const toml::node& e : *a) {
      const std::optional<double> v = e.is_number() ? e.value<double>() : std::nullopt;
      if (!v) throw InputError(file_, int(e.source().begin.line), dotted(key), "expected numbers, got " + typeName(e));
      if (!std::isfinite(*v)) throw InputError(file_, int(e.source().begin.line), dotted(key), "must be finite");
      out.push_back(*v);
    }
    return out;
  }
  static std::string typeName(const toml::node& n) {
    switch (n.type()) {
      case toml::node_type::string: return "a string";
      case toml::node_type::integer: return "an integer";
      case toml::node_type::floating_point: return "a number";
      case toml::node_type::boolean: return "a boolean";
      case toml::node_type::array: return "an array";
      case toml::node_type::table: return "a table";
      default: return "a date/time";
    }
  }
  // (Shortest round-trip text: a value just inside or outside a bound is
  // not rounded onto it, as 0.9999999 was to "1".)
  static std::string toString(double v) { return numberText(v); }

  const toml::table& table_;
  std::string file_;
  std::string path_;
  std::set<std::string> used_;
};

/// @brief Parses a TOML file, turning syntax errors and unreadable files into InputError.
inline toml::table parseTomlFile(const std::string& path) {
  // (A folder reads as an empty file: its tables would then be missing.)
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw InputError(path, 0, "", "is a folder, not a TOML file");
  try {
    return toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    const std::string what(e.description());
    if (e.source().begin.line == 0) throw InputError(path, 0, "", "cannot read the file (" + what + ")");
    throw InputError(path, int(e.source().begin.line), "", "TOML syntax error: " + what);
  }
}

}  // namespace lsdem::io::detail
