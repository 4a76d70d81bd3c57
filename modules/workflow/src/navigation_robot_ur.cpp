// The navigation loop's robot on a UR controller (robot::UrRtdeArm), and where the simulated cart docks.
#include <cmath>
#include <string>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/robot/ur_rtde_arm.h"
#include "navigation_robot.h"

namespace mrsns::workflow {

Eigen::Isometry3d simulatedDocking(const NavigationRobotOptions& options, const Eigen::Isometry3d& tracker_T_patient,
                                   const Eigen::Isometry3d& base_T_flange) {
  // The planned entry 45 mm in front of the drill at its start pose, the planned direction within a few
  // degrees of the drill's, so the approach has work to do. The drill of the robot module's test scene.
  Eigen::Isometry3d flange_T_tip = Eigen::Isometry3d::Identity();
  flange_T_tip.translation() << 0, 0, 150;
  const Eigen::Isometry3d tip0 = base_T_flange * flange_T_tip;
  const Eigen::Vector3d direction_base = (tip0.linear() * Eigen::Vector3d(0.08, -0.05, 1.0)).normalized();
  const Eigen::Vector3d entry_base = tip0.translation() + tip0.linear() * Eigen::Vector3d(8, 5, 45);
  Eigen::Isometry3d base_T_plan = Eigen::Isometry3d::Identity();
  base_T_plan.linear() =
      Eigen::Quaterniond::FromTwoVectors(options.plan.direction(), direction_base).toRotationMatrix();
  base_T_plan.translation() = entry_base - base_T_plan.linear() * options.plan.entry;
  return tracker_T_patient * options.patient_T_plan * base_T_plan.inverse();
}

namespace detail {

namespace {

std::uint16_t port(int value, const char* what) {
  if (value < 1 || value > 65535) {
    throw InvalidArgumentError(std::string("navigation robot 'ur': ") + what + " port " + std::to_string(value) +
                               " is not a TCP port: use 1-65535 (UR defaults: RTDE 30004, real-time script 30003, "
                               "dashboard 29999)");
  }
  return static_cast<std::uint16_t>(value);
}

}  // namespace

std::shared_ptr<robot::RobotArm> connectUrArm(const NavigationRobotOptions& options) {
  if (!options.tracker_T_robot_base) {
    throw InvalidArgumentError(
        "navigation robot 'ur': no robot calibration (RobotBaseToTracker): a real arm stands where it is, so the "
        "loop needs where its base is in the tracker frame; run the robot-calibration step first");
  }
  if (!options.tracker_T_robot_base->matrix().allFinite()) {
    throw InvalidArgumentError("navigation robot 'ur': RobotBaseToTracker is not finite: re-run robot-calibration");
  }
  if (!(options.control_rate_hz >= 1.0 && options.control_rate_hz <= 500.0)) {
    throw InvalidArgumentError(
        "navigation robot 'ur': control_rate_hz must be in [1, 500] Hz (RTDE; UR: 125 or "
        "500), got " +
        std::to_string(options.control_rate_hz));
  }
  if (!(options.ur_silence_s > 0.0 && options.ur_silence_s <= 10.0)) {
    throw InvalidArgumentError("navigation robot 'ur': ur_silence_s must be in (0, 10] s");
  }
  if (!(options.ur_connect_timeout_s > 0.0 && options.ur_connect_timeout_s <= 60.0)) {
    throw InvalidArgumentError("navigation robot 'ur': ur_connect_timeout_s must be in (0, 60] s");
  }
  robot::UrRtdeArmOptions ur;
  ur.host = options.ur_host;
  ur.rtde_port = port(options.ur_rtde_port, "RTDE");
  ur.script_port = port(options.ur_script_port, "real-time script");
  ur.dashboard_port = port(options.ur_dashboard_port, "dashboard");
  ur.frequency_hz = options.control_rate_hz;
  ur.connect_timeout_s = options.ur_connect_timeout_s;
  // At least the 1.5 periods the arm assumes for a dedicated machine.
  ur.stale_after_periods = std::max(1.5, options.ur_silence_s * options.control_rate_hz);
  const std::string where = options.ur_host + ":" + std::to_string(ur.rtde_port) + " (RTDE) and " + options.ur_host +
                            ":" + std::to_string(ur.script_port) + " (real-time script)";
  try {
    auto arm = std::make_shared<robot::UrRtdeArm>(ur);
    logger()->info("navigation robot: UR controller {} at {}", arm->controllerVersion(), where);
    return arm;
  } catch (const NetworkError& e) {
    throw NetworkError("navigation robot 'ur': cannot connect to the UR controller at " + where + ": " + e.what() +
                       ". Check that the robot (or `mrsns-cli robot-sim`) is on and reachable at " + options.ur_host +
                       ", that it is in remote control, and the ports (--robot-ports RTDE,SCRIPT,DASHBOARD)");
  }
}

}  // namespace detail
}  // namespace mrsns::workflow
