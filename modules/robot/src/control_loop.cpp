#include "mrsns/robot/control_loop.h"

#include <chrono>
#include <cmath>
#include <thread>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"

namespace mrsns::robot {

TrackingSnapshot snapshotFromRepository(const TransformRepository& repository, TransformRepository::Query& drill,
                                        TransformRepository::Query& patient, double now_s, bool connected) {
  TrackingSnapshot s;
  s.connected = connected;
  s.time_s = now_s;
  const auto d = repository.evaluate(drill);
  const auto p = repository.evaluate(patient);
  s.drill_tracked = d.status == TransformStatus::Ok;
  s.drill_timestamp_s = std::isnan(d.timestamp) ? now_s : d.timestamp;
  s.tracker_T_drill = d.to_T_from;
  s.patient_tracked = p.status == TransformStatus::Ok;
  s.patient_timestamp_s = std::isnan(p.timestamp) ? now_s : p.timestamp;
  s.tracker_T_patient = p.to_T_from;
  return s;
}

ControlLoop::ControlLoop(std::shared_ptr<RobotArm> arm, const Ur5Kinematics& kinematics, const ControlLoopSetup& setup,
                         const ControlLoopOptions& options)
    : arm_(std::move(arm)),
      kinematics_(kinematics),
      setup_(setup),
      options_(options),
      supervisor_(options.limits),
      guidance_(kinematics, setup.flange_T_tip, options.guidance) {
  if (!arm_) throw InvalidArgumentError("ControlLoop: the robot arm is null; pass the arm the loop commands");
  registration::validateScrewPath(setup.plan);
  period_ = arm_->controlPeriodS();
  if (!(period_ > 0)) throw InvalidArgumentError("ControlLoop: the arm reports a non-positive control period");
  marker_T_tip_ = setup.flange_T_marker.inverse() * setup.flange_T_tip;
  PlannedAxis axis;
  axis.entry = setup.plan.entry;
  axis.direction = setup.plan.direction();
  axis.valid = true;
  supervisor_.setPlannedAxis(axis);
  last_arm_ = arm_->state();
}

void ControlLoop::setSoftTissue(std::shared_ptr<const MeshLocator> surface) {
  supervisor_.setSoftTissue(std::move(surface));
}

void ControlLoop::setSoftTissue(std::shared_ptr<const SoftTissueSurface> surface) {
  supervisor_.setSoftTissue(std::move(surface));
}

CycleReport ControlLoop::tick(const TrackingSnapshot& tracking, double cycle_time_s, std::uint64_t missed_cycles) {
  CycleReport report;
  ++cycle_;
  time_s_ += period_ * static_cast<double>(1 + missed_cycles);
  report.cycle = cycle_;
  const ArmState arm = arm_->state();
  last_arm_ = arm;

  // Where the patient (plan frame) is in the robot base this cycle.
  const bool tracked = tracking.connected && tracking.drill_tracked && tracking.patient_tracked;
  if (tracking.connected && tracking.patient_tracked && (tracking.drill_tracked || !options_.marker_feedback)) {
    const Eigen::Isometry3d base_T_tracker =
        options_.marker_feedback ? arm.base_T_flange * setup_.flange_T_marker * tracking.tracker_T_drill.inverse()
                                 : setup_.base_T_tracker;
    const Eigen::Isometry3d measured = base_T_tracker * tracking.tracker_T_patient * setup_.patient_T_plan;
    if (!have_estimate_) {
      base_T_plan_ = measured;
      have_estimate_ = true;
    } else {
      const double alpha = std::min(1.0, period_ / options_.estimate_time_constant_s);
      base_T_plan_ = interpolatePose(base_T_plan_, measured, alpha);
    }
  }
  report.base_T_plan = base_T_plan_;

  SupervisorInputs in;
  in.cycle = cycle_;
  in.time_s = time_s_;
  in.arm = arm;
  in.tracker_connected = tracking.connected;
  in.tool_tracked = tracking.drill_tracked;
  in.tool_age_s = tracking.time_s - tracking.drill_timestamp_s;
  in.patient_tracked = tracking.patient_tracked;
  in.patient_age_s = tracking.time_s - tracking.patient_timestamp_s;
  if (tracked) {
    // The drill as the tracker sees it, in the plan frame: independent of the robot's own kinematics.
    const Eigen::Isometry3d plan_T_tip = setup_.patient_T_plan.inverse() * tracking.tracker_T_patient.inverse() *
                                         tracking.tracker_T_drill * marker_T_tip_;
    const Eigen::Vector3d tip = plan_T_tip.translation(), axis = plan_T_tip.linear().col(2);
    if (!have_tip_ || options_.measurement_time_constant_s <= 0) {
      tip_plan_filtered_ = tip;
      axis_plan_filtered_ = axis;
      have_tip_ = true;
    } else if (tracking.drill_timestamp_s != last_drill_timestamp_) {
      const double dt = std::max(0.0, tracking.drill_timestamp_s - last_drill_timestamp_);
      const double alpha = 1.0 - std::exp(-dt / options_.measurement_time_constant_s);
      tip_plan_filtered_ += alpha * (tip - tip_plan_filtered_);
      axis_plan_filtered_ = (axis_plan_filtered_ + alpha * (axis - axis_plan_filtered_)).normalized();
    }
    last_drill_timestamp_ = tracking.drill_timestamp_s;
    in.tip_plan = tip_plan_filtered_;
    in.axis_plan = axis_plan_filtered_;
  } else {
    have_tip_ = false;  // after a tracking gap the filter restarts from the first new measurement
  }
  in.tip_base = (arm.base_T_flange * setup_.flange_T_tip).translation();
  in.tip_speed_mm_s =
      (arm.flange_twist.head<3>() + arm.flange_twist.tail<3>().cross(in.tip_base - arm.base_T_flange.translation()))
          .norm();
  in.cycle_time_s = cycle_time_s;
  in.missed_cycles = missed_cycles;
  report.decision = supervisor_.tick(in);

  // A stop goes out first, in the cycle it was detected; nothing else is sent in that cycle.
  if (report.decision.stop != StopCommand::None) {
    report.stop_sent = report.decision.stop;
    report.stop_accepted = report.decision.stop == StopCommand::ProtectiveStop
                               ? arm_->protectiveStop()
                               : arm_->stopJ(options_.limits.stop_deceleration_rad_s2);
    // A repeated stop changes nothing the first one did not: a paused placement (whose stop is repeated until the
    // arm rests) keeps its guidance and resumes where it was.
    if (!report.decision.stop_repeated) guidance_.reset();
    return report;
  }
  if (!report.decision.motion_allowed || !have_estimate_) return report;

  AxisInBase axis;
  axis.entry = base_T_plan_ * setup_.plan.entry;
  axis.direction = base_T_plan_.linear() * setup_.plan.direction();
  axis.length_mm = setup_.plan.effectiveLength();
  report.guidance = guidance_.update(arm, axis, period_, hand_);
  if (report.guidance.aligned) supervisor_.aligned(cycle_, time_s_);
  if (report.guidance.done) supervisor_.finished(cycle_, time_s_);
  if (report.guidance.has_target) report.motion_sent = arm_->servoJ(report.guidance.q);
  return report;
}

void ControlLoop::runRealTime(const std::function<TrackingSnapshot()>& read_tracking, const std::atomic<bool>& stop,
                              const std::function<void(const CycleReport&)>& on_cycle) {
  using Clock = std::chrono::steady_clock;
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(period_));
  auto next = Clock::now() + period;
  double last_cycle_time = 0;
  std::uint64_t missed = 0;
  while (!stop.load(std::memory_order_relaxed)) {
    const auto begin = Clock::now();
    const CycleReport r = tick(read_tracking(), last_cycle_time, missed);
    if (on_cycle) on_cycle(r);
    const auto end = Clock::now();
    last_cycle_time = std::chrono::duration<double>(end - begin).count();
    // Cycles whose start time already passed are missed, not run late in a burst.
    missed = 0;
    while (next <= end) {
      next += period;
      ++missed;
    }
    if (missed > 0) --missed;  // the boundary just passed is the next cycle, not a missed one
    std::this_thread::sleep_until(next);
    next += period;
  }
}

bool ControlLoop::enable() {
  if (!arm_->state().connected) return false;
  return supervisor_.enable(cycle_, time_s_);
}

bool ControlLoop::startPlacement() {
  if (!supervisor_.startAligning(cycle_, time_s_)) return false;
  guidance_.start(arm_->state());
  return true;
}

bool ControlLoop::pause() {
  if (!supervisor_.pause(cycle_, time_s_)) return false;
  arm_->stopJ(options_.limits.stop_deceleration_rad_s2);
  return true;
}

bool ControlLoop::resume() {
  return supervisor_.resume(cycle_, time_s_);
}

bool ControlLoop::retract() {
  if (guidance_.phase() != GuidancePhase::Advance) return false;
  guidance_.retract();
  return true;
}

bool ControlLoop::acknowledge() {
  ArmState arm = arm_->state();
  if (arm.safety == SafetyMode::ProtectiveStop) {
    if (!arm_->unlockProtectiveStop()) return false;
    arm = arm_->state();
  }
  return supervisor_.acknowledge(arm, cycle_, time_s_);
}

}  // namespace mrsns::robot
