#pragma once
// The safety supervisor: an explicit state machine run once per control cycle. Its tick() receives what
// the cycle observed (arm state, tracking, drill pose against the plan, soft tissue, loop timing) and
// returns the decision: the stop command to send first, in this same cycle, and whether motion may be
// commanded at all. Every transition is recorded with its cycle and reason; leaving Stopped or Fault
// needs an explicit acknowledge().
//
//   Disabled --enable--> Ready --startAligning--> Aligning --aligned--> Advancing --finished--> Ready
//   Aligning/Advancing --pause--> Paused --resume--> (back)      any active state --stop condition--> Stopped
//   robot-reported protective/emergency stop or fault --> Fault  Stopped/Fault --acknowledge--> Ready
//
// Real-time: tick() never throws and allocates only when it records a transition.
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "mrsns/core/mesh_locator.h"
#include "mrsns/robot/robot_arm.h"

namespace mrsns::robot {

enum class SupervisorState { Disabled, Ready, Aligning, Advancing, Paused, Stopped, Fault };

enum class StopReason {
  None,
  ToolNotTracked,
  PatientNotTracked,
  ToolStale,
  PatientStale,
  OffAxisDistance,
  OffAxisAngle,
  SoftTissueMargin,
  OutsideWorkspace,
  OverSpeed,
  WatchdogOverrun,
  MissedCycles,
  RobotDisconnected,
  RobotStalled,  ///< the controller's cycle counter stopped advancing
  TrackerDisconnected,
  RobotProtectiveStop,
  RobotEmergencyStop,
  RobotFault,
  Operator,  ///< requested by the user (pause/disable/stop button)
};

enum class StopCommand { None, StopJ, ProtectiveStop };

const char* toString(SupervisorState state);
const char* toString(StopReason reason);
const char* toString(StopCommand command);

struct SupervisorLimits {
  double max_tracking_age_s = 0.1;     ///< a pose older than this is stale (tracker at 60 Hz: 6 frames)
  double max_axis_distance_mm = 1.5;   ///< drill tip from the planned axis, while advancing
  double max_axis_angle_rad = 0.035;   ///< drill axis from the planned axis (2 deg), while advancing
  double soft_tissue_margin_mm = 2.0;  ///< drill (tip and shaft) to the current soft-tissue surface
  /// k: the margin grows by k standard deviations of the surface where the drill is nearest
  /// (SoftTissueSurface::face_sd_mm: where the posterior shape model is unsure, the drill keeps further away).
  double soft_tissue_margin_sd = 2.0;
  /// The drill's shaft, from the tip back along the axis, is kept out of the margin too (0: the tip alone).
  double drill_shaft_length_mm = 0.0;
  /// Spacing of the shaft's check points; the margin grows by half of it, so no point between two is missed.
  double drill_shaft_step_mm = 0.5;
  Eigen::Vector3d workspace_min_mm = Eigen::Vector3d(-900, -900, -300);  ///< tip box in the robot base
  Eigen::Vector3d workspace_max_mm = Eigen::Vector3d(900, 900, 900);
  double max_tcp_speed_mm_s = 100.0;  ///< drill tip speed limit
  double max_cycle_time_s = 0.002;    ///< computation time of one cycle before the watchdog trips
  std::uint64_t max_missed_cycles = 2;
  std::uint64_t max_stalled_cycles = 3;  ///< ticks without the robot's cycle counter advancing
  double stop_deceleration_rad_s2 = 15.0;
  /// The arm is at rest when no joint moves faster than this (a real UR reports ~1e-4 rad/s standing still):
  /// until then the stop that was sent goes out again every cycle, in case the controller missed or ignored it.
  double at_rest_joint_speed_rad_s = 0.005;
};

/// What one control cycle observed. The drill tip and axis are measured by the tracker and expressed in
/// the plan (CT) frame; the tip in the robot base comes from the robot's kinematics.
struct SupervisorInputs {
  std::uint64_t cycle = 0;
  double time_s = 0;  ///< workstation clock
  ArmState arm;
  bool tracker_connected = true;
  bool tool_tracked = true;
  double tool_age_s = 0;
  bool patient_tracked = true;
  double patient_age_s = 0;
  Eigen::Vector3d tip_plan = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis_plan = Eigen::Vector3d::UnitZ();  ///< unit, drilling direction
  Eigen::Vector3d tip_base = Eigen::Vector3d::Zero();
  /// Speed of the drill tip (robot kinematics), mm/s: what the speed limit applies to.
  double tip_speed_mm_s = 0;
  double cycle_time_s = 0;          ///< how long the previous cycle's computation took
  std::uint64_t missed_cycles = 0;  ///< cycles skipped since the previous tick
};

/// The soft tissue the drill keeps away from, in the plan frame: a surface (e.g. the posterior mean shape of
/// paper 001, or the part of it near the planned paths) and the standard deviation of each face's position
/// (the largest of its vertices'; empty: a surface known exactly).
struct SoftTissueSurface {
  std::shared_ptr<const MeshLocator> surface;
  std::vector<double> face_sd_mm;
  double max_sd_mm = 0.0;  ///< the largest of face_sd_mm
};

struct PlannedAxis {
  Eigen::Vector3d entry = Eigen::Vector3d::Zero();       ///< plan frame, mm
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();  ///< unit
  bool valid = false;
};

struct SupervisorDecision {
  SupervisorState state = SupervisorState::Disabled;
  StopCommand stop = StopCommand::None;
  bool motion_allowed = false;
  StopReason reason = StopReason::None;
  /// The stop is the one sent earlier, sent again because the arm still moves.
  bool stop_repeated = false;
  /// Figures of this cycle (NaN when not computed).
  double axis_distance_mm = 0, axis_angle_rad = 0, soft_tissue_distance_mm = 0;
};

struct TransitionRecord {
  std::uint64_t cycle = 0;
  double time_s = 0;
  SupervisorState from = SupervisorState::Disabled;
  SupervisorState to = SupervisorState::Disabled;
  StopReason reason = StopReason::None;
  StopCommand command = StopCommand::None;
  std::string detail;
};

class SafetySupervisor {
 public:
  explicit SafetySupervisor(const SupervisorLimits& limits = {});

