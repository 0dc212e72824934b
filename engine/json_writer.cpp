#include "engine/json_writer.h"

#include <cmath>
#include <stdexcept>

#include "engine/number_text.h"

namespace dem {

std::string json_escape(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (const char c : s) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\b': out += "\\b"; break;
      case '\f': out += "\\f"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          static constexpr char hex[] = "0123456789abcdef";
          out += "\\u00";
          out += hex[(static_cast<unsigned char>(c) >> 4) & 0xf];
          out += hex[static_cast<unsigned char>(c) & 0xf];
        } else {
          out += c;
        }
    }
  }
  return out;
}

JsonObject& JsonObject::insert(const std::string& key, Value value) {
  for (const auto& entry : entries_) {
    if (entry.first == key) throw std::invalid_argument("JSON object: duplicate key '" + key + "'");
  }
  entries_.emplace_back(key, std::move(value));
  return *this;
}

JsonObject& JsonObject::add(const std::string& key, double value) { return insert(key, value); }
JsonObject& JsonObject::add(const std::string& key, std::int64_t value) { return insert(key, value); }
JsonObject& JsonObject::add(const std::string& key, std::uint64_t value) { return insert(key, value); }
JsonObject& JsonObject::add(const std::string& key, bool value) { return insert(key, value); }
JsonObject& JsonObject::add(const std::string& key, std::string value) { return insert(key, std::move(value)); }
JsonObject& JsonObject::add(const std::string& key, JsonObject value) {
  return insert(key, std::make_shared<const JsonObject>(std::move(value)));
}
JsonObject& JsonObject::add(const std::string& key, std::vector<double> values) {
  return insert(key, std::move(values));
}

std::string JsonObject::dump(int indent) const {
  std::string out;
  dump_to(out, indent < 0 ? 0 : indent, 0);
  return out;
}

void JsonObject::dump_to(std::string& out, int indent, int depth) const {
  const auto append_number = [&out](double v) {
    if (std::isfinite(v)) {
      text::append_double(out, v);
    } else {
      out += "null";
    }
  };
  if (entries_.empty()) {
    out += "{}";
    return;
  }
  const bool pretty = indent > 0;
  const std::string inner(pretty ? static_cast<std::size_t>(indent) * (depth + 1) : 0, ' ');
  out += '{';
  for (std::size_t k = 0; k < entries_.size(); ++k) {
    const auto& [key, value] = entries_[k];
    if (k > 0) out += ',';
    if (pretty) {
      out += '\n';
      out += inner;
    }
    out += '"';
    out += json_escape(key);
    out += pretty ? "\": " : "\":";
    if (const auto* d = std::get_if<double>(&value)) {
      append_number(*d);
    } else if (const auto* i = std::get_if<std::int64_t>(&value)) {
      text::append_integer(out, *i);
    } else if (const auto* u = std::get_if<std::uint64_t>(&value)) {
      text::append_integer(out, *u);
    } else if (const auto* b = std::get_if<bool>(&value)) {
      out += *b ? "true" : "false";
    } else if (const auto* s = std::get_if<std::string>(&value)) {
      out += '"';
      out += json_escape(*s);
      out += '"';
    } else if (const auto* o = std::get_if<std::shared_ptr<const JsonObject>>(&value)) {
      (*o)->dump_to(out, indent, depth + 1);
    } else {
      const auto& array = std::get<std::vector<double>>(value);
      out += '[';
      for (std::size_t j = 0; j < array.size(); ++j) {
        if (j > 0) out += pretty ? ", " : ",";
        append_number(array[j]);
      }
      out += ']';
    }
  }
  if (pretty) {
    out += '\n';
    out.append(static_cast<std::size_t>(indent) * depth, ' ');
  }
  out += '}';
}

}  // namespace dem
