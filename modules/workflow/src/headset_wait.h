#pragma once
// What a step that serves the hologram stream (the HMD calibrations) says while
// it waits for the headset: before it first connects, and after it left.
#include <string>

#include "mrsns/core/format.h"

namespace mrsns::workflow::detail {

/// The failure once `waited_s` is past `wait_s`, else empty.
inline std::string headsetWaitFailure(int drops, const std::string& endpoint, double waited_s, double wait_s) {
  if (waited_s <= wait_s) return {};
  return (drops == 0 ? "no headset connected to the hologram stream at " + endpoint
                     : "the headset left and did not come back to " + endpoint) +
         " within " + formatFixed(wait_s, 0) + " s (is the HMD app running and pointed at this workstation?)";
}

/// The operator's progress line while waiting; `again` names what is asked again when it is back ("view 2 of 4").
inline std::string headsetWaitMessage(int drops, const std::string& endpoint, const std::string& again) {
  return drops == 0 ? "waiting for the headset to connect to the hologram stream at " + endpoint
                    : "the headset left: waiting for it to come back (" + again + " again)";
}

}  // namespace mrsns::workflow::detail
