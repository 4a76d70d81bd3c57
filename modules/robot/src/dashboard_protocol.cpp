#include "mrsns/robot/dashboard_protocol.h"

#include <array>
#include <utility>

#include "mrsns/core/error.h"

namespace mrsns::robot {
namespace {

constexpr std::array<std::pair<UrRobotMode, const char*>, 10> kRobotModes{{
    {UrRobotMode::NoController, "NO_CONTROLLER"},
    {UrRobotMode::Disconnected, "DISCONNECTED"},
    {UrRobotMode::ConfirmSafety, "CONFIRM_SAFETY"},
    {UrRobotMode::Booting, "BOOTING"},
    {UrRobotMode::PowerOff, "POWER_OFF"},
    {UrRobotMode::PowerOn, "POWER_ON"},
    {UrRobotMode::Idle, "IDLE"},
    {UrRobotMode::Backdrive, "BACKDRIVE"},
    {UrRobotMode::Running, "RUNNING"},
    {UrRobotMode::UpdatingFirmware, "UPDATING_FIRMWARE"},
}};

constexpr std::array<std::pair<UrSafetyMode, const char*>, 13> kSafetyModes{{
    {UrSafetyMode::Normal, "NORMAL"},
    {UrSafetyMode::Reduced, "REDUCED"},
    {UrSafetyMode::ProtectiveStop, "PROTECTIVE_STOP"},
    {UrSafetyMode::Recovery, "RECOVERY"},
    {UrSafetyMode::SafeguardStop, "SAFEGUARD_STOP"},
    {UrSafetyMode::SystemEmergencyStop, "SYSTEM_EMERGENCY_STOP"},
    {UrSafetyMode::RobotEmergencyStop, "ROBOT_EMERGENCY_STOP"},
    {UrSafetyMode::Violation, "VIOLATION"},
    {UrSafetyMode::Fault, "FAULT"},
    {UrSafetyMode::ValidateJointId, "VALIDATE_JOINT_ID"},
    {UrSafetyMode::UndefinedSafetyMode, "UNDEFINED_SAFETY_MODE"},
    {UrSafetyMode::AutomaticModeSafeguardStop, "AUTOMATIC_MODE_SAFEGUARD_STOP"},
    {UrSafetyMode::SystemThreePositionEnablingStop, "SYSTEM_THREE_POSITION_ENABLING_STOP"},
}};

std::string_view stripLine(std::string_view s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r' || s.back() == ' ' || s.back() == '\t')) {
    s.remove_suffix(1);
  }
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  return s;
}

std::string quoted(std::string_view s) {
  std::string out = "'";
  for (char c : s.substr(0, 120)) out += (c >= 32 && c < 127) ? c : '?';
  return out + (s.size() > 120 ? "...'" : "'");
}

[[noreturn]] void unexpected(std::string_view what, std::string_view reply) {
  throw FormatError("dashboard server: unexpected reply " + quoted(reply) + " to '" + std::string(what) +
                    "' (is this port 29999 of a UR controller, PolyScope 5?)");
}

}  // namespace

const char* toString(UrRobotMode mode) {
  for (const auto& [m, name] : kRobotModes) {
    if (m == mode) return name;
  }
  return "UNKNOWN";
}

const char* toString(UrSafetyMode mode) {
  for (const auto& [m, name] : kSafetyModes) {
    if (m == mode) return name;
  }
  return "UNKNOWN";
}

std::optional<UrRobotMode> urRobotModeFromString(std::string_view name) {
  for (const auto& [m, n] : kRobotModes) {
    if (name == n) return m;
  }
  return std::nullopt;
}

std::optional<UrSafetyMode> urSafetyModeFromString(std::string_view name) {
  for (const auto& [m, n] : kSafetyModes) {
    if (name == n) return m;
  }
  return std::nullopt;
}

std::optional<UrRobotMode> urRobotModeFromInt(int value) {
  if (value < -1 || value > 8) return std::nullopt;
  return static_cast<UrRobotMode>(value);
}

std::optional<UrSafetyMode> urSafetyModeFromInt(int value) {
  if (value < 1 || value > 13) return std::nullopt;
  return static_cast<UrSafetyMode>(value);
}

