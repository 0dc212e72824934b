#pragma once
// JSON text for summary.json: an ordered object with numbers written locale-independently with 17
// significant digits. Writing the file is the caller's (write_file_atomically).
#include <cstdint>
#include <memory>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

namespace dem {

/// `s` with '"', '\\' and control characters (< 0x20) escaped for a JSON string (without the quotes).
/// Other bytes, UTF-8 included, pass through.
std::string json_escape(const std::string& s);

/// An ordered JSON object: keys keep insertion order, a duplicate key throws std::invalid_argument.
/// Doubles are written with 17 significant digits, non-finite ones as null (JSON has no NaN or inf).
class JsonObject {
 public:
  JsonObject& add(const std::string& key, double value);
  JsonObject& add(const std::string& key, std::int64_t value);
  JsonObject& add(const std::string& key, std::uint64_t value);
  JsonObject& add(const std::string& key, bool value);
  JsonObject& add(const std::string& key, std::string value);
  JsonObject& add(const std::string& key, const char* value) { return add(key, std::string(value)); }
  JsonObject& add(const std::string& key, JsonObject value);
  JsonObject& add(const std::string& key, std::vector<double> values);
  /// Any other integer type (int, unsigned, std::size_t...) goes to the 64-bit overload of its signedness.
  template <typename T>
    requires(std::is_integral_v<T> && !std::is_same_v<T, bool> && !std::is_same_v<T, std::int64_t> &&
             !std::is_same_v<T, std::uint64_t>)
  JsonObject& add(const std::string& key, T value) {
    if constexpr (std::is_signed_v<T>) {
      return add(key, static_cast<std::int64_t>(value));
    } else {
      return add(key, static_cast<std::uint64_t>(value));
    }
  }

  std::size_t size() const { return entries_.size(); }
  bool empty() const { return entries_.empty(); }

  /// The object as JSON text without a trailing newline. `indent` > 0: one key per line, nested by
  /// `indent` spaces, arrays on one line; `indent` <= 0: compact, no spaces.
  std::string dump(int indent = 2) const;

 private:
  using Value = std::variant<double, std::int64_t, std::uint64_t, bool, std::string,
                             std::shared_ptr<const JsonObject>, std::vector<double>>;
  JsonObject& insert(const std::string& key, Value value);
  void dump_to(std::string& out, int indent, int depth) const;

  std::vector<std::pair<std::string, Value>> entries_;  // nested objects are immutable once added
};

}  // namespace dem
