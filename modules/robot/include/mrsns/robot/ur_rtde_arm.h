#pragma once
// RobotArm over the network, for a real UR controller or the in-project UR simulator: RTDE (30004) streams the
// state (joints, speeds, TCP pose and speed, robot and safety mode, controller time) at 125 or 500 Hz on a
// reader thread; commands go as URScript lines to the real-time interface (30003); the protective-stop unlock
// goes through the dashboard server (29999). The same supervisor code drives either.
//
// Connection loss: state().connected is false as soon as the newest RTDE package is older than
// stale_after_periods control periods at the time of the call (a silent controller), or the RTDE or script
// socket failed (a closed connection). Nothing throws after construction: commands return false.
#include <cstdint>
#include <memory>
#include <string>

#include "mrsns/robot/robot_arm.h"
#include "mrsns/robot/urscript.h"

namespace mrsns::robot {

struct UrRtdeArmOptions {
  std::string host = "127.0.0.1";
  std::uint16_t rtde_port = 30004;
  std::uint16_t dashboard_port = 29999;
  std::uint16_t script_port = 30003;
  double frequency_hz = 500;  // RTDE output rate: 500 (e-series) or 125 (CB3); sets controlPeriodS()
  double connect_timeout_s = 2.0;
  double stale_after_periods = 1.5;
  urscript::ServoJOptions servo;  // servo.time_s is replaced by the control period
  double speedl_time_s = 0.1;     // speedl holds this long unless renewed (a dead client stops the arm)
  double protective_stop_deceleration_rad_s2 = 15.0;
};

struct UrRtdeArmStats {
  std::uint64_t packages = 0;       // RTDE data packages received
  std::uint64_t commands_sent = 0;  // script lines written
  std::uint64_t commands_refused = 0;
  double last_package_age_s = 0;
};

class UrRtdeArm : public RobotArm {
 public:
  /// Connects RTDE (protocol v2, output recipe, start) and the script interface. Throws NetworkError when the
  /// controller cannot be reached, FormatError when it answers outside the protocol, UnsupportedError when it
  /// refuses protocol version 2.
  explicit UrRtdeArm(const UrRtdeArmOptions& options = {});
  ~UrRtdeArm() override;
  UrRtdeArm(const UrRtdeArm&) = delete;
  UrRtdeArm& operator=(const UrRtdeArm&) = delete;

  ArmState state() const override;
  bool servoJ(const Joints& q_target) override;
  bool speedL(const Twist& twist, double acceleration_mm_s2) override;
  bool stopJ(double deceleration_rad_s2) override;
  /// Sends protective_stop() and latches locally: motion is refused until unlockProtectiveStop() succeeds.
  bool protectiveStop() override;
  /// Dashboard "unlock protective stop" then "close safety popup"; false when the controller refuses (UR: not
  /// within 5 s of the stop) or is unreachable.
  bool unlockProtectiveStop() override;
  double controlPeriodS() const override;

  [[nodiscard]] UrRtdeArmStats stats() const;
  /// The controller's version from RTDE negotiation ("5.8.0.0").
  [[nodiscard]] std::string controllerVersion() const;
  /// Closes both connections (the reader thread ends); state().connected becomes false.
  void disconnect();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mrsns::robot
