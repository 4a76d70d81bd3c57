#include "navigation_robot.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/core/rigid.h"

namespace mrsns::workflow {

registration::ScrewPath defaultNavigationPlan() {
  registration::ScrewPath plan;
  plan.name = "navigation";
  plan.entry = Eigen::Vector3d(0.0, 0.0, 60.0);
  plan.target = Eigen::Vector3d(0.0, 0.0, 90.0);
  return plan;
}

namespace detail {

namespace {

// Forwards to the arm and counts the motion commands it accepts.
class MotionCountingArm final : public robot::RobotArm {
 public:
  MotionCountingArm(std::shared_ptr<robot::RobotArm> arm, std::shared_ptr<std::atomic<std::uint64_t>> accepted)
      : arm_(std::move(arm)), accepted_(std::move(accepted)) {}
  robot::ArmState state() const override { return arm_->state(); }
  bool servoJ(const robot::Joints& q_target) override { return counted(arm_->servoJ(q_target)); }
  bool speedL(const robot::Twist& twist, double acceleration_mm_s2) override {
    return counted(arm_->speedL(twist, acceleration_mm_s2));
  }
  bool stopJ(double deceleration_rad_s2) override { return arm_->stopJ(deceleration_rad_s2); }
  bool protectiveStop() override { return arm_->protectiveStop(); }
  bool unlockProtectiveStop() override { return arm_->unlockProtectiveStop(); }
  double controlPeriodS() const override { return arm_->controlPeriodS(); }

