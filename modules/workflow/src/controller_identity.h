#pragma once
// Who drives whom: a simulated tracker (mrsns-sim's PlusServer, the in-process
// simulated tracker, a recording played back) never drives a real UR
// controller. mrsns-sim announces the serial number of its own controller in
// its device identity; the in-process simulated tracker and a playback have no
// room, so they may drive only a controller on this machine (a simulator).
#include <string>

namespace mrsns::workflow::detail {

/// The identity the PlusServer at host:port gives (mrsns-sim names itself), "" when it says nothing within
/// timeout_s.
std::string trackerIdentity(const std::string& host, int port, double timeout_s);

/// "... UR controller serial 2018551234)" -> "2018551234"; "" when the identity announces none.
std::string announcedSerial(const std::string& identity);

/// The controller's serial number from its dashboard. Throws NetworkError naming host:port when it cannot be
/// asked (`who` starts the message).
std::string controllerSerial(const std::string& host, int dashboard_port, const std::string& who);

/// 127.0.0.0/8, ::1 or localhost.
bool isLoopbackHost(const std::string& host);

}  // namespace mrsns::workflow::detail
