#pragma once
// Status of a transform, as PLUS records it per frame (OK / INVALID) plus the
// case of a transform that was never received.
#include <string_view>

namespace mrsns {

enum class TransformStatus {
  Ok,       ///< measured and usable
  Invalid,  ///< reported, but the device marked it unusable (tool out of view, occluded)
  Missing,  ///< never reported (or no path to it)
};

/// PLUS spelling: "OK", "INVALID", "MISSING".
constexpr std::string_view toString(TransformStatus status) {
  switch (status) {
    case TransformStatus::Ok: return "OK";
    case TransformStatus::Invalid: return "INVALID";
    case TransformStatus::Missing: return "MISSING";
  }
  return "MISSING";
}

/// The worse of two statuses (Missing is worse than Invalid is worse than Ok).
constexpr TransformStatus worse(TransformStatus a, TransformStatus b) {
  return static_cast<int>(a) >= static_cast<int>(b) ? a : b;
}

}  // namespace mrsns
