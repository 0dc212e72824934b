#pragma once
// The strict reader of one TOML table of a scene: typed getters with defaults and checks (a wrong
// type or a non-physical value throws InputError naming file, line, column, the field and what would
// be valid), and unknown-key detection (every key no getter asked for is reported, with the closest
// known one). Every key asked for must be in the schema (scene_schema.h). Loader side only: it is
// one of the files that use toml++.
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <toml++/toml.h>

#include "engine/input_error.h"
#include "engine/scene_schema.h"
#include "engine/types.h"

namespace dem::loader {

/// Levenshtein distance of two keys (for did-you-mean suggestions).
std::size_t edit_distance(const std::string& a, const std::string& b);

/// "a, b, c".
std::string join(const std::vector<std::string>& items);

/// A table's path without array indices: "contacts[2].normal_damping" -> "contacts.normal_damping".

std::string schema_path(const std::string& path);

/// " (unit)" for a unit other than "" and "–", else nothing.
std::string with_unit(const std::string& unit);

/// Reads one TOML table: typed getters with defaults and checks, and unknown-key detection.
class TableReader {
 public:
  TableReader(const toml::table& table, std::string path, const std::string& file)
      : table_(table), path_(std::move(path)), file_(file), schema_path_(schema_path(path_)) {}

  std::string field(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

  [[noreturn]] void fail(const std::string& key, const std::string& message) const {
    const toml::node* node = table_.get(key);
    if (!node) {
      // A missing key is often a misspelt one: point at the near miss and name the key wanted.
      if (const auto near = near_miss(key))
        fail_at(near->second, key, message + "; found '" + near->first + "': did you mean '" + key + "'?");
    }
    fail_at(node, key, message);
  }

  /// Like fail, located at `node` (the table itself when null).
  [[noreturn]] void fail_at(const toml::node* node, const std::string& key, const std::string& message) const {
    const toml::source_region& where = node ? node->source() : table_.source();
    throw InputError(file_, static_cast<int>(where.begin.line), static_cast<int>(where.begin.column), field(key),
                     message + (where.begin.line == 0 ? " (set on the command line)" : ""));
  }

  /// The key of this table closest to `key` that no getter has asked for: edit distance 1 for short keys,
  /// up to 3 for long ones (so "max" is not taken for a misspelt "min").
  std::optional<std::pair<std::string, const toml::node*>> near_miss(const std::string& key) const {
    std::optional<std::pair<std::string, const toml::node*>> best;
    std::size_t best_distance = std::min<std::size_t>(4, std::max<std::size_t>(2, key.size() / 5 + 1));
    for (const auto& [k, value] : table_) {
      const std::string name(k.str());
      if (used_.count(name)) continue;
      const std::size_t d = edit_distance(name, key);
      if (d > 0 && d < best_distance) best.emplace(name, &value), best_distance = d;
    }
    return best;
  }

  bool has(const std::string& key) {
    use(key);
    return table_.contains(key);
  }

  std::optional<Real> optional_real(const std::string& key) {
    use(key);
    const toml::node* node = table_.get(key);
    if (!node) return std::nullopt;
    if (auto v = node->value_exact<double>()) return *v;
    if (auto v = node->value_exact<int64_t>()) return static_cast<Real>(*v);
    fail(key, "expected a number");
  }

  Real real(const std::string& key, Real fallback) { return optional_real(key).value_or(fallback); }

  Real positive(const std::string& key, Real fallback) {
    const Real v = real(key, fallback);
    if (!(v > 0) || !std::isfinite(v)) fail(key, "must be a finite number > 0" + unit(key) + ", got " + number(v));
    return v;
  }

  Real non_negative(const std::string& key, Real fallback) {
    const Real v = real(key, fallback);
    if (!(v >= 0) || !std::isfinite(v)) fail(key, "must be a finite number >= 0" + unit(key) + ", got " + number(v));
    return v;
  }

  Real required_positive(const std::string& key) {
    if (!table_.contains(key)) fail(key, "is required: a finite number > 0" + unit(key));
    return positive(key, 0);
  }

  int integer(const std::string& key, int fallback) {
    use(key);
    const toml::node* node = table_.get(key);
    if (!node) return fallback;
    if (auto v = node->value_exact<int64_t>()) {
      if (*v < std::numeric_limits<int>::min() || *v > std::numeric_limits<int>::max())
        fail(key, "integer out of range (at most " + std::to_string(std::numeric_limits<int>::max()) + ")");
      return static_cast<int>(*v);
    }
    fail(key, "expected an integer");
  }

  /// A non-negative 64-bit integer (seeds).
  std::uint64_t unsigned_integer(const std::string& key, std::uint64_t fallback) {
    use(key);
    const toml::node* node = table_.get(key);
    if (!node) return fallback;
    if (auto v = node->value_exact<int64_t>(); v && *v >= 0) return static_cast<std::uint64_t>(*v);
    fail(key, "expected a non-negative integer");
  }

  bool boolean(const std::string& key, bool fallback) {
    use(key);
    const toml::node* node = table_.get(key);
    if (!node) return fallback;
    if (auto v = node->value_exact<bool>()) return *v;
    fail(key, "expected true or false");
  }

  std::string string(const std::string& key, const std::string& fallback) {
    use(key);
    const toml::node* node = table_.get(key);
    if (!node) return fallback;
    if (auto v = node->value_exact<std::string>()) return *v;
    fail(key, "expected a string");
  }

  /// A string that must be one of `choices`; returns its index.
  std::size_t choice(const std::string& key, const std::vector<std::string>& choices, std::size_t fallback) {
    if (!table_.contains(key)) {
      use(key);
      return fallback;
    }
    const std::string v = string(key, "");
    for (std::size_t i = 0; i < choices.size(); ++i)
      if (choices[i] == v) return i;
    fail(key, "'" + v + "' is not valid; expected one of: " + join(choices));
  }

  Vec3 vec3(const std::string& key, const Vec3& fallback) {
    use(key);
    const toml::node* node = table_.get(key);
    if (!node) return fallback;
    const toml::array* a = node->as_array();
    if (!a || a->size() != 3) fail(key, "expected an array of 3 numbers [x, y, z]" + unit(key));
    Vec3 v;
    for (std::size_t i = 0; i < 3; ++i) {
      const toml::node& e = *a->get(i);
      if (auto d = e.value_exact<double>()) v[static_cast<int>(i)] = *d;
      else if (auto n = e.value_exact<int64_t>()) v[static_cast<int>(i)] = static_cast<Real>(*n);
      else fail_at(e.source().begin.line == 0 ? &e : node, key, "expected an array of 3 numbers [x, y, z]" + unit(key));
    }
    if (!v.allFinite()) fail(key, "components must be finite");
    return v;
  }

  /// An array of points [[x, y, z], ...].
  std::vector<Vec3> vec3_list(const std::string& key) {
    use(key);
    std::vector<Vec3> out;
    const toml::node* node = table_.get(key);
    if (!node) return out;
    const toml::array* a = node->as_array();
    if (!a) fail(key, "expected an array of points [[x, y, z], ...]");
    for (const toml::node& e : *a) {
      const toml::array* p = e.as_array();
      if (!p || p->size() != 3) fail_at(&e, key, "expected an array of points [[x, y, z], ...]");
      Vec3 v;
      for (std::size_t i = 0; i < 3; ++i) {
        const toml::node& c = *p->get(i);
        if (auto d = c.value_exact<double>()) v[static_cast<int>(i)] = *d;
        else if (auto n = c.value_exact<int64_t>()) v[static_cast<int>(i)] = static_cast<Real>(*n);
        else fail_at(&e, key, "expected an array of points [[x, y, z], ...]");
      }
      if (!v.allFinite()) fail_at(&e, key, "components must be finite");
      out.push_back(v);
    }
    return out;
  }

  const toml::table* table(const std::string& key) {
    use(key);
    const toml::node* node = table_.get(key);
    if (!node) return nullptr;
    if (const toml::table* t = node->as_table()) return t;
    fail(key, "expected a table");
  }

  /// An array of tables ([[key]] in TOML).
  std::vector<const toml::table*> tables(const std::string& key) {
    use(key);
    std::vector<const toml::table*> out;
    const toml::node* node = table_.get(key);
    if (!node) return out;
    const toml::array* a = node->as_array();
    if (!a) fail(key, "expected an array of tables ([[" + key + "]])");
    for (const toml::node& e : *a) {
      if (!e.as_table()) fail(key, "every entry must be a table");
      out.push_back(e.as_table());
    }
    return out;
  }

  const toml::node* node(const std::string& key) {
    use(key);
    return table_.get(key);
  }

  /// Throws for the first key that no getter asked for, suggesting the closest known one.
  void finish() const {
    for (const auto& [key, value] : table_) {
      const std::string k(key.str());
      if (used_.count(k)) continue;
      std::string best;
      std::size_t best_distance = 4;
      for (const auto& u : used_) {
        const std::size_t d = edit_distance(k, u);
        if (d < best_distance) best = u, best_distance = d;
      }
      std::string message = "unknown key";
      if (!best.empty()) message += "; did you mean '" + best + "'?";
      std::vector<std::string> known(used_.begin(), used_.end());
      message += " Valid keys here: " + join(known);
      const toml::source_region& where = value.source();
      if (where.begin.line == 0) message += " (set on the command line)";
      throw InputError(file_, static_cast<int>(where.begin.line), static_cast<int>(where.begin.column), field(k),
                       message);
    }
  }

  const std::string& file() const { return file_; }
  const toml::table& raw() const { return table_; }
  bool contains(const std::string& key) const { return table_.contains(key); }
  int line() const { return static_cast<int>(table_.source().begin.line); }
  int column() const { return static_cast<int>(table_.source().begin.column); }
  const std::string& path() const { return path_; }

  static std::string number(Real v) {
    std::ostringstream s;
    s << v;
    return s.str();
  }

 private:
  /// Marks `key` as known here (finish() accepts it). A key outside the schema is a bug of the
  /// loader, not of the scene: std::logic_error (tests and the fuzzer report it).
  const SceneKey& use(const std::string& key) {
    const std::string full = schema_path_.empty() ? key : schema_path_ + "." + key;
    const SceneKey* known = find_scene_key(full);
    if (!known)
      throw std::logic_error("scene loader reads '" + full + "', which is not in its schema (scene_schema.cpp)");
    record_scene_key(full);
    used_.insert(key);
    return *known;
  }

  /// " (unit)" for a key with a physical unit, else nothing: for messages about its value.
  std::string unit(const std::string& key) { return with_unit(use(key).unit); }

  const toml::table& table_;
  std::string path_;
  const std::string& file_;
  std::string schema_path_;
  std::set<std::string> used_;
};


/// "name[i]": the path of entry i of an array of tables.
std::string indexed(const std::string& name, std::size_t i);

}  // namespace dem::loader
