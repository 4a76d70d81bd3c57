#pragma once
// Numbers in messages a person reads: "0.43 deg", not "0.433861 deg".
#include <cstdio>
#include <string>

namespace mrsns {

/// `value` with `decimals` digits after the point ("%.*f").
inline std::string formatFixed(double value, int decimals = 2) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, value);
  return buffer;
}

/// `value` with `significant` significant digits ("%.*g").
inline std::string formatGeneral(double value, int significant = 4) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*g", significant, value);
  return buffer;
}

}  // namespace mrsns
