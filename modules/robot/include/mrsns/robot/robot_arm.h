#pragma once
// The in-process interface of a robot arm the workstation commands: one implementation simulates a UR5
// deterministically (SimulatedArm), another speaks to a real UR controller or the in-project UR simulator
// over RTDE (UrRtdeArm). The control loop and the safety supervisor see only this interface.
#include <Eigen/Geometry>
#include <cstdint>

namespace mrsns::robot {

using Joints = Eigen::Matrix<double, 6, 1>;  // rad
using Twist = Eigen::Matrix<double, 6, 1>;   // [v (mm/s); w (rad/s)] in the base frame

enum class SafetyMode { Normal, Reduced, ProtectiveStop, EmergencyStop, Violation, Fault };
enum class RobotMode { Disconnected, PowerOff, Idle, Running, Stopped };

struct ArmState {
  double time_s = 0;        // robot controller time
  std::uint64_t cycle = 0;  // controller cycle counter
  Joints q = Joints::Zero(), qd = Joints::Zero();
  Eigen::Isometry3d base_T_flange = Eigen::Isometry3d::Identity();  // mm
  Twist flange_twist = Twist::Zero();                               // actual TCP speed, base frame
  SafetyMode safety = SafetyMode::Normal;
  RobotMode mode = RobotMode::Disconnected;
  bool connected = false;
};

// Implemented by SimulatedArm (in-process, deterministic, robotcore) and UrRtdeArm (network client of a real UR
// controller or of the in-project UR simulator, robotnet). Commands never throw: they return false when refused.
class RobotArm {
 public:
  virtual ~RobotArm() = default;
  virtual ArmState state() const = 0;
  virtual bool servoJ(const Joints& q_target) = 0;  // target for the next control cycle
  virtual bool speedL(const Twist& twist, double acceleration_mm_s2) = 0;
  virtual bool stopJ(double deceleration_rad_s2) = 0;  // controlled stop (UR stopj)
  virtual bool protectiveStop() = 0;                   // immediate stop, needs unlock to move again
  virtual bool unlockProtectiveStop() = 0;
  virtual double controlPeriodS() const = 0;  // 0.002 (500 Hz) or 0.008 (125 Hz)
};

const char* toString(SafetyMode mode);
const char* toString(RobotMode mode);

}  // namespace mrsns::robot
