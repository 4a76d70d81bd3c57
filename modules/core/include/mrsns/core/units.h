#pragma once
// Angle constants, one definition for every module (degrees in, radians
// inside: `30.0 * kDeg`).
#include <numbers>

namespace mrsns {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kTwoPi = 2.0 * std::numbers::pi;
/// Radians in one degree.
inline constexpr double kDeg = std::numbers::pi / 180.0;

}  // namespace mrsns