RobotMode toRobotMode(UrRobotMode mode) {
  switch (mode) {
    case UrRobotMode::NoController:
    case UrRobotMode::Disconnected: return RobotMode::Disconnected;
    case UrRobotMode::ConfirmSafety:
    case UrRobotMode::Booting:
    case UrRobotMode::PowerOff:
    case UrRobotMode::UpdatingFirmware: return RobotMode::PowerOff;
    case UrRobotMode::PowerOn:
    case UrRobotMode::Idle:
    case UrRobotMode::Backdrive: return RobotMode::Idle;
    case UrRobotMode::Running: return RobotMode::Running;
  }
  return RobotMode::Disconnected;
}

SafetyMode toSafetyMode(UrSafetyMode mode) {
  switch (mode) {
    case UrSafetyMode::Normal: return SafetyMode::Normal;
    case UrSafetyMode::Reduced: return SafetyMode::Reduced;
    case UrSafetyMode::ProtectiveStop:
    case UrSafetyMode::SafeguardStop:
    case UrSafetyMode::AutomaticModeSafeguardStop:
    case UrSafetyMode::SystemThreePositionEnablingStop: return SafetyMode::ProtectiveStop;
    case UrSafetyMode::SystemEmergencyStop:
    case UrSafetyMode::RobotEmergencyStop: return SafetyMode::EmergencyStop;
    case UrSafetyMode::Violation: return SafetyMode::Violation;
    case UrSafetyMode::Recovery:
    case UrSafetyMode::Fault:
    case UrSafetyMode::ValidateJointId:
    case UrSafetyMode::UndefinedSafetyMode: return SafetyMode::Fault;
  }
  return SafetyMode::Fault;
}

UrRobotMode toUrRobotMode(RobotMode mode) {
  switch (mode) {
    case RobotMode::Disconnected: return UrRobotMode::Disconnected;
    case RobotMode::PowerOff: return UrRobotMode::PowerOff;
    case RobotMode::Idle: return UrRobotMode::Idle;
    case RobotMode::Running: return UrRobotMode::Running;
    case RobotMode::Stopped: return UrRobotMode::Idle;
  }
  return UrRobotMode::Disconnected;
}

UrSafetyMode toUrSafetyMode(SafetyMode mode) {
  switch (mode) {
    case SafetyMode::Normal: return UrSafetyMode::Normal;
    case SafetyMode::Reduced: return UrSafetyMode::Reduced;
    case SafetyMode::ProtectiveStop: return UrSafetyMode::ProtectiveStop;
    case SafetyMode::EmergencyStop: return UrSafetyMode::RobotEmergencyStop;
    case SafetyMode::Violation: return UrSafetyMode::Violation;
    case SafetyMode::Fault: return UrSafetyMode::Fault;
  }
  return UrSafetyMode::Fault;
}

