#pragma once
// A client of the UR dashboard server (TCP 29999): connects, checks the greeting, then sends one command line
// at a time and reads its reply, with a timeout on each. Blocking; not for the control loop (a dashboard reply
// takes tens of milliseconds on a real controller).
#include <cstdint>
#include <memory>
#include <string>

#include "mrsns/robot/dashboard_protocol.h"

namespace mrsns::robot {

namespace detail {
class TcpConnection;
}

struct DashboardClientOptions {
  std::string host = "127.0.0.1";
  std::uint16_t port = dashboard::kDefaultPort;
  double timeout_s = 2.0;
};

class DashboardClient {
 public:
  /// Connects and reads the greeting. Throws NetworkError when unreachable, FormatError when the greeting is not
  /// the dashboard server's.
  explicit DashboardClient(const DashboardClientOptions& options = {});
  ~DashboardClient();
  DashboardClient(const DashboardClient&) = delete;
  DashboardClient& operator=(const DashboardClient&) = delete;

  /// Sends `line` (a newline is appended) and returns the reply line. Throws NetworkError on timeout or close.
  std::string request(const std::string& line);
  /// A state-changing command; throws FormatError on an undocumented reply (refusals return accepted = false).
  dashboard::CommandResult command(dashboard::Command command);
  UrRobotMode robotMode();
  UrSafetyMode safetyMode();
  UrSafetyMode safetyStatus();
  bool programRunning();
  std::string polyscopeVersion();

 private:
  DashboardClientOptions options_;
  std::unique_ptr<detail::TcpConnection> connection_;
};

}  // namespace mrsns::robot
