#include "mrsns/robot/guidance.h"

#include <algorithm>
#include <cmath>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"

namespace mrsns::robot {

const char* toString(GuidancePhase phase) {
  switch (phase) {
    case GuidancePhase::Idle: return "Idle";
    case GuidancePhase::Approach: return "Approach";
    case GuidancePhase::Advance: return "Advance";
    case GuidancePhase::Retract: return "Retract";
    case GuidancePhase::Done: return "Done";
  }
  return "Unknown";
}

Twist constrainToAxis(const Twist& hand, const Eigen::Vector3d& direction) {
  Twist t = Twist::Zero();
  const double n = direction.norm();
  if (!(n > 0) || !hand.allFinite()) return t;
  const Eigen::Vector3d d = direction / n;
  t.head<3>() = hand.head<3>().dot(d) * d;
  return t;
}

Guidance::Guidance(const Ur5Kinematics& kinematics, const Eigen::Isometry3d& flange_T_tip,
                   const GuidanceOptions& options)
    : kinematics_(kinematics), flange_T_tip_(flange_T_tip), options_(options) {
  if (!(options.approach_speed_mm_s > 0) || !(options.approach_rotation_speed_rad_s > 0) ||
      !(options.approach_acceleration_mm_s2 > 0) || !(options.approach_angular_acceleration_rad_s2 > 0) ||
      !(options.advance_speed_mm_s > 0) || !(options.retract_speed_mm_s > 0) || !(options.align_tolerance_mm > 0) ||
      !(options.align_tolerance_rad > 0) || !(options.standoff_mm >= 0)) {
    throw InvalidArgumentError("Guidance: speeds and tolerances must be positive and standoff_mm >= 0");
  }
}

void Guidance::start(const ArmState& arm) {
  commanded_tip_ = arm.base_T_flange * flange_T_tip_;
  phase_ = GuidancePhase::Approach;
  depth_ = -options_.standoff_mm;
  settled_ = 0;
  linear_speed_ = 0;
  angular_speed_ = 0;
}

void Guidance::retract() {
  if (phase_ == GuidancePhase::Advance) phase_ = GuidancePhase::Retract;
}

Eigen::Isometry3d Guidance::tipPoseOnAxis(const AxisInBase& axis, double depth) const {
  // Tool z along the axis; the roll about it is free, so keep the commanded roll (smallest rotation).
  const Eigen::Vector3d z = commanded_tip_.linear().col(2);
  const Eigen::Quaterniond q_min = Eigen::Quaterniond::FromTwoVectors(z, axis.direction);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q_min.toRotationMatrix() * commanded_tip_.linear();
  T.translation() = axis.entry + depth * axis.direction;
  return T;
}

GuidanceCommand Guidance::update(const ArmState& arm, const AxisInBase& axis, double dt_s, const Twist& hand) {
  GuidanceCommand c;
  c.phase = phase_;
  if (phase_ == GuidancePhase::Idle || phase_ == GuidancePhase::Done || !(dt_s > 0) || !axis.entry.allFinite() ||
      !axis.direction.allFinite()) {
    return c;
  }
  const double full_depth = options_.depth_mm > 0 ? options_.depth_mm : axis.length_mm;
  if (phase_ == GuidancePhase::Approach) {
    // Move the commanded pose toward the stand-off pose on trapezoidal profiles (bounded speed and
    // acceleration, braking to arrive at rest): a step in the commanded speed would make the servo lag and
    // then overshoot the speed limit catching up.
    const Eigen::Isometry3d goal = tipPoseOnAxis(axis, -options_.standoff_mm);
    const Eigen::Vector3d dp = goal.translation() - commanded_tip_.translation();
    const double dist = dp.norm();
    linear_speed_ = std::min({linear_speed_ + options_.approach_acceleration_mm_s2 * dt_s, options_.approach_speed_mm_s,
                              std::sqrt(2.0 * options_.approach_acceleration_mm_s2 * dist)});
    const double step = linear_speed_ * dt_s;
    commanded_tip_.translation() += dist > step ? (step / dist) * dp : dp;
    const Eigen::Vector3d phi = so3Log(commanded_tip_.linear().transpose() * goal.linear());
    const double angle = phi.norm();
    angular_speed_ = std::min({angular_speed_ + options_.approach_angular_acceleration_rad_s2 * dt_s,
                               options_.approach_rotation_speed_rad_s,
                               std::sqrt(2.0 * options_.approach_angular_acceleration_rad_s2 * angle)});
    const double rstep = angular_speed_ * dt_s;
    commanded_tip_.linear() = commanded_tip_.linear() * so3Exp(angle > rstep ? (rstep / angle) * phi : phi);
    const Eigen::Isometry3d actual_tip = arm.base_T_flange * flange_T_tip_;
    const bool within = (actual_tip.translation() - goal.translation()).norm() < options_.align_tolerance_mm &&
                        rotationAngleBetween(actual_tip.linear(), goal.linear()) < options_.align_tolerance_rad;
    settled_ = within ? settled_ + 1 : 0;
    depth_ = -options_.standoff_mm;
    if (settled_ >= options_.align_settle_cycles) {
      phase_ = GuidancePhase::Advance;
      c.aligned = true;
    }
  } else if (phase_ == GuidancePhase::Advance) {
    double v = options_.advance_speed_mm_s;
    if (options_.mode == AdvanceMode::HandGuided) {
      v = std::clamp(constrainToAxis(hand, axis.direction).head<3>().dot(axis.direction), -options_.max_hand_speed_mm_s,
                     options_.max_hand_speed_mm_s);
    }
    depth_ = std::clamp(depth_ + v * dt_s, -options_.standoff_mm, full_depth);
    commanded_tip_ = tipPoseOnAxis(axis, depth_);
    if (options_.mode == AdvanceMode::RobotDriven && depth_ >= full_depth) phase_ = GuidancePhase::Retract;
  } else if (phase_ == GuidancePhase::Retract) {
    depth_ = std::max(depth_ - options_.retract_speed_mm_s * dt_s, -options_.standoff_mm);
    commanded_tip_ = tipPoseOnAxis(axis, depth_);
    if (depth_ <= -options_.standoff_mm) {
      phase_ = GuidancePhase::Done;
      c.done = true;
    }
  }
  c.depth_mm = depth_;
  const auto q = kinematics_.inverseNearest(commanded_tip_ * flange_T_tip_.inverse(), arm.q, &options_.limits);
  if (!q) {
    c.ik_failed = true;
    return c;
  }
  c.has_target = true;
  c.q = *q;
  c.phase = phase_;
  return c;
}

}  // namespace mrsns::robot