  /// Runs every check for this cycle. Never throws.
  SupervisorDecision tick(const SupervisorInputs& in);

  void setPlannedAxis(const PlannedAxis& axis) { axis_ = axis; }
  /// The current soft-tissue surface in the plan frame (e.g. the posterior shape), or null for none. Build
  /// it off the control thread and swap it in; the supervisor keeps it alive while it uses it. Throws
  /// InvalidArgumentError when face_sd_mm is neither empty nor one per face.
  void setSoftTissue(std::shared_ptr<const SoftTissueSurface> surface);
  /// A surface known exactly (no standard deviation).
  void setSoftTissue(std::shared_ptr<const MeshLocator> surface);
  [[nodiscard]] const SupervisorLimits& limits() const { return limits_; }

  // Requests (from the control object). Each returns false, changing nothing, when not allowed now.
  bool enable(std::uint64_t cycle, double time_s);
  bool disable(std::uint64_t cycle, double time_s);
  bool startAligning(std::uint64_t cycle, double time_s);
  bool aligned(std::uint64_t cycle, double time_s);
  bool finished(std::uint64_t cycle, double time_s);
  bool pause(std::uint64_t cycle, double time_s);
  bool resume(std::uint64_t cycle, double time_s);
  /// Leaves Stopped/Fault for Ready. Refused while the arm still moves (|qd| > 1e-6 rad/s) or the robot
  /// still reports a safety stop (unlock it first).
  bool acknowledge(const ArmState& arm, std::uint64_t cycle, double time_s);

  [[nodiscard]] SupervisorState state() const { return state_; }
  [[nodiscard]] const std::vector<TransitionRecord>& transitions() const { return log_; }
  /// The stop that put the supervisor in Stopped/Fault (None otherwise).
  [[nodiscard]] StopReason lastStopReason() const { return last_stop_; }

 private:
  void transition(SupervisorState to, StopReason reason, StopCommand command, std::uint64_t cycle, double time_s,
                  std::string detail);
  [[nodiscard]] bool active() const;
  /// The stop of the last transition that commanded one, until the arm is at rest (None after).
  StopCommand pending_stop_ = StopCommand::None;
  StopReason pending_reason_ = StopReason::None;

  SupervisorLimits limits_;
  PlannedAxis axis_;
  struct SoftTissueIntrusion {
    SurfacePoint nearest;  ///< face -1 when no check point is within its margin (distance: the nearest found)
    double margin_mm = 0.0;
    double behind_tip_mm = 0.0;  ///< where on the shaft
  };
  // The drill's check point deepest inside its margin (margin_mm + k sd of the face + half a step).
  [[nodiscard]] SoftTissueIntrusion softTissueIntrusion(const SupervisorInputs& in) const;

  std::shared_ptr<const SoftTissueSurface> soft_tissue_;
  SupervisorState state_ = SupervisorState::Disabled;
  SupervisorState paused_from_ = SupervisorState::Ready;
  StopReason last_stop_ = StopReason::None;
  std::vector<TransitionRecord> log_;
  std::uint64_t last_robot_cycle_ = 0;
  std::uint64_t stalled_ticks_ = 0;
  bool have_robot_cycle_ = false;
};

}  // namespace mrsns::robot
