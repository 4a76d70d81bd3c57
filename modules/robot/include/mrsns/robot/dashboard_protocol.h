#pragma once
// The UR dashboard server protocol (TCP 29999) as documented by Universal Robots: one command per line, one
// reply line each; the server greets with "Connected: Universal Robots Dashboard Server". Also the controller's
// robot-mode and safety-mode numbers and names, shared by RTDE, the primary interface and the dashboard, and
// their mapping onto the workstation's RobotMode / SafetyMode. Pure text, no sockets.
#include <optional>
#include <string>
#include <string_view>

#include "mrsns/robot/robot_arm.h"

namespace mrsns::robot {

/// Robot mode as the controller numbers it (RTDE robot_mode, primary robot mode data).
enum class UrRobotMode : int {
  NoController = -1,
  Disconnected = 0,
  ConfirmSafety = 1,
  Booting = 2,
  PowerOff = 3,
  PowerOn = 4,
  Idle = 5,
  Backdrive = 6,
  Running = 7,
  UpdatingFirmware = 8,
};
/// Safety mode as the controller numbers it (RTDE safety_mode, primary safety-mode message).
enum class UrSafetyMode : int {
  Normal = 1,
  Reduced = 2,
  ProtectiveStop = 3,
  Recovery = 4,
  SafeguardStop = 5,
  SystemEmergencyStop = 6,
  RobotEmergencyStop = 7,
  Violation = 8,
  Fault = 9,
  ValidateJointId = 10,
  UndefinedSafetyMode = 11,
  AutomaticModeSafeguardStop = 12,
  SystemThreePositionEnablingStop = 13,
};

/// Dashboard spelling: "RUNNING", "POWER_OFF", ...; "NORMAL", "PROTECTIVE_STOP", ...
const char* toString(UrRobotMode mode);
const char* toString(UrSafetyMode mode);
std::optional<UrRobotMode> urRobotModeFromString(std::string_view name);
std::optional<UrSafetyMode> urSafetyModeFromString(std::string_view name);
/// From the integers on the wire; nullopt for numbers the controller does not define.
std::optional<UrRobotMode> urRobotModeFromInt(int value);
std::optional<UrSafetyMode> urSafetyModeFromInt(int value);

RobotMode toRobotMode(UrRobotMode mode);
SafetyMode toSafetyMode(UrSafetyMode mode);
UrRobotMode toUrRobotMode(RobotMode mode);
UrSafetyMode toUrSafetyMode(SafetyMode mode);

namespace dashboard {

constexpr unsigned short kDefaultPort = 29999;
constexpr std::string_view kWelcome = "Connected: Universal Robots Dashboard Server";

enum class Command {
  PowerOn,
  PowerOff,
  BrakeRelease,
  Play,
  Stop,
  Pause,
  RobotMode,
  SafetyMode,
  SafetyStatus,
  UnlockProtectiveStop,
  CloseSafetyPopup,
  Running,
  PolyscopeVersion,
  Quit,
  // Queries of PolyScope 5.6+ that client libraries ask (ur_rtde's isInRemoteControl, getRobotModel,
  // getSerialNumber, programState, getLoadedProgram).
  IsInRemoteControl,
  GetRobotModel,
  GetSerialNumber,
  ProgramState,
  GetLoadedProgram,
};

/// The command line without its newline ("power on", "unlock protective stop", ...).
std::string commandLine(Command command);
/// Server side: the command a line asks for (trailing CR/LF and surrounding blanks ignored), nullopt when the
/// dashboard server would answer "could not understand".
std::optional<Command> parseCommand(std::string_view line);

/// What a reply line means for the command that was sent.
struct CommandResult {
  bool accepted = false;  // false: the controller understood and refused (e.g. "Failed to execute: play")
  std::string reply;      // the line as received, without CR/LF
};
/// Client side: classifies the reply to a state-changing command. Throws FormatError when the line is neither the
/// documented success nor a documented refusal (wrong port, protocol drift, a reply to another command).
CommandResult interpretReply(Command command, std::string_view reply);
/// "Robotmode: RUNNING" -> Running. Throws FormatError on any other line or an unknown mode name.
UrRobotMode parseRobotModeReply(std::string_view reply);
/// "Safetymode: NORMAL" or "Safetystatus: PROTECTIVE_STOP". Throws FormatError otherwise.
UrSafetyMode parseSafetyModeReply(std::string_view reply);
/// "Program running: true|false". Throws FormatError otherwise.
bool parseRunningReply(std::string_view reply);

/// Server side: the documented reply lines (without newline).
std::string successReply(Command command);
std::string failureReply(Command command);
std::string robotModeReply(UrRobotMode mode);
std::string safetyModeReply(UrSafetyMode mode, bool status_form);
std::string runningReply(bool running);
std::string notUnderstoodReply(std::string_view line);
/// The controller refuses to unlock within 5 s of the protective stop.
std::string unlockTooEarlyReply();
/// "PolyscopeVersion": "URSoftware 5.8.0.10253 (<build date>)". Four numbers, as a real controller sends them:
/// clients (ur_rtde) parse major.minor.bugfix.build and refuse anything shorter.
std::string polyscopeVersionReply(unsigned major, unsigned minor, unsigned bugfix, unsigned build);
/// "is in remote control": "true" / "false".
std::string remoteControlReply(bool remote);
/// "programState": "PLAYING <name>", "STOPPED <name>" (the program's name; "<unnamed>" without a file).
std::string programStateReply(bool running, std::string_view program = "<unnamed>");

}  // namespace dashboard
}  // namespace mrsns::robot
