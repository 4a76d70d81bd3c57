#pragma once
// The device parameters every live step shares (connect-devices, navigation, robot-placement): where the
// tracking comes from and, for the in-process simulator, its noise and a scripted dropout.
#include "mrsns/workflow/navigation.h"
#include "step_internal.h"

namespace mrsns::workflow::detail {

#define MRSNS_DEVICE_KEYS                                                                            \
  "source", "host", "port", "file", "playback_speed", "seed", "rate_hz", "noise_mm", "dropout_tool", \
      "dropout_start_s", "dropout_duration_s"

inline DeviceOptions deviceOptions(const Params& p) {
  DeviceOptions d;
  d.source = p.text("source", d.source);
  d.host = p.text("host", d.host);
  d.port = p.integer("port", d.port);
  d.file = p.text("file", "");
  d.playback_speed = p.number("playback_speed", d.playback_speed);
  d.seed = static_cast<std::uint64_t>(p.integer("seed", 1));
  d.rate_hz = p.number("rate_hz", d.rate_hz);
  d.noise_mm = p.number("noise_mm", d.noise_mm);
  d.dropout_tool = p.text("dropout_tool", d.dropout_tool);
  d.dropout_start_s = p.number("dropout_start_s", d.dropout_start_s);
  d.dropout_duration_s = p.number("dropout_duration_s", d.dropout_duration_s);
  return d;
}

}  // namespace mrsns::workflow::detail