namespace dashboard {
namespace {

constexpr std::array<std::pair<Command, const char*>, 19> kCommands{{
    {Command::PowerOn, "power on"},
    {Command::PowerOff, "power off"},
    {Command::BrakeRelease, "brake release"},
    {Command::Play, "play"},
    {Command::Stop, "stop"},
    {Command::Pause, "pause"},
    {Command::RobotMode, "robotmode"},
    {Command::SafetyMode, "safetymode"},
    {Command::SafetyStatus, "safetystatus"},
    {Command::UnlockProtectiveStop, "unlock protective stop"},
    {Command::CloseSafetyPopup, "close safety popup"},
    {Command::Running, "running"},
    {Command::PolyscopeVersion, "PolyscopeVersion"},
    {Command::Quit, "quit"},
    {Command::IsInRemoteControl, "is in remote control"},
    {Command::GetRobotModel, "get robot model"},
    {Command::GetSerialNumber, "get serial number"},
    {Command::ProgramState, "programState"},
    {Command::GetLoadedProgram, "get loaded program"},
}};

}  // namespace

std::string commandLine(Command command) {
  for (const auto& [c, line] : kCommands) {
    if (c == command) return line;
  }
  return {};
}

std::optional<Command> parseCommand(std::string_view line) {
  line = stripLine(line);
  for (const auto& [c, text] : kCommands) {
    if (line == text) return c;
  }
  return std::nullopt;
}

std::string successReply(Command command) {
  switch (command) {
    case Command::PowerOn: return "Powering on";
    case Command::PowerOff: return "Powering off";
    case Command::BrakeRelease: return "Brake releasing";
    case Command::Play: return "Starting program";
    case Command::Stop: return "Stopped";
    case Command::Pause: return "Pausing program";
    case Command::UnlockProtectiveStop: return "Protective stop releasing";
    case Command::CloseSafetyPopup: return "closing safety popup";
    case Command::Quit: return "Disconnected";
    case Command::PolyscopeVersion: return polyscopeVersionReply(5, 8, 0, 0);
    case Command::RobotMode:
    case Command::SafetyMode:
    case Command::SafetyStatus:
    case Command::Running:
    case Command::IsInRemoteControl:
    case Command::GetRobotModel:
    case Command::GetSerialNumber:
    case Command::ProgramState:
    case Command::GetLoadedProgram: break;
  }
  return {};
}

std::string failureReply(Command command) {
  switch (command) {
    case Command::Play: return "Failed to execute: play";
    case Command::Stop: return "Failed to execute: stop";
    case Command::Pause: return "Failed to execute: pause";
    case Command::UnlockProtectiveStop: return "Cannot unlock protective stop, robot is not in protective stop";
    default: return "Failed to execute: " + commandLine(command);
  }
}

std::string unlockTooEarlyReply() {
  return "Cannot unlock protective stop until 5s after occurrence. Always inspect cause of protective stop before "
         "unlocking";
}

std::string polyscopeVersionReply(unsigned major, unsigned minor, unsigned bugfix, unsigned build) {
  return "URSoftware " + std::to_string(major) + "." + std::to_string(minor) + "." + std::to_string(bugfix) + "." +
         std::to_string(build) + " (MR-SNS UR simulator)";
}

std::string remoteControlReply(bool remote) {
  return remote ? "true" : "false";
}

std::string programStateReply(bool running, std::string_view program) {
  return std::string(running ? "PLAYING " : "STOPPED ") + std::string(program);
}

std::string robotModeReply(UrRobotMode mode) {
  return std::string("Robotmode: ") + toString(mode);
}
std::string safetyModeReply(UrSafetyMode mode, bool status_form) {
  return std::string(status_form ? "Safetystatus: " : "Safetymode: ") + toString(mode);
}
std::string runningReply(bool running) {
  return std::string("Program running: ") + (running ? "true" : "false");
}
std::string notUnderstoodReply(std::string_view line) {
  return "could not understand: '" + std::string(stripLine(line)) + "'";
}

CommandResult interpretReply(Command command, std::string_view reply_in) {
  const auto reply = stripLine(reply_in);
  CommandResult result{false, std::string(reply)};
  const auto success = successReply(command);
  if (success.empty()) {
    throw InvalidArgumentError("dashboard: '" + commandLine(command) +
                               "' is a query; read its reply with the matching parse function");
  }
  if (command == Command::PolyscopeVersion) {
    if (!reply.starts_with("URSoftware")) unexpected(commandLine(command), reply);
    result.accepted = true;
    return result;
  }
  if (reply == success) {
    result.accepted = true;
    return result;
  }
  if (reply.starts_with("Failed to execute") || reply.starts_with("Cannot unlock protective stop")) {
    return result;
  }
  unexpected(commandLine(command), reply);
}

UrRobotMode parseRobotModeReply(std::string_view reply_in) {
  const auto reply = stripLine(reply_in);
  constexpr std::string_view prefix = "Robotmode: ";
  if (!reply.starts_with(prefix)) unexpected("robotmode", reply);
  const auto mode = urRobotModeFromString(reply.substr(prefix.size()));
  if (!mode) unexpected("robotmode", reply);
  return *mode;
}

UrSafetyMode parseSafetyModeReply(std::string_view reply_in) {
  const auto reply = stripLine(reply_in);
  std::string_view rest;
  for (std::string_view prefix : {"Safetymode: ", "Safetystatus: "}) {
    if (reply.starts_with(prefix)) rest = reply.substr(prefix.size());
  }
  const auto mode = urSafetyModeFromString(rest);
  if (rest.empty() || !mode) unexpected("safetymode", reply);
  return *mode;
}

bool parseRunningReply(std::string_view reply_in) {
  const auto reply = stripLine(reply_in);
  if (reply == "Program running: true") return true;
  if (reply == "Program running: false") return false;
  unexpected("running", reply);
}

}  // namespace dashboard
}  // namespace mrsns::robot