 private:
  bool counted(bool accepted) {
    if (accepted) accepted_->fetch_add(1);
    return accepted;
  }
  std::shared_ptr<robot::RobotArm> arm_;
  std::shared_ptr<std::atomic<std::uint64_t>> accepted_;
};

constexpr std::size_t kCycleRing = 4096;  // 8 s of cycle start times at 500 Hz

bool atRest(const robot::ArmState& arm) {
  return arm.qd.cwiseAbs().maxCoeff() <= 1e-6;  // the supervisor's acknowledge threshold
}

}  // namespace

robot::TrackingSnapshot snapshotFromFeed(const TrackingFeed& feed, double now_s) {
  robot::TrackingSnapshot s;
  s.connected = feed.connected;
  s.time_s = now_s;
  s.drill_tracked = feed.tool_ok && feed.others_ok;
  s.drill_timestamp_s = std::isnan(feed.tool_time_s) ? now_s : feed.tool_time_s;
  s.tracker_T_drill = feed.tracker_T_tool;
  s.patient_tracked = feed.patient_ok;
  s.patient_timestamp_s = std::isnan(feed.patient_time_s) ? now_s : feed.patient_time_s;
  s.tracker_T_patient = feed.tracker_T_patient;
  return s;
}

NavigationRobot::NavigationRobot(const NavigationRobotOptions& options, double max_tracking_age_s,
                                 double marker_noise_mm, std::uint64_t seed, std::function<double()> clock)
    : options_(options),
      max_age_s_(max_tracking_age_s),
      marker_noise_mm_(marker_noise_mm),
      clock_(std::move(clock)),
      rng_(seed * 2654435761ULL + 7) {
  if (!(options.control_rate_hz > 0.0 && options.control_rate_hz <= 1000.0)) {
    throw InvalidArgumentError("navigation robot: control_rate_hz must be in (0, 1000] Hz (UR: 125 or 500), got " +
                               std::to_string(options.control_rate_hz));
  }
  if (!(max_tracking_age_s > 0.0)) {
    throw InvalidArgumentError("navigation robot: silence_timeout_s (the supervisor's tracking age limit) must be > 0");
  }
  if (!(options.advance_speed_mm_s > 0.0)) {
    throw InvalidArgumentError("navigation robot: advance_speed_mm_s must be > 0");
  }
  if (options.robot == "ur") {
    // Connects now, on the caller's thread: an unreachable controller is the caller's error, before any
    // thread starts.
    arm_ = connectUrArm(options);
  } else {
    robot::SimulatedArmOptions arm_options;
    arm_options.control_period_s = 1.0 / options.control_rate_hz;
    sim_arm_ = std::make_shared<robot::SimulatedArm>(arm_options);
    arm_ = sim_arm_;
  }

  robot::ControlLoopSetup setup;
  if (options.flange_T_marker && options.flange_T_tip) {
    // The session's calibrations of this robot's drill.
    flange_T_marker_ = *options.flange_T_marker;
    setup.flange_T_tip = *options.flange_T_tip;
  } else {
    // The simulated drill: the flange marker and tip of the robot module's test scene.
    flange_T_marker_.linear() = so3Exp(Eigen::Vector3d(0.0, 0.5, 0.3));
    flange_T_marker_.translation() << 60, 0, 40;
    setup.flange_T_tip.translation() << 0, 0, 150;
  }
  setup.flange_T_marker = flange_T_marker_;
  setup.plan = options.plan;  // validated by the ControlLoop
  setup.patient_T_plan = options.patient_T_plan;
  // base_T_tracker stays identity: with marker feedback the loop locates the patient through the drill
  // marker, so the robot-tracker calibration does not enter the chain.
  robot::ControlLoopOptions control;
  control.marker_feedback = true;
  control.limits.max_tracking_age_s = max_tracking_age_s;
  control.limits.max_cycle_time_s = options.max_cycle_time_s;
  control.limits.max_missed_cycles = options.max_missed_cycles;
  if (!sim_arm_) {
    // RTDE packages and control ticks run on two clocks: a tick that sees no new package is jitter, not a
    // stalled controller, until the controller has been silent for ur_silence_s.
    control.limits.max_stalled_cycles =
        std::max<std::uint64_t>(control.limits.max_stalled_cycles,
                                static_cast<std::uint64_t>(std::ceil(options.ur_silence_s * options.control_rate_hz)));
  }
  control.guidance.advance_speed_mm_s = options.advance_speed_mm_s;
  control.limits.soft_tissue_margin_mm = options.soft_tissue_margin_mm;
  control.limits.soft_tissue_margin_sd = options.soft_tissue_margin_sd;
  // The shaft from the tip back to the flange: everything of the drill that goes near the patient.
  control.limits.drill_shaft_length_mm =
      options.drill_shaft_length_mm >= 0.0 ? options.drill_shaft_length_mm : setup.flange_T_tip.translation().norm();
  control_ = std::make_unique<robot::ControlLoop>(std::make_shared<MotionCountingArm>(arm_, arm_motion_accepted_),
                                                  kinematics_, setup, control);
  figures_.robot = sim_arm_ ? "simulated" : "ur";
  figures_.supervisor_state = robot::toString(control_->supervisor().state());
  // A real UR's stopping-time limit is a safety setting of the controller; the UR5 CB3 default is what the
  // simulated arm assumes too.
  figures_.stop_time_limit_s =
      sim_arm_ ? sim_arm_->options().stop_time_limit_s : robot::SimulatedArmOptions{}.stop_time_limit_s;
}

NavigationRobot::~NavigationRobot() {
  stop();
}

void NavigationRobot::dock(const Eigen::Isometry3d& tracker_T_patient) {
  // A real arm stands where the robot calibration found it; the simulated cart is wheeled to the patient.
  tracker_T_base_ = sim_arm_ ? simulatedDocking(options_, tracker_T_patient, arm_->state().base_T_flange)
                             : *options_.tracker_T_robot_base;
  docked_ = true;
  thread_ = std::thread([this] { controlThread(); });
}

std::optional<tracking::ToolUpdate> NavigationRobot::observeDrill(
    const std::optional<Eigen::Isometry3d>& tracker_T_patient, double timestamp, bool visible) {
  if (!docked_) {
    if (!tracker_T_patient) return std::nullopt;
    std::lock_guard lock(thread_mutex_);
    if (stopping_) return std::nullopt;
    dock(*tracker_T_patient);
  }
  // A real tracker sees the real drill: its own tool_transform reaches the supervisor.
  if (stopping_ || (!sim_arm_ && !options_.simulate_drill_marker)) return std::nullopt;
  Eigen::Isometry3d tracker_T_marker = tracker_T_base_ * arm_->state().base_T_flange * flange_T_marker_;
  if (marker_noise_mm_ > 0.0) {
    // The simulated tracker's noise model: isotropic, per-axis sigma = rms / sqrt(3).
    std::normal_distribution<double> n(0.0, marker_noise_mm_ / std::sqrt(3.0));
    tracker_T_marker.translation() += Eigen::Vector3d(n(rng_), n(rng_), n(rng_));
  }
  tracking::ToolUpdate u;
  u.name = options_.tool_transform;
  u.to_T_from = tracker_T_marker;
  u.status = visible ? TransformStatus::Ok : TransformStatus::Invalid;
  u.timestamp = timestamp;
  return u;
}

void NavigationRobot::feed(TrackingFeed feed, double now_s) {
  std::lock_guard lock(feed_mutex_);
  feed.connected = feed.connected && feed_.connected;
  const bool lost = !feed.connected || !feed.tool_ok || !feed.patient_ok || !feed.others_ok;
  if (!lost) {
    loss_onset_s_ = std::numeric_limits<double>::quiet_NaN();
  } else if (std::isnan(loss_onset_s_)) {
    loss_onset_s_ = now_s;
  }
  feed_ = std::move(feed);
}

void NavigationRobot::setConnected(bool connected, double now_s) {
  std::lock_guard lock(feed_mutex_);
  if (feed_.connected == connected) return;
  feed_.connected = connected;
  if (!connected) {
    if (std::isnan(loss_onset_s_)) loss_onset_s_ = now_s;
    if (feed_.lost.empty()) feed_.lost = "tracker disconnected";
  }
}

bool NavigationRobot::trackingGood(const TrackingFeed& feed, double now_s) const {
  return feed.connected && feed.tool_ok && feed.patient_ok && feed.others_ok &&
         now_s - feed.tool_time_s <= max_age_s_ && now_s - feed.patient_time_s <= max_age_s_;
}

void NavigationRobot::setSoftTissue(std::shared_ptr<const robot::SoftTissueSurface> surface, double arrived_s) {
  std::lock_guard lock(tissue_mutex_);
  pending_tissue_.emplace(std::move(surface), arrived_s);
}

void NavigationRobot::controlThread() {
  cycle_starts_.assign(kCycleRing, std::numeric_limits<double>::quiet_NaN());
  arm_origin_s_ = clock_();
  control_->runRealTime(
      [this] {
        cycle_start_s_ = clock_();
        {
          std::lock_guard lock(tissue_mutex_);
          if (pending_tissue_) {
            control_->setSoftTissue(std::move(pending_tissue_->first));
            const double installed_ms = 1e3 * (cycle_start_s_ - pending_tissue_->second);
            pending_tissue_.reset();
            std::lock_guard status_lock(status_mutex_);
            figures_.us_frame_to_margin_ms = installed_ms;
          }
        }
        {
          std::lock_guard lock(feed_mutex_);
          cycle_feed_ = feed_;
          cycle_onset_s_ = loss_onset_s_;
        }
        return snapshotFromFeed(cycle_feed_, cycle_start_s_);
      },
      quit_, [this](const robot::CycleReport& report) { onCycle(report); });
  // Leaving: the arm must not keep following a target nobody updates.
  arm_->stopJ(control_->supervisor().limits().stop_deceleration_rad_s2);
}

void NavigationRobot::onCycle(const robot::CycleReport& report) {
  const double period = control_->periodS();
  const double previous_start = cycle_starts_[(report.cycle + kCycleRing - 1) % kCycleRing];
  cycle_starts_[report.cycle % kCycleRing] = cycle_start_s_;
  std::uint64_t missed = 0;
  if (!std::isnan(previous_start) && cycle_start_s_ - previous_start > 1.5 * period) {
    missed = static_cast<std::uint64_t>(std::llround((cycle_start_s_ - previous_start) / period)) - 1;
  }

  std::int64_t latency_cycles = -1;
  double latency_ms = std::numeric_limits<double>::quiet_NaN();
  if (report.stop_sent != robot::StopCommand::None && !report.decision.stop_repeated) {
    // When the loss began: a stale pose became stale at its time plus the age limit; otherwise the first
    // batch that showed the loss (or when the loop saw the source go away).
    double onset = cycle_onset_s_;
    if (report.decision.reason == robot::StopReason::ToolStale) onset = cycle_feed_.tool_time_s + max_age_s_;
    if (report.decision.reason == robot::StopReason::PatientStale) onset = cycle_feed_.patient_time_s + max_age_s_;
    if (std::isnan(onset)) onset = cycle_start_s_;  // not a tracking stop: counted from this cycle
    latency_ms = 1e3 * (cycle_start_s_ - onset);
    latency_cycles = 0;
    for (std::uint64_t k = 0; k < kCycleRing && k < report.cycle; ++k) {
      const double t = cycle_starts_[(report.cycle - k) % kCycleRing];
      if (std::isnan(t) || t < onset) break;
      ++latency_cycles;
    }
    stop_arm_time_s_ = arm_->state().time_s;
  }

  // Operator requests run here, between two cycles, on the only thread that touches the ControlLoop.
  std::deque<std::packaged_task<bool(robot::ControlLoop&)>> requests;
  {
    std::lock_guard lock(request_mutex_);
    requests.swap(requests_);
  }
  for (auto& r : requests) r(*control_);
  if (options_.auto_start && !auto_started_ && !hold_ && trackingGood(cycle_feed_, cycle_start_s_) &&
      control_->supervisor().state() == robot::SupervisorState::Disabled) {
    // A UR controller refuses until its first RTDE package arrived: tried again next cycle.
    if (control_->enable()) {
      auto_started_ = true;
      control_->startPlacement();
    }
  }

  if (sim_arm_) {
    // The simulated controller runs on the wall clock: cycles this thread missed pass for the arm too.
    const auto due = static_cast<std::uint64_t>(std::max(0.0, std::floor((clock_() - arm_origin_s_) / period)));
    const std::uint64_t steps = std::clamp<std::uint64_t>(due > arm_steps_ ? due - arm_steps_ : 1, 1, 25);
    for (std::uint64_t k = 0; k < steps; ++k) sim_arm_->step();
    arm_steps_ = std::max(due, arm_steps_ + steps);
  }
  const robot::ArmState arm = arm_->state();
  double time_to_stop = std::numeric_limits<double>::quiet_NaN();
  if (!std::isnan(stop_arm_time_s_) && atRest(arm)) {
    time_to_stop = arm.time_s - stop_arm_time_s_;
    stop_arm_time_s_ = std::numeric_limits<double>::quiet_NaN();
  }

  const auto& supervisor = control_->supervisor();
  const auto& records = supervisor.transitions();
  std::lock_guard lock(status_mutex_);
  for (std::size_t i = log_.size(); i < records.size(); ++i) {
    const auto& r = records[i];
    NavigationRobotTransition t;
    t.cycle = r.cycle;
    const double start = cycle_starts_[r.cycle % kCycleRing];
    t.time_s = std::isnan(start) ? cycle_start_s_ : start;
    t.from = robot::toString(r.from);
    t.to = robot::toString(r.to);
    t.reason = robot::toString(r.reason);
    t.command = robot::toString(r.command);
    t.detail = r.detail;
    if (r.to == robot::SupervisorState::Stopped || r.to == robot::SupervisorState::Fault) t.tracking = cycle_feed_.lost;
    figures_.last_transition = "cycle " + std::to_string(t.cycle) + " " + t.from + " -> " + t.to + " (" + t.reason +
                               ": " + t.detail + ") " + t.command;
    log_.push_back(std::move(t));
  }
  auto& f = figures_;
  f.robot_docked = true;
  f.supervisor_state = robot::toString(supervisor.state());
  f.supervisor_stop =
      supervisor.lastStopReason() == robot::StopReason::None ? "" : robot::toString(supervisor.lastStopReason());
  f.guidance_phase = robot::toString(control_->guidance().phase());
  f.robot_cycles = report.cycle;
  f.robot_missed_cycles += missed;
  f.arm_speed_rad_s = arm.qd.cwiseAbs().maxCoeff();
  f.flange_speed_mm_s = arm.flange_twist.head<3>().norm();
  f.depth_mm = report.guidance.depth_mm;
  if (report.motion_sent) ++f.motion_commands;
  // Counted at the arm, not from the loop's report (which never sends motion
  // in a stopped state by construction): any motion the arm accepted in a
  // cycle that ends with the supervisor stopped is a violation.
  const std::uint64_t accepted = arm_motion_accepted_->load();
  const std::uint64_t new_motion = accepted - arm_motion_checked_;
  arm_motion_checked_ = accepted;
  if (new_motion > 0 &&
      (supervisor.state() == robot::SupervisorState::Stopped || supervisor.state() == robot::SupervisorState::Fault)) {
    f.motion_commands_after_stop += new_motion;
  }
  if (latency_cycles >= 0) {
    ++f.robot_stops;
    f.stop_latency_cycles = latency_cycles;
    f.stop_latency_ms = latency_ms;
    f.time_to_stop_s = std::numeric_limits<double>::quiet_NaN();
  }
  if (!std::isnan(time_to_stop)) f.time_to_stop_s = time_to_stop;
}

bool NavigationRobot::post(std::function<bool(robot::ControlLoop&)> request, std::string& why) {
  if (!docked_ || stopping_) {
    why = docked_ ? "the robot's control loop has stopped" : "the robot is not docked yet (no patient sample so far)";
    return false;
  }
  // 0 pending, 1 running, 2 given up by the caller: a request the caller
  // reported as not done must never run later (a late resume would move the
  // arm after the operator was told the re-arm failed).
  auto phase = std::make_shared<std::atomic<int>>(0);
  std::packaged_task<bool(robot::ControlLoop&)> task([phase, request = std::move(request)](robot::ControlLoop& c) {
    int pending = 0;
    if (!phase->compare_exchange_strong(pending, 1)) return false;
    return request(c);
  });
  auto result = task.get_future();
  {
    std::lock_guard lock(request_mutex_);
    requests_.push_back(std::move(task));
  }
  if (result.wait_for(std::chrono::seconds(2)) != std::future_status::ready) {
    int pending = 0;
    if (phase->compare_exchange_strong(pending, 2)) {
      why = "the robot's control loop did not answer within 2 s (nothing was done)";
      return false;
    }
    result.wait();  // it started meanwhile: its outcome is the answer
  }
  try {
    return result.get();
  } catch (const std::exception&) {
    why = "the robot's control loop stopped before answering";
    return false;
  }
}

bool NavigationRobot::rearm(std::string& why) {
  // The loop does not reconnect a lost controller: acknowledging would only stop again on the next cycle.
  if (!sim_arm_ && !arm_->state().connected) {
    why = "the UR controller at " + options_.ur_host +
          " is not connected: check it (power, network, remote "
          "control), then start navigation again";
    return false;
  }
  {
    std::lock_guard lock(feed_mutex_);
    if (docked_ && !trackingGood(feed_, clock_())) {
      why = "tracking is still lost (" + (feed_.lost.empty() ? std::string("stale poses") : feed_.lost) +
            "): restore it, then re-arm";
      return false;
    }
  }
  const bool held = hold_.load();
  // After the operator's stop the paused placement resumes; after a safety stop the supervisor
  // acknowledges and waits in Ready.
  const auto rearm_request = [held](robot::ControlLoop& c) {
    const auto state = c.supervisor().state();
    if (state == robot::SupervisorState::Paused) return c.resume();
    if (state == robot::SupervisorState::Stopped || state == robot::SupervisorState::Fault) return c.acknowledge();
    return held;  // operator-held before anything moved: nothing to acknowledge
  };
  if (!docked_ && held) {
    hold_ = false;
    return true;
  }
  if (post(rearm_request, why)) {
    hold_ = false;
    return true;
  }
  if (why.empty()) {
    std::string state;
    {
      std::lock_guard lock(status_mutex_);  // the supervisor itself belongs to the control thread
      state = figures_.supervisor_state;
    }
    why = "the supervisor refused to acknowledge: it is not stopped, or the arm still moves (state " + state + ")";
  }
  return false;
}

bool NavigationRobot::operatorStop(std::string& why) {
  hold_ = true;
  if (!docked_) return true;  // the arm has not moved yet; the hold keeps it so
  const bool ok = post(
      [this](robot::ControlLoop& c) {
        const auto state = c.supervisor().state();
        if (state != robot::SupervisorState::Aligning && state != robot::SupervisorState::Advancing) {
          return true;  // not commanding motion: Ready, Paused, Stopped, Fault, Disabled
        }
        if (!c.pause()) return false;
        // Control thread: the time to rest is measured from here, as for a safety stop.
        stop_arm_time_s_ = arm_->state().time_s;
        std::lock_guard lock(status_mutex_);
        figures_.time_to_stop_s = std::numeric_limits<double>::quiet_NaN();
        return true;
      },
      why);
  if (!ok && why.empty()) why = "the supervisor refused the operator's pause";
  return ok;
}

bool NavigationRobot::startPlacement() {
  std::string why;
  return post(
      [](robot::ControlLoop& c) {
        if (c.supervisor().state() == robot::SupervisorState::Disabled) c.enable();
        return c.startPlacement();
      },
      why);
}

void NavigationRobot::stop() {
  {
    std::lock_guard lock(thread_mutex_);
    stopping_ = true;
    quit_ = true;
    if (thread_.joinable()) thread_.join();
  }
  std::lock_guard lock(request_mutex_);
  requests_.clear();
}

void NavigationRobot::fillStatus(NavigationStatus& s) const {
  std::lock_guard lock(status_mutex_);
  const auto& f = figures_;
  s.robot = f.robot;
  s.robot_docked = f.robot_docked;
  s.supervisor_state = f.supervisor_state;
  s.supervisor_stop = f.supervisor_stop;
  s.last_transition = f.last_transition;
  s.guidance_phase = f.guidance_phase;
  s.robot_cycles = f.robot_cycles;
  s.robot_missed_cycles = f.robot_missed_cycles;
  s.arm_speed_rad_s = f.arm_speed_rad_s;
  s.flange_speed_mm_s = f.flange_speed_mm_s;
  s.depth_mm = f.depth_mm;
  s.motion_commands = f.motion_commands;
  s.motion_commands_after_stop = f.motion_commands_after_stop;
  s.robot_stops = f.robot_stops;
  s.stop_latency_cycles = f.stop_latency_cycles;
  s.stop_latency_ms = f.stop_latency_ms;
  s.time_to_stop_s = f.time_to_stop_s;
  s.stop_time_limit_s = f.stop_time_limit_s;
  // The frame's margin is in force from the cycle that installed it.
  if (std::isfinite(f.us_frame_to_margin_ms)) s.us_frame_to_margin_ms = f.us_frame_to_margin_ms;
}

std::vector<NavigationRobotTransition> NavigationRobot::transitions() const {
  std::lock_guard lock(status_mutex_);
  return log_;
}

}  // namespace detail
}  // namespace mrsns::workflow
