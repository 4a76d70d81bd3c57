#pragma once
// The minimum-jerk profile (Flash & Hogan 1985): how a hand, or a gently
// driven arm, goes from one pose to another with zero speed and acceleration
// at both ends. s in [0, 1] (clamped) -> fraction of the way, in [0, 1].
#include <algorithm>

namespace mrsns {

[[nodiscard]] inline double minimumJerk(double s) {
  s = std::clamp(s, 0.0, 1.0);
  return s * s * s * (10.0 - 15.0 * s + 6.0 * s * s);
}

}  // namespace mrsns
