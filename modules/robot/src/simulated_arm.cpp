#include "mrsns/robot/simulated_arm.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "mrsns/core/error.h"

namespace mrsns::robot {

const char* toString(Fault fault) {
  switch (fault) {
    case Fault::ProtectiveStop: return "ProtectiveStop";
    case Fault::EmergencyStop: return "EmergencyStop";
    case Fault::JointFault: return "JointFault";
    case Fault::Disconnect: return "Disconnect";
    case Fault::Reconnect: return "Reconnect";
    case Fault::Freeze: return "Freeze";
  }
  return "Unknown";
}

SimulatedArm::SimulatedArm(const SimulatedArmOptions& options) : options_(options), kinematics_(options.dh) {
  if (!(options.control_period_s > 0) || !(options.stop_deceleration_rad_s2 > 0)) {
    throw InvalidArgumentError(
        "SimulatedArm: control_period_s and stop_deceleration_rad_s2 must be positive (e.g. 0.002 and 15)");
  }
  if (!options.q0.allFinite() || !withinLimits(options.q0, options.limits)) {
    throw InvalidArgumentError("SimulatedArm: start joints q0 are not finite or outside the joint limits");
  }
  q_ = options.q0;
  servo_target_ = q_;
  stop_deceleration_ = options.stop_deceleration_rad_s2;
  stops_to_lose_ = std::max(0, options.stops_lost);
}

ArmState SimulatedArm::state() const {
  std::lock_guard lock(mutex_);
  ArmState s;
  s.time_s = time_s_;
  s.cycle = cycle_;
  s.q = q_;
  s.qd = qd_;
  s.base_T_flange = kinematics_.forward(q_);
  s.flange_twist = kinematics_.jacobian(q_) * qd_;
  s.safety = safety_;
  s.connected = connected_;
  if (!connected_) {
    s.mode = RobotMode::Disconnected;
  } else if (!powered_) {
    s.mode = RobotMode::PowerOff;
  } else if (safety_ != SafetyMode::Normal && safety_ != SafetyMode::Reduced) {
    s.mode = RobotMode::Stopped;
  } else {
    s.mode = qd_.cwiseAbs().maxCoeff() > 0 || motion_ == Motion::Servo || motion_ == Motion::Speed ? RobotMode::Running
                                                                                                   : RobotMode::Idle;
  }
  return s;
}

bool SimulatedArm::acceptsMotion() const {
  return connected_ && powered_ && !frozen_ && (safety_ == SafetyMode::Normal || safety_ == SafetyMode::Reduced);
}

bool SimulatedArm::servoJ(const Joints& q_target) {
  std::lock_guard lock(mutex_);
  if (!acceptsMotion() || !q_target.allFinite() || !withinLimits(q_target, options_.limits)) {
    ++refused_;
    return false;
  }
  motion_ = Motion::Servo;
  servo_target_ = q_target;
  return true;
}

bool SimulatedArm::speedL(const Twist& twist, double acceleration_mm_s2) {
  std::lock_guard lock(mutex_);
  if (!acceptsMotion() || !twist.allFinite() || !(acceleration_mm_s2 > 0) ||
      twist.head<3>().norm() > options_.max_tcp_speed_mm_s) {
    ++refused_;
    return false;
  }
  if (motion_ != Motion::Speed) speed_command_ = kinematics_.jacobian(q_) * qd_;
  motion_ = Motion::Speed;
  speed_target_ = twist;
  speed_acceleration_ = acceleration_mm_s2;
  return true;
}

void SimulatedArm::beginStop(double deceleration) {
  motion_ = Motion::Stopping;
  stop_deceleration_ = deceleration;
}

bool SimulatedArm::stopJ(double deceleration_rad_s2) {
  std::lock_guard lock(mutex_);
  if (!connected_ || frozen_ || !(deceleration_rad_s2 > 0) || !std::isfinite(deceleration_rad_s2)) {
    ++refused_;
    return false;
  }
  if (loseStop()) return true;
  // A gentle stopj is honoured, but never slower than the safety system would stop the arm.
  beginStop(std::max(deceleration_rad_s2, options_.stop_deceleration_rad_s2));
  return true;
}

bool SimulatedArm::protectiveStop() {
  std::lock_guard lock(mutex_);
  if (!connected_ || frozen_) {
    ++refused_;
    return false;
  }
  if (loseStop()) return true;
  applyFault(Fault::ProtectiveStop);
  return true;
}

bool SimulatedArm::loseStop() {
  if (stops_to_lose_ <= 0) return false;
  --stops_to_lose_;
  ++stops_lost_;
  return true;
}

bool SimulatedArm::unlockProtectiveStop() {
  std::lock_guard lock(mutex_);
  // UR refuses to unlock while the arm still moves or when the stop is not a protective one.
  if (!connected_ || safety_ != SafetyMode::ProtectiveStop || qd_.cwiseAbs().maxCoeff() > 0) {
    ++refused_;
    return false;
  }
  safety_ = SafetyMode::Normal;
  motion_ = Motion::Hold;
  return true;
}

bool SimulatedArm::resetEmergencyStop() {
  std::lock_guard lock(mutex_);
  if (safety_ != SafetyMode::EmergencyStop && safety_ != SafetyMode::Fault) return false;
  if (qd_.cwiseAbs().maxCoeff() > 0) return false;
  safety_ = SafetyMode::Normal;
  powered_ = true;
  motion_ = Motion::Hold;
  return true;
}

void SimulatedArm::reset(const Joints& q) {
  std::lock_guard lock(mutex_);
  q_ = q;
  qd_.setZero();
  servo_target_ = q;
  speed_command_.setZero();
  speed_target_.setZero();
  motion_ = Motion::Hold;
}

std::uint64_t SimulatedArm::refusedCommands() const {
  std::lock_guard lock(mutex_);
  return refused_;
}

std::uint64_t SimulatedArm::lostStops() const {
  std::lock_guard lock(mutex_);
  return stops_lost_;
}

void SimulatedArm::injectFault(Fault kind, std::uint64_t at_cycle) {
  std::lock_guard lock(mutex_);
  faults_.push_back({kind, at_cycle});
}

void SimulatedArm::applyFault(Fault kind) {
  switch (kind) {
    case Fault::ProtectiveStop:
      if (safety_ == SafetyMode::Normal || safety_ == SafetyMode::Reduced) safety_ = SafetyMode::ProtectiveStop;
      beginStop(options_.stop_deceleration_rad_s2);
      break;
    case Fault::EmergencyStop:
      safety_ = SafetyMode::EmergencyStop;
      beginStop(options_.stop_deceleration_rad_s2);
      break;
    case Fault::JointFault:
      safety_ = SafetyMode::Fault;
      beginStop(options_.stop_deceleration_rad_s2);
      break;
    case Fault::Disconnect:
      connected_ = false;
      // A UR program whose servoj/speedl stream stops runs out and the controller stops the arm itself.
      beginStop(options_.stop_deceleration_rad_s2);
      break;
    case Fault::Reconnect: connected_ = true; break;
    case Fault::Freeze: frozen_ = true; break;
  }
}

Joints SimulatedArm::speedLJointVelocity() const {
  // Damped least squares on the mm-scaled Jacobian: exact away from singularities, bounded near them.
  Eigen::Matrix<double, 6, 6> J = kinematics_.jacobian(q_);
  Twist t = speed_command_;
  J.topRows<3>() *= 1e-3;
  t.head<3>() *= 1e-3;
  const double lambda2 = options_.speedl_damping * options_.speedl_damping;
  const Eigen::Matrix<double, 6, 6> JJt = J * J.transpose() + lambda2 * Eigen::Matrix<double, 6, 6>::Identity();
  return J.transpose() * JJt.ldlt().solve(t);
}

void SimulatedArm::step(double dt_s) {
  std::lock_guard lock(mutex_);
  if (frozen_ || !(dt_s > 0)) return;
  const Joints& vmax = options_.limits.max_qd;
  const Joints& amax = options_.limits.max_qdd;
  Joints qd_next = qd_;
  switch (motion_) {
    case Motion::Hold: {
      for (int i = 0; i < 6; ++i) {
        const double dv = std::clamp(-qd_[i], -amax[i] * dt_s, amax[i] * dt_s);
        qd_next[i] = qd_[i] + dv;
      }
      break;
    }
    case Motion::Servo: {
      // Fastest approach that can still brake to rest on the target (v = sqrt(2 a |e|)), then one scale for
      // all joints on the speed and on the acceleration so the joints stay coordinated (the tool keeps its
      // path instead of the fast wrist running ahead of the slow shoulder).
      Joints v_want;
      for (int i = 0; i < 6; ++i) {
        const double e = servo_target_[i] - q_[i];
        v_want[i] = std::copysign(std::min(std::abs(e) / dt_s, std::sqrt(2.0 * amax[i] * std::abs(e))), e);
      }
      const double over_v = (v_want.cwiseAbs().array() / vmax.array()).maxCoeff();
      if (over_v > 1.0) v_want /= over_v;
      const Joints dv = v_want - qd_;
      const double over_a = (dv.cwiseAbs().array() / (amax.array() * dt_s)).maxCoeff();
      qd_next = qd_ + (over_a > 1.0 ? dv / over_a : dv);
      break;
    }
    case Motion::Speed: {
      const Twist diff = speed_target_ - speed_command_;
      const double lin = diff.head<3>().norm();
      const double max_change = speed_acceleration_ * dt_s;
      // Linear and angular parts ramp together (one scale) so the TCP keeps its direction.
      const double scale = lin > max_change ? max_change / lin : 1.0;
      speed_command_ += scale * diff;
      Joints v = speedLJointVelocity();
      const double over = (v.cwiseAbs().array() / vmax.array()).maxCoeff();
      if (over > 1.0) v /= over;
      for (int i = 0; i < 6; ++i) qd_next[i] = qd_[i] + std::clamp(v[i] - qd_[i], -amax[i] * dt_s, amax[i] * dt_s);
      break;
    }
    case Motion::Stopping: {
      for (int i = 0; i < 6; ++i) {
        const double dv = std::clamp(-qd_[i], -stop_deceleration_ * dt_s, stop_deceleration_ * dt_s);
        qd_next[i] = qd_[i] + dv;
      }
      break;
    }
  }
  for (int i = 0; i < 6; ++i) qd_next[i] = std::clamp(qd_next[i], -vmax[i], vmax[i]);
  // Trapezoidal position update: exact for the constant acceleration within the cycle.
  Joints q_next = q_ + 0.5 * (qd_ + qd_next) * dt_s;
  // The hardware limits are hard stops for the model: a joint that reaches one stops there, and the
  // controller raises a protective stop as the real one does on a joint-limit violation.
  for (int i = 0; i < 6; ++i) {
    if (q_next[i] < options_.limits.min_q[i] || q_next[i] > options_.limits.max_q[i]) {
      q_next[i] = std::clamp(q_next[i], options_.limits.min_q[i], options_.limits.max_q[i]);
      qd_next.setZero();
      if (safety_ == SafetyMode::Normal) safety_ = SafetyMode::ProtectiveStop;
      motion_ = Motion::Stopping;
    }
  }
  q_ = q_next;
  qd_ = qd_next;
  if (motion_ == Motion::Stopping && qd_.isZero(0.0)) {
    if (safety_ == SafetyMode::EmergencyStop) powered_ = false;
  }
  time_s_ += dt_s;
  ++cycle_;
  for (auto it = faults_.begin(); it != faults_.end();) {
    if (it->at_cycle <= cycle_) {
      applyFault(it->kind);
      it = faults_.erase(it);
    } else {
      ++it;
    }
  }
}

}  // namespace mrsns::robot
