#include "mrsns/robot/robot_arm.h"

namespace mrsns::robot {

const char* toString(SafetyMode mode) {
  switch (mode) {
    case SafetyMode::Normal: return "Normal";
    case SafetyMode::Reduced: return "Reduced";
    case SafetyMode::ProtectiveStop: return "ProtectiveStop";
    case SafetyMode::EmergencyStop: return "EmergencyStop";
    case SafetyMode::Violation: return "Violation";
    case SafetyMode::Fault: return "Fault";
  }
  return "Unknown";
}

const char* toString(RobotMode mode) {
  switch (mode) {
    case RobotMode::Disconnected: return "Disconnected";
    case RobotMode::PowerOff: return "PowerOff";
    case RobotMode::Idle: return "Idle";
    case RobotMode::Running: return "Running";
    case RobotMode::Stopped: return "Stopped";
  }
  return "Unknown";
}

}  // namespace mrsns::robot
