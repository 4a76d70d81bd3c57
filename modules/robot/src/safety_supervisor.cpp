#include "mrsns/robot/safety_supervisor.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"

namespace mrsns::robot {

const char* toString(SupervisorState state) {
  switch (state) {
    case SupervisorState::Disabled: return "Disabled";
    case SupervisorState::Ready: return "Ready";
    case SupervisorState::Aligning: return "Aligning";
    case SupervisorState::Advancing: return "Advancing";
    case SupervisorState::Paused: return "Paused";
    case SupervisorState::Stopped: return "Stopped";
    case SupervisorState::Fault: return "Fault";
  }
  return "Unknown";
}

const char* toString(StopReason reason) {
  switch (reason) {
    case StopReason::None: return "None";
    case StopReason::ToolNotTracked: return "ToolNotTracked";
    case StopReason::PatientNotTracked: return "PatientNotTracked";
    case StopReason::ToolStale: return "ToolStale";
    case StopReason::PatientStale: return "PatientStale";
    case StopReason::OffAxisDistance: return "OffAxisDistance";
    case StopReason::OffAxisAngle: return "OffAxisAngle";
    case StopReason::SoftTissueMargin: return "SoftTissueMargin";
    case StopReason::OutsideWorkspace: return "OutsideWorkspace";
    case StopReason::OverSpeed: return "OverSpeed";
    case StopReason::WatchdogOverrun: return "WatchdogOverrun";
    case StopReason::MissedCycles: return "MissedCycles";
    case StopReason::RobotDisconnected: return "RobotDisconnected";
    case StopReason::RobotStalled: return "RobotStalled";
    case StopReason::TrackerDisconnected: return "TrackerDisconnected";
    case StopReason::RobotProtectiveStop: return "RobotProtectiveStop";
    case StopReason::RobotEmergencyStop: return "RobotEmergencyStop";
    case StopReason::RobotFault: return "RobotFault";
    case StopReason::Operator: return "Operator";
  }
  return "Unknown";
}

const char* toString(StopCommand command) {
  switch (command) {
    case StopCommand::None: return "None";
    case StopCommand::StopJ: return "StopJ";
    case StopCommand::ProtectiveStop: return "ProtectiveStop";
  }
  return "Unknown";
}

SafetySupervisor::SafetySupervisor(const SupervisorLimits& limits) : limits_(limits) {}

bool SafetySupervisor::active() const {
  return state_ == SupervisorState::Ready || state_ == SupervisorState::Aligning ||
         state_ == SupervisorState::Advancing || state_ == SupervisorState::Paused;
}

void SafetySupervisor::transition(SupervisorState to, StopReason reason, StopCommand command, std::uint64_t cycle,
                                  double time_s, std::string detail) {
  TransitionRecord r{cycle, time_s, state_, to, reason, command, std::move(detail)};
  if (to == SupervisorState::Stopped || to == SupervisorState::Fault) {
    last_stop_ = reason;
    logger()->warn("robot supervisor: cycle {} {} -> {} ({}: {}), command {}", cycle, toString(state_), toString(to),
                   toString(reason), r.detail, toString(command));
  } else {
    logger()->info("robot supervisor: cycle {} {} -> {} ({})", cycle, toString(state_), toString(to), r.detail);
  }
  if (to == SupervisorState::Paused) paused_from_ = state_;
  if (command != StopCommand::None) {
    pending_stop_ = command;
    pending_reason_ = reason;
  } else if (to == SupervisorState::Aligning || to == SupervisorState::Advancing || to == SupervisorState::Ready) {
    pending_stop_ = StopCommand::None;  // acknowledged or moving again: the earlier stop is over
  }
  state_ = to;
  log_.push_back(std::move(r));
}

void SafetySupervisor::setSoftTissue(std::shared_ptr<const SoftTissueSurface> surface) {
  if (surface && surface->surface && !surface->face_sd_mm.empty() &&
      static_cast<Eigen::Index>(surface->face_sd_mm.size()) != surface->surface->faceCount()) {
    throw InvalidArgumentError(fmt::format("soft tissue: {} standard deviations for {} faces",
                                           surface->face_sd_mm.size(), surface->surface->faceCount()));
  }
  soft_tissue_ = surface && surface->surface ? std::move(surface) : nullptr;
}

void SafetySupervisor::setSoftTissue(std::shared_ptr<const MeshLocator> surface) {
  if (!surface) {
    soft_tissue_.reset();
    return;
  }
  auto exact = std::make_shared<SoftTissueSurface>();
  exact->surface = std::move(surface);
  soft_tissue_ = std::move(exact);
}

SafetySupervisor::SoftTissueIntrusion SafetySupervisor::softTissueIntrusion(const SupervisorInputs& in) const {
  const SoftTissueSurface& tissue = *soft_tissue_;
  const double shaft = std::max(0.0, limits_.drill_shaft_length_mm);
  const int steps = shaft > 0.0 ? static_cast<int>(std::ceil(shaft / std::max(limits_.drill_shaft_step_mm, 0.01))) : 0;
  const double step = steps > 0 ? shaft / steps : 0.0;
  // Any point of the shaft lies within step/2 of a check point.
  const double base = limits_.soft_tissue_margin_mm + 0.5 * step;
  const double k = std::max(0.0, limits_.soft_tissue_margin_sd);
  const double reach = base + k * tissue.max_sd_mm;
  auto margin_at = [&](Eigen::Index face) {
    return tissue.face_sd_mm.empty() ? base : base + k * tissue.face_sd_mm[static_cast<std::size_t>(face)];
  };
  const Eigen::Vector3d back = -in.axis_plan.normalized();
  // Far from the whole shaft (the usual case): one query.
  if (steps > 0 && tissue.surface->closestPointWithin(in.tip_plan + 0.5 * shaft * back, 0.5 * shaft + reach).face < 0) {
    return {SurfacePoint{}, base, 0.0};
  }
  SurfacePoint nearest;
  SoftTissueIntrusion worst{SurfacePoint{}, base, 0.0};
  double worst_excess = 0.0;
  for (int i = 0; i <= steps; ++i) {
    const auto sp = tissue.surface->closestPointWithin(in.tip_plan + (i * step) * back, reach);
    if (sp.face < 0) continue;
    if (sp.distance < nearest.distance) nearest = sp;
    const double margin = margin_at(sp.face);
    if (sp.distance - margin < worst_excess) {
      worst_excess = sp.distance - margin;
      worst = {sp, margin, i * step};
    }
  }
  if (worst.nearest.face >= 0) return worst;
  nearest.face = -1;  // within reach but outside its own margin: reported, not a stop
  return {nearest, base, 0.0};
}

SupervisorDecision SafetySupervisor::tick(const SupervisorInputs& in) {
  SupervisorDecision d;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  d.axis_distance_mm = d.axis_angle_rad = d.soft_tissue_distance_mm = nan;

  // Stall detection runs in every state so a frozen controller is noticed before motion is requested.
  if (have_robot_cycle_ && in.arm.cycle == last_robot_cycle_) {
    ++stalled_ticks_;
  } else {
    stalled_ticks_ = 0;
  }
  last_robot_cycle_ = in.arm.cycle;
  have_robot_cycle_ = true;

  if (active()) {
    StopReason reason = StopReason::None;
    StopCommand command = StopCommand::StopJ;
    std::string detail;
    auto fail = [&](StopReason r, StopCommand c, std::string text) {
      if (reason == StopReason::None) {
        reason = r;
        command = c;
        detail = std::move(text);
      }
    };
    const bool moving_phase = state_ == SupervisorState::Aligning || state_ == SupervisorState::Advancing;
    // Robot-reported stops first: they are the most severe and the robot is already stopping.
    if (in.arm.safety == SafetyMode::EmergencyStop) {
      fail(StopReason::RobotEmergencyStop, StopCommand::ProtectiveStop, "robot reports an emergency stop");
    } else if (in.arm.safety == SafetyMode::ProtectiveStop) {
      fail(StopReason::RobotProtectiveStop, StopCommand::ProtectiveStop, "robot reports a protective stop");
    } else if (in.arm.safety == SafetyMode::Fault || in.arm.safety == SafetyMode::Violation) {
      fail(StopReason::RobotFault, StopCommand::ProtectiveStop,
           std::string("robot reports safety mode ") + toString(in.arm.safety));
    }
    if (!in.arm.connected) {
      fail(StopReason::RobotDisconnected, StopCommand::ProtectiveStop, "no connection to the robot");
    } else if (stalled_ticks_ >= limits_.max_stalled_cycles) {
      fail(StopReason::RobotStalled, StopCommand::ProtectiveStop,
           fmt::format("robot cycle counter stuck at {} for {} ticks", in.arm.cycle, stalled_ticks_));
    }
    if (!in.tracker_connected)
      fail(StopReason::TrackerDisconnected, StopCommand::StopJ, "no connection to the tracker");
    if (!in.tool_tracked) fail(StopReason::ToolNotTracked, StopCommand::StopJ, "drill marker not tracked");
    if (!in.patient_tracked) fail(StopReason::PatientNotTracked, StopCommand::StopJ, "patient reference not tracked");
    if (in.tool_tracked && !(in.tool_age_s <= limits_.max_tracking_age_s)) {
      fail(StopReason::ToolStale, StopCommand::StopJ, fmt::format("drill pose {:.3f} s old", in.tool_age_s));
    }
    if (in.patient_tracked && !(in.patient_age_s <= limits_.max_tracking_age_s)) {
      fail(StopReason::PatientStale, StopCommand::StopJ, fmt::format("patient pose {:.3f} s old", in.patient_age_s));
    }
    if (in.cycle_time_s > limits_.max_cycle_time_s) {
      fail(StopReason::WatchdogOverrun, StopCommand::StopJ,
           fmt::format("cycle took {:.2f} ms > {:.2f} ms", 1e3 * in.cycle_time_s, 1e3 * limits_.max_cycle_time_s));
    }
    if (in.missed_cycles > limits_.max_missed_cycles) {
      fail(StopReason::MissedCycles, StopCommand::StopJ, fmt::format("{} cycles missed", in.missed_cycles));
    }
    const double speed = in.tip_speed_mm_s;
    if (!(speed <= limits_.max_tcp_speed_mm_s)) {
      fail(StopReason::OverSpeed, StopCommand::ProtectiveStop,
           fmt::format("drill tip speed {:.1f} mm/s > {:.1f}", speed, limits_.max_tcp_speed_mm_s));
    }
    if (!((in.tip_base.array() >= limits_.workspace_min_mm.array()).all() &&
          (in.tip_base.array() <= limits_.workspace_max_mm.array()).all())) {
      fail(StopReason::OutsideWorkspace, StopCommand::StopJ,
           fmt::format("drill tip ({:.0f}, {:.0f}, {:.0f}) mm outside the workspace", in.tip_base.x(), in.tip_base.y(),
                       in.tip_base.z()));
    }
    const bool tracking_ok = in.tool_tracked && in.patient_tracked && in.tracker_connected;
    if (tracking_ok && soft_tissue_ && (moving_phase || state_ == SupervisorState::Paused)) {
      const SoftTissueIntrusion hit = softTissueIntrusion(in);
      d.soft_tissue_distance_mm = hit.nearest.distance;
      if (hit.nearest.face >= 0) {
        fail(StopReason::SoftTissueMargin, StopCommand::ProtectiveStop,
             hit.behind_tip_mm > 0.0
                 ? fmt::format("drill shaft ({:.1f} mm behind the tip) {:.2f} mm from the soft tissue (margin {:.2f} mm)",
                               hit.behind_tip_mm, hit.nearest.distance, hit.margin_mm)
                 : fmt::format("drill tip {:.2f} mm from the soft tissue (margin {:.2f} mm)", hit.nearest.distance,
                               hit.margin_mm));
      }
    }
    if (tracking_ok && axis_.valid) {
      const Eigen::Vector3d rel = in.tip_plan - axis_.entry;
      d.axis_distance_mm = (rel - rel.dot(axis_.direction) * axis_.direction).norm();
      d.axis_angle_rad = std::atan2(in.axis_plan.cross(axis_.direction).norm(), in.axis_plan.dot(axis_.direction));
      if (state_ == SupervisorState::Advancing) {
        if (!(d.axis_distance_mm <= limits_.max_axis_distance_mm)) {
          fail(StopReason::OffAxisDistance, StopCommand::StopJ,
               fmt::format("drill tip {:.2f} mm off the planned axis (limit {:.2f})", d.axis_distance_mm,
                           limits_.max_axis_distance_mm));
        }
        if (!(d.axis_angle_rad <= limits_.max_axis_angle_rad)) {
          fail(StopReason::OffAxisAngle, StopCommand::StopJ,
               fmt::format("drill {:.2f} deg off the planned direction (limit {:.2f})",
                           d.axis_angle_rad * 180 / std::numbers::pi,
                           limits_.max_axis_angle_rad * 180 / std::numbers::pi));
        }
      }
    }
    if (reason != StopReason::None) {
      const bool robot_side = reason == StopReason::RobotEmergencyStop || reason == StopReason::RobotProtectiveStop ||
                              reason == StopReason::RobotFault;
      transition(robot_side ? SupervisorState::Fault : SupervisorState::Stopped, reason, command, in.cycle, in.time_s,
                 detail);
      d.stop = command;
      d.reason = reason;
    }
  }
  d.state = state_;
  d.motion_allowed = state_ == SupervisorState::Aligning || state_ == SupervisorState::Advancing;
  // A stop is repeated every cycle until the arm is at rest: a controller that missed or ignored it (a lost
  // packet, a program that was not listening) still stops within a cycle of the next one.
  if (d.stop == StopCommand::None && pending_stop_ != StopCommand::None && !d.motion_allowed) {
    if (in.arm.qd.cwiseAbs().maxCoeff() > limits_.at_rest_joint_speed_rad_s) {
      d.stop = pending_stop_;
      d.reason = pending_reason_;
      d.stop_repeated = true;
    } else {
      pending_stop_ = StopCommand::None;
    }
  }
  return d;
}

bool SafetySupervisor::enable(std::uint64_t cycle, double time_s) {
  if (state_ != SupervisorState::Disabled) return false;
  transition(SupervisorState::Ready, StopReason::None, StopCommand::None, cycle, time_s, "enabled");
  return true;
}

bool SafetySupervisor::disable(std::uint64_t cycle, double time_s) {
  if (state_ == SupervisorState::Disabled) return false;
  transition(SupervisorState::Disabled, StopReason::Operator, StopCommand::StopJ, cycle, time_s, "disabled");
  return true;
}

bool SafetySupervisor::startAligning(std::uint64_t cycle, double time_s) {
  if (state_ != SupervisorState::Ready || !axis_.valid) return false;
  transition(SupervisorState::Aligning, StopReason::None, StopCommand::None, cycle, time_s, "align to planned axis");
  return true;
}

bool SafetySupervisor::aligned(std::uint64_t cycle, double time_s) {
  if (state_ != SupervisorState::Aligning) return false;
  transition(SupervisorState::Advancing, StopReason::None, StopCommand::None, cycle, time_s, "aligned");
  return true;
}

bool SafetySupervisor::finished(std::uint64_t cycle, double time_s) {
  if (state_ != SupervisorState::Advancing && state_ != SupervisorState::Aligning) return false;
  transition(SupervisorState::Ready, StopReason::None, StopCommand::None, cycle, time_s, "path finished");
  return true;
}

bool SafetySupervisor::pause(std::uint64_t cycle, double time_s) {
  if (state_ != SupervisorState::Aligning && state_ != SupervisorState::Advancing) return false;
  transition(SupervisorState::Paused, StopReason::Operator, StopCommand::StopJ, cycle, time_s, "paused");
  return true;
}

bool SafetySupervisor::resume(std::uint64_t cycle, double time_s) {
  if (state_ != SupervisorState::Paused) return false;
  transition(paused_from_, StopReason::None, StopCommand::None, cycle, time_s, "resumed");
  return true;
}

bool SafetySupervisor::acknowledge(const ArmState& arm, std::uint64_t cycle, double time_s) {
  if (state_ != SupervisorState::Stopped && state_ != SupervisorState::Fault) return false;
  if (arm.qd.cwiseAbs().maxCoeff() > 1e-6) return false;
  if (arm.safety != SafetyMode::Normal && arm.safety != SafetyMode::Reduced) return false;
  transition(SupervisorState::Ready, StopReason::None, StopCommand::None, cycle, time_s,
             std::string("acknowledged ") + toString(last_stop_));
  last_stop_ = StopReason::None;
  return true;
}

}  // namespace mrsns::robot
