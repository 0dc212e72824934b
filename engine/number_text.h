#pragma once
// Numbers as text for the result writers, locale-independent: doubles as printf("%.17g") would write
// them in the C locale (std::to_chars, 17 significant digits), so they read back bit-exactly with strtod.
#include <charconv>
#include <string>
#include <string_view>
#include <system_error>

namespace dem::text {

/// Appends `value` as printf("%.17g") would in the C locale, whatever the program's locale.
inline void append_double(std::string& out, double value) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value, std::chars_format::general, 17);
  out.append(buffer, result.ptr);
}

template <typename Int>
void append_integer(std::string& out, Int value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  out.append(buffer, result.ptr);
}

/// Parses all of `text` as a double; false if it is not exactly one number.
inline bool parse_double(std::string_view text, double& value) {
  const auto result = std::from_chars(text.data(), text.data() + text.size(), value);
  return result.ec == std::errc() && result.ptr == text.data() + text.size();
}

}  // namespace dem::text
