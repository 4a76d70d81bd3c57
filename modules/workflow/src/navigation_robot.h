#pragma once
// The robot side of the navigation loop: a simulated UR5 (robot::SimulatedArm) or a UR controller over the
// network (robot::UrRtdeArm), the workstation's robot::ControlLoop and its robot::SafetySupervisor, ticked in real time
// on their own thread. The loop thread hands it what each tracking batch said (TrackingFeed); the control thread turns
// the latest feed into the supervisor's tracking inputs every cycle, so a lost, stale or disconnected tracker stops the
// arm through the supervisor. Only the control thread touches the ControlLoop: operator requests (rearm, start) are
// posted to it and run between two cycles.
#include <Eigen/Geometry>
#include <atomic>
#include <deque>
#include <functional>
#include <future>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <thread>
#include <vector>

#include "mrsns/robot/control_loop.h"
#include "mrsns/robot/simulated_arm.h"
#include "mrsns/robot/ur5_kinematics.h"
#include "mrsns/tracking/tracking_source.h"
#include "mrsns/workflow/navigation.h"

namespace mrsns::workflow::detail {

/// What the latest tracking batch said about the transforms the robot needs; times on the loop clock.
struct TrackingFeed {
  bool connected = true;
  bool tool_ok = false;
  double tool_time_s = std::numeric_limits<double>::quiet_NaN();
  Eigen::Isometry3d tracker_T_tool = Eigen::Isometry3d::Identity();
  bool patient_ok = false;
  double patient_time_s = std::numeric_limits<double>::quiet_NaN();
  Eigen::Isometry3d tracker_T_patient = Eigen::Isometry3d::Identity();
  /// Every other required transform is Ok (the supervisor has one tool input: losing one of these counts
  /// as the tool not tracked).
  bool others_ok = true;
  /// The first watched transform that is not Ok, "PatientToTracker INVALID"; empty when none.
  std::string lost;
};

/// Validates the "ur" options and connects robot::UrRtdeArm. Throws InvalidArgumentError for bad ports, rate
/// or a missing robot calibration, NetworkError (naming host:port and what to check) when nothing answers.
std::shared_ptr<robot::RobotArm> connectUrArm(const NavigationRobotOptions& options);

/// The supervisor's tracking view at now_s.
robot::TrackingSnapshot snapshotFromFeed(const TrackingFeed& feed, double now_s);

class NavigationRobot {
 public:
  /// Throws InvalidArgumentError for a bad rate, plan or missing robot calibration ("ur"); NetworkError when
  /// the UR controller cannot be reached ("ur": connects here, before any thread starts).
  NavigationRobot(const NavigationRobotOptions& options, double max_tracking_age_s, double marker_noise_mm,
                  std::uint64_t seed, std::function<double()> clock);
  ~NavigationRobot();
  NavigationRobot(const NavigationRobot&) = delete;
  NavigationRobot& operator=(const NavigationRobot&) = delete;

  /// Loop thread, once per tracking batch: docks the arm at the patient on the first patient sample (and
  /// starts the control thread), then returns the drill marker as the tracker sees it on the arm.
  std::optional<tracking::ToolUpdate> observeDrill(const std::optional<Eigen::Isometry3d>& tracker_T_patient,
                                                   double timestamp, bool visible);
  /// Loop thread: the supervisor's tracking inputs from now on.
  void feed(TrackingFeed feed, double now_s);
  /// Loop thread, on every wake-up: whether the tracking source still delivers.
  void setConnected(bool connected, double now_s);

  /// Supervisor acknowledge; false with `why` while tracking is lost, the arm moves, or no arm.
  bool rearm(std::string& why);
  bool startPlacement();
  /// The operator's stop: a moving supervisor pauses (reason Operator, StopJ); in any other state the arm
  /// is not commanded and the automatic start is held until rearm(). False with `why` when the control
  /// loop does not answer.
  bool operatorStop(std::string& why);
  /// Any thread: the soft tissue the supervisor checks from the next control cycle on (the frame that gave it
  /// arrived at arrived_s on the loop clock).
  void setSoftTissue(std::shared_ptr<const robot::SoftTissueSurface> surface, double arrived_s);
  /// Ends the control thread, leaving the arm stopping. Idempotent.
  void stop();

  /// Fills the robot fields of `status`.
  void fillStatus(NavigationStatus& status) const;
  [[nodiscard]] std::vector<NavigationRobotTransition> transitions() const;
  [[nodiscard]] bool docked() const { return docked_.load(); }

 private:
  void dock(const Eigen::Isometry3d& tracker_T_patient);
  void controlThread();
  void onCycle(const robot::CycleReport& report);
  bool post(std::function<bool(robot::ControlLoop&)> request, std::string& why);
  [[nodiscard]] bool trackingGood(const TrackingFeed& feed, double now_s) const;

  NavigationRobotOptions options_;
  double max_age_s_;
  double marker_noise_mm_;
  std::function<double()> clock_;
  std::mt19937_64 rng_;

  robot::Ur5Kinematics kinematics_;
  std::shared_ptr<robot::RobotArm> arm_;
  std::shared_ptr<robot::SimulatedArm> sim_arm_;  // null with "ur": the controller steps its own arm
  // Motion commands (servoJ, speedL) the arm accepted, counted between the
  // ControlLoop and the arm: checks the loop's own report from outside.
  std::shared_ptr<std::atomic<std::uint64_t>> arm_motion_accepted_ = std::make_shared<std::atomic<std::uint64_t>>(0);
  std::uint64_t arm_motion_checked_ = 0;  // control thread only
  // Set when docking (loop thread), read-only afterwards.
  std::unique_ptr<robot::ControlLoop> control_;
  Eigen::Isometry3d tracker_T_base_ = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d flange_T_marker_ = Eigen::Isometry3d::Identity();
  std::atomic<bool> docked_{false};
  std::atomic<bool> stopping_{false};
  std::atomic<bool> quit_{false};
  std::atomic<bool> hold_{false};  // the operator stopped: no automatic start until rearm()
  std::mutex thread_mutex_;        // docking (loop thread) against stop() (caller's thread)
  std::thread thread_;

  mutable std::mutex feed_mutex_;  // guards feed_, loss_onset_s_
  TrackingFeed feed_;
  double loss_onset_s_ = std::numeric_limits<double>::quiet_NaN();

  std::mutex tissue_mutex_;  // guards pending_tissue_
  std::optional<std::pair<std::shared_ptr<const robot::SoftTissueSurface>, double>> pending_tissue_;

  std::mutex request_mutex_;
  std::deque<std::packaged_task<bool(robot::ControlLoop&)>> requests_;

  // Control thread only.
  TrackingFeed cycle_feed_;
  double cycle_onset_s_ = std::numeric_limits<double>::quiet_NaN();
  double cycle_start_s_ = 0.0;
  std::vector<double> cycle_starts_;  // ring of cycle start times, for the latency in cycles
  double arm_origin_s_ = 0.0;
  std::uint64_t arm_steps_ = 0;
  bool auto_started_ = false;
  double stop_arm_time_s_ = std::numeric_limits<double>::quiet_NaN();

  mutable std::mutex status_mutex_;  // guards the published figures below
  NavigationStatus figures_;
  std::vector<NavigationRobotTransition> log_;
};

}  // namespace mrsns::workflow::detail
