#pragma once
// A deterministic in-process UR5: the joint-space model the UR controller runs at 500 Hz (servoJ tracking
// with speed and acceleration limits, speedL through the Jacobian, stopJ, protective and emergency
// stops) plus fault injection, so tests and trials can place a fault on an exact controller cycle.
//
// Stopping: the UR safety system stops the arm with a category 2 stop (protective stop) or a category 1
// stop (emergency stop), both decelerating along the path before the brakes hold. The deceleration and
// the stopping-time limit are options; the defaults (stop_deceleration_rad_s2 = 15, so a joint at the
// full pi rad/s stops in 0.21 s, under stop_time_limit_s = 0.5 s) are within the UR5 CB3 default
// stopping-time limit. Tests check that every stop ends inside stop_time_limit_s.
//
// Thread safety: every public member takes an internal mutex, so a real-time server may step the arm on
// one thread while protocol handlers command it on another.
#include <cstdint>
#include <mutex>
#include <vector>

#include "mrsns/robot/robot_arm.h"
#include "mrsns/robot/ur5_kinematics.h"

namespace mrsns::robot {

enum class Fault {
  ProtectiveStop,  ///< the controller raises a protective stop (e.g. its collision detection)
  EmergencyStop,   ///< the e-stop button: stop, then power off; needs resetEmergencyStop()
  JointFault,      ///< a joint reports a fault: safety mode Fault, the arm stops
  Disconnect,      ///< the link to the workstation drops: state().connected false, commands refused
  Reconnect,       ///< the link comes back
  Freeze,          ///< the controller stops advancing (its cycle counter and state no longer change)
};

const char* toString(Fault fault);

struct SimulatedArmOptions {
  DhParameters dh = ur5DhParameters();
  JointLimits limits = ur5JointLimits();
  double control_period_s = 0.002;
  /// Start joints: a folded, non-singular pose above the table.
  Joints q0 = (Joints() << 0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0).finished();
  double stop_deceleration_rad_s2 = 15.0;
  double stop_time_limit_s = 0.5;
  /// speedL: the TCP speed the controller accepts before it refuses the command (mm/s; UR5 TCP limit 1000).
  double max_tcp_speed_mm_s = 1000.0;
  /// speedL near a singularity: damped least squares with this damping (mm-scaled Jacobian).
  double speedl_damping = 1e-3;
  /// The first this many stop commands (stopJ, protectiveStop) are lost on the way, as a dropped packet or a
  /// script interface that was not listening would lose them: taken without error, not acted on. A fault to
  /// test that the workstation repeats its stop until the arm is at rest.
  int stops_lost = 0;
};

class SimulatedArm : public RobotArm {
 public:
  /// Throws InvalidArgumentError for a non-positive period or deceleration, or start joints outside the limits.
  explicit SimulatedArm(const SimulatedArmOptions& options = {});

  ArmState state() const override;
  bool servoJ(const Joints& q_target) override;
  bool speedL(const Twist& twist, double acceleration_mm_s2) override;
  bool stopJ(double deceleration_rad_s2) override;
  bool protectiveStop() override;
  bool unlockProtectiveStop() override;
  double controlPeriodS() const override { return options_.control_period_s; }

  /// Advances the model by dt_s (one controller cycle; the cycle counter increases by one).
  void step(double dt_s);
  /// One control period.
  void step() { step(options_.control_period_s); }

  /// The fault happens at the end of the step that brings the cycle counter to `at_cycle` (so the first
  /// state showing it has cycle == at_cycle). Several faults may be queued.
  void injectFault(Fault kind, std::uint64_t at_cycle);
  /// Clears the e-stop (the operator released the button and powered on); false when there is none.
  bool resetEmergencyStop();

  /// Puts the arm at rest at q (test set-up); clears commands but not safety states.
  void reset(const Joints& q);

  [[nodiscard]] const Ur5Kinematics& kinematics() const { return kinematics_; }
  [[nodiscard]] const SimulatedArmOptions& options() const { return options_; }
  /// Commands refused since construction (a safety state, disconnection, bad values).
  [[nodiscard]] std::uint64_t refusedCommands() const;
  /// Stop commands lost on the way (options().stops_lost).
  [[nodiscard]] std::uint64_t lostStops() const;

 private:
  enum class Motion { Hold, Servo, Speed, Stopping };
  struct PendingFault {
    Fault kind;
    std::uint64_t at_cycle;
  };
  void applyFault(Fault kind);
  void beginStop(double deceleration);
  /// True when this stop command is one of the lost ones (called under the mutex).
  bool loseStop();
  [[nodiscard]] bool acceptsMotion() const;
  [[nodiscard]] Joints speedLJointVelocity() const;

  mutable std::mutex mutex_;
  SimulatedArmOptions options_;
  Ur5Kinematics kinematics_;
  double time_s_ = 0;
  std::uint64_t cycle_ = 0;
  Joints q_, qd_ = Joints::Zero();
  Motion motion_ = Motion::Hold;
  Joints servo_target_;
  Twist speed_target_ = Twist::Zero();
  Twist speed_command_ = Twist::Zero();  // ramped toward speed_target_
  double speed_acceleration_ = 0;
  double stop_deceleration_ = 15.0;
  SafetyMode safety_ = SafetyMode::Normal;
  bool connected_ = true;
  bool frozen_ = false;
  bool powered_ = true;
  std::vector<PendingFault> faults_;
  std::uint64_t refused_ = 0;
  int stops_to_lose_ = 0;
  std::uint64_t stops_lost_ = 0;
};

}  // namespace mrsns::robot
