#pragma once
// The UR simulator on ports the system picks (tests run in parallel).
#include "mrsns/robot/ur_simulator.h"

namespace mrsns::test {

/// Every interface of the simulator on an ephemeral 127.0.0.1 port; the
/// protective-stop unlock takes `unlock_delay_s`.
inline robot::UrSimulatorOptions ephemeralUrSimulator(double unlock_delay_s = 0.0) {
  robot::UrSimulatorOptions o;
  o.rtde_port = o.dashboard_port = o.secondary_port = o.realtime_port = 0;
  o.unlock_delay_s = unlock_delay_s;
  return o;
}

}  // namespace mrsns::test
