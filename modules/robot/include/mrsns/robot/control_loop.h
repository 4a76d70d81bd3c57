#pragma once
// The workstation's robot control loop: once per cycle (500 Hz) it reads the arm state and a tracking
// snapshot, runs the safety supervisor, sends the supervisor's stop command first when there is one, and
// otherwise at most one motion command from the guidance. It is the only object that commands the arm:
// it holds the RobotArm, and nothing in tracking, igtlink or the hologram stream can reach it.
//
// Deterministic mode: the caller calls tick() (tests, trials; no sleeping, no threads). Real-time mode:
// runRealTime() ticks on a fixed-rate clock, measures each cycle's computation time and the cycles it
// missed, and feeds both to the supervisor's watchdog.
#include <Eigen/Geometry>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>

#include "mrsns/core/transform_repository.h"
#include "mrsns/registration/screw_path.h"
#include "mrsns/robot/guidance.h"
#include "mrsns/robot/robot_arm.h"
#include "mrsns/robot/safety_supervisor.h"
#include "mrsns/robot/ur5_kinematics.h"

namespace mrsns::robot {

/// The tracker's view at one instant: the drill marker and the patient reference in the tracker frame.
struct TrackingSnapshot {
  bool connected = true;
  double time_s = 0;  ///< now, on the clock of the timestamps
  bool drill_tracked = false;
  double drill_timestamp_s = 0;
  Eigen::Isometry3d tracker_T_drill = Eigen::Isometry3d::Identity();
  bool patient_tracked = false;
  double patient_timestamp_s = 0;
  Eigen::Isometry3d tracker_T_patient = Eigen::Isometry3d::Identity();
};

/// A snapshot from the transform repository a TrackingSource fills ("DrillToTracker",
/// "PatientToTracker" queries prepared by the caller). Never throws.
TrackingSnapshot snapshotFromRepository(const TransformRepository& repository, TransformRepository::Query& drill,
                                        TransformRepository::Query& patient, double now_s, bool connected);

/// Calibrations and plan the loop works with (estimates: what the workstation believes).
struct ControlLoopSetup {
  Eigen::Isometry3d flange_T_marker = Eigen::Isometry3d::Identity();  ///< robot-tracker calibration
  Eigen::Isometry3d base_T_tracker = Eigen::Isometry3d::Identity();   ///< robot-tracker calibration
  Eigen::Isometry3d flange_T_tip = Eigen::Isometry3d::Identity();     ///< drill geometry; tip z = drilling direction
  Eigen::Isometry3d patient_T_plan = Eigen::Isometry3d::Identity();   ///< registration (plan/CT -> patient reference)
  registration::ScrewPath plan;
};

struct ControlLoopOptions {
  SupervisorLimits limits;
  GuidanceOptions guidance;
  /// Locate the patient from the drill marker (base_T_flange * flange_T_marker * marker seen by the tracker),
  /// which cancels the error of base_T_tracker; otherwise through base_T_tracker.
  bool marker_feedback = true;
  /// Time constant of the filter on the patient's pose in the base (s); tracking noise averages out over it.
  double estimate_time_constant_s = 0.2;
  /// Low-pass on the tracker-measured drill tip and axis the supervisor checks against the plan, applied
  /// per new tracker frame (s; 0: raw). Trades detection delay for fewer stops caused by tracking noise.
  double measurement_time_constant_s = 0.0;
};

struct CycleReport {
  std::uint64_t cycle = 0;
  SupervisorDecision decision;
  GuidanceCommand guidance;
  StopCommand stop_sent = StopCommand::None;
  bool stop_accepted = false;
  bool motion_sent = false;
  Eigen::Isometry3d base_T_plan = Eigen::Isometry3d::Identity();  ///< current estimate
};

class ControlLoop {
 public:
  /// Throws InvalidArgumentError for a null arm or an invalid plan.
  ControlLoop(std::shared_ptr<RobotArm> arm, const Ur5Kinematics& kinematics, const ControlLoopSetup& setup,
              const ControlLoopOptions& options = {});
  ControlLoop(const ControlLoop&) = delete;
  ControlLoop& operator=(const ControlLoop&) = delete;

  /// One control cycle. `cycle_time_s`: computation time of the previous cycle; `missed_cycles`: cycles
  /// skipped since the previous tick (both 0 in deterministic mode unless a test injects them).
  CycleReport tick(const TrackingSnapshot& tracking, double cycle_time_s = 0, std::uint64_t missed_cycles = 0);

  /// Fixed-rate loop until `stop` is set: sleeps to the next period boundary, never throws.
  void runRealTime(const std::function<TrackingSnapshot()>& read_tracking, const std::atomic<bool>& stop,
                   const std::function<void(const CycleReport&)>& on_cycle = {});

  // Operator requests; false when the supervisor refuses them.
  bool enable();
  bool startPlacement();  ///< Ready -> Aligning, guidance starts its approach
  bool pause();
  bool resume();
  bool retract();
  /// Unlocks a robot protective stop when there is one, then acknowledges the supervisor's stop.
  bool acknowledge();

  void setSoftTissue(std::shared_ptr<const MeshLocator> surface);
  void setSoftTissue(std::shared_ptr<const SoftTissueSurface> surface);
  void setHandTwist(const Twist& hand) { hand_ = hand; }

  [[nodiscard]] const SafetySupervisor& supervisor() const { return supervisor_; }
  [[nodiscard]] const Guidance& guidance() const { return guidance_; }
  [[nodiscard]] std::uint64_t cycle() const { return cycle_; }
  [[nodiscard]] double periodS() const { return period_; }
  [[nodiscard]] const Eigen::Isometry3d& basePlanEstimate() const { return base_T_plan_; }

 private:
  std::shared_ptr<RobotArm> arm_;
  const Ur5Kinematics& kinematics_;
  ControlLoopSetup setup_;
  ControlLoopOptions options_;
  SafetySupervisor supervisor_;
  Guidance guidance_;
  double period_ = 0.002;
  std::uint64_t cycle_ = 0;
  double time_s_ = 0;
  Eigen::Isometry3d base_T_plan_ = Eigen::Isometry3d::Identity();
  bool have_estimate_ = false;
  Eigen::Isometry3d marker_T_tip_ = Eigen::Isometry3d::Identity();
  Twist hand_ = Twist::Zero();
  ArmState last_arm_;
  Eigen::Vector3d tip_plan_filtered_ = Eigen::Vector3d::Zero(), axis_plan_filtered_ = Eigen::Vector3d::UnitZ();
  double last_drill_timestamp_ = -1e300;
  bool have_tip_ = false;
};

}  // namespace mrsns::robot
