#include "mrsns/robot/dashboard_client.h"

#include "mrsns/core/error.h"
#include "ur_tcp.h"

namespace mrsns::robot {

DashboardClient::DashboardClient(const DashboardClientOptions& options) : options_(options) {
  if (!(options.timeout_s > 0)) throw InvalidArgumentError("dashboard client: timeout_s must be > 0");
  connection_ =
      std::make_unique<detail::TcpConnection>(options.host, options.port, options.timeout_s, "UR dashboard server");
  const auto greeting = connection_->readLine(options.timeout_s);
  if (!greeting.starts_with("Connected: Universal Robots Dashboard Server")) {
    throw FormatError("UR dashboard server at " + connection_->peer() + ": unexpected greeting '" +
                      greeting.substr(0, 80) + "' (is port " + std::to_string(options.port) +
                      " the dashboard server, 29999?)");
  }
}

DashboardClient::~DashboardClient() = default;

std::string DashboardClient::request(const std::string& line) {
  connection_->write(line + "\n", options_.timeout_s);
  return connection_->readLine(options_.timeout_s);
}

dashboard::CommandResult DashboardClient::command(dashboard::Command command) {
  return dashboard::interpretReply(command, request(dashboard::commandLine(command)));
}

UrRobotMode DashboardClient::robotMode() {
  return dashboard::parseRobotModeReply(request(dashboard::commandLine(dashboard::Command::RobotMode)));
}

UrSafetyMode DashboardClient::safetyMode() {
  return dashboard::parseSafetyModeReply(request(dashboard::commandLine(dashboard::Command::SafetyMode)));
}

UrSafetyMode DashboardClient::safetyStatus() {
  return dashboard::parseSafetyModeReply(request(dashboard::commandLine(dashboard::Command::SafetyStatus)));
}

bool DashboardClient::programRunning() {
  return dashboard::parseRunningReply(request(dashboard::commandLine(dashboard::Command::Running)));
}

std::string DashboardClient::polyscopeVersion() {
  return command(dashboard::Command::PolyscopeVersion).reply;
}

}  // namespace mrsns::robot
