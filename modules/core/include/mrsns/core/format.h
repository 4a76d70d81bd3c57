#pragma once
// Numbers in messages a person reads: "0.43 deg", not "0.433861 deg".
#include <charconv>
#include <string>

namespace mrsns {

/// `value` with `decimals` digits after the point.
inline std::string formatFixed(double value, int decimals = 2) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value, std::chars_format::fixed, decimals);
  return result.ec == std::errc() ? std::string(buffer, result.ptr) : std::to_string(value);
}

/// `value` with `significant` significant digits.
inline std::string formatGeneral(double value, int significant = 4) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value, std::chars_format::general, significant);
  return result.ec == std::errc() ? std::string(buffer, result.ptr) : std::to_string(value);
}

}  // namespace mrsns
