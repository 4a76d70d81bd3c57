#include "controller_identity.h"

#include <cctype>
#include <chrono>
#include <memory>
#include <thread>

#include "mrsns/core/error.h"
#include "mrsns/core/transform_repository.h"
#include "mrsns/robot/dashboard_client.h"
#include "mrsns/tracking/igtl_source.h"
#include "step_internal.h"

namespace mrsns::workflow::detail {

std::string trackerIdentity(const std::string& host, int port, double timeout_s) {
  tracking::IgtlTrackingSource source(std::make_shared<TransformRepository>(), plusClientOptions(host, port));
  source.start();
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  std::string identity;
  while (identity.empty() && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    identity = source.deviceIdentity();
  }
  source.stop();
  return identity;
}

std::string announcedSerial(const std::string& identity) {
  const std::string key = "UR controller serial ";
  const auto at = identity.find(key);
  if (at == std::string::npos) return {};
  std::string serial;
  for (std::size_t i = at + key.size(); i < identity.size() && std::isdigit(static_cast<unsigned char>(identity[i])); ++i)
    serial += identity[i];
  return serial;
}

std::string controllerSerial(const std::string& host, int dashboard_port, const std::string& who) {
  try {
    robot::DashboardClient dashboard({host, static_cast<std::uint16_t>(dashboard_port), 2.0});
    return dashboard.request("get serial number");
  } catch (const Error& e) {
    throw NetworkError(who + ": cannot reach the UR dashboard at " + host + ":" + std::to_string(dashboard_port) +
                       " (" + e.what() + "): check that the robot is on, in remote control, and the ports");
  }
}

bool isLoopbackHost(const std::string& host) {
  return host == "localhost" || host == "::1" || host.rfind("127.", 0) == 0;
}

}  // namespace mrsns::workflow::detail
