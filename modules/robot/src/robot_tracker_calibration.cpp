#include "mrsns/robot/robot_tracker_calibration.h"

#include <cmath>
#include <random>
#include <string>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"

namespace mrsns::robot {

RobotTrackerCalibrationResult calibrateRobotTracker(const std::vector<Eigen::Isometry3d>& base_T_flange,
                                                    const std::vector<Eigen::Isometry3d>& tracker_T_marker,
                                                    const RobotTrackerCalibrationOptions& options) {
  if (base_T_flange.size() != tracker_T_marker.size()) {
    throw InvalidArgumentError("calibrateRobotTracker: " + std::to_string(base_T_flange.size()) + " robot poses but " +
                               std::to_string(tracker_T_marker.size()) +
                               " marker poses; record one marker pose per robot station");
  }
  if (base_T_flange.size() < options.min_poses) {
    throw InvalidArgumentError("calibrateRobotTracker: " + std::to_string(base_T_flange.size()) +
                               " stations, need at least " + std::to_string(options.min_poses) +
                               "; record more stations rotating about different axes");
  }
  for (std::size_t i = 0; i < base_T_flange.size(); ++i) {
    if (!base_T_flange[i].matrix().allFinite() || !tracker_T_marker[i].matrix().allFinite()) {
      throw InvalidArgumentError("calibrateRobotTracker: station " + std::to_string(i) +
                                 " has a non-finite pose; drop it or record it again");
    }
  }
  RobotWorldHandEyeResult he;
  try {
    he = calibrateRobotWorldHandEye(base_T_flange, tracker_T_marker, options.hand_eye);
  } catch (const InvalidArgumentError& e) {
    throw InvalidArgumentError(std::string("calibrateRobotTracker: degenerate station set (") + e.what() +
                               "); move the flange so its rotations span at least two axes, e.g. with "
                               "generateCalibrationPoses");
  }
  RobotTrackerCalibrationResult r;
  r.flange_T_marker = he.hand_T_eye;
  r.base_T_tracker = he.base_T_world;
  r.axis_spread_rad = he.axis_spread_rad;
  r.poses = static_cast<int>(base_T_flange.size());
  double st = 0, sr = 0;
  for (std::size_t i = 0; i < base_T_flange.size(); ++i) {
    const Eigen::Isometry3d a = base_T_flange[i] * r.flange_T_marker;
    const Eigen::Isometry3d b = r.base_T_tracker * tracker_T_marker[i];
    const double dt = (a.translation() - b.translation()).norm();
    const double dr = rotationAngleBetween(a.linear(), b.linear());
    r.translation_residual_mm.push_back(dt);
    r.rotation_residual_rad.push_back(dr);
    st += dt * dt;
    sr += dr * dr;
  }
  r.translation_rms_mm = std::sqrt(st / static_cast<double>(r.poses));
  r.rotation_rms_rad = std::sqrt(sr / static_cast<double>(r.poses));
  return r;
}

CalibrationPoses generateCalibrationPoses(const Ur5Kinematics& kinematics, const Joints& q_center,
                                          const CalibrationPoseOptions& options) {
  if (options.count < 3 || !(options.tilt_rad > 0) || !(options.position_spread_mm >= 0)) {
    throw InvalidArgumentError(
        "generateCalibrationPoses: count must be >= 3, tilt_rad > 0 and position_spread_mm >= 0");
  }
  const Eigen::Isometry3d center = kinematics.forward(q_center);
  std::mt19937_64 rng(options.seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  CalibrationPoses out;
  const Eigen::Vector3d axes[3] = {Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ()};
  int attempts = 0;
  Joints q_prev = q_center;
  while (static_cast<int>(out.q.size()) < options.count && attempts < 50 * options.count) {
    const int k = static_cast<int>(out.q.size());
    ++attempts;
    // Cycle the tilt axis through the flange's x, y, z so the relative motions' axes span 3D, with a
    // random component so no two stations repeat.
    Eigen::Vector3d axis = axes[k % 3] + 0.3 * Eigen::Vector3d(u(rng), u(rng), u(rng));
    axis.normalize();
    const double angle = ((k / 3) % 2 == 0 ? 1.0 : -1.0) * options.tilt_rad * (0.7 + 0.3 * std::abs(u(rng)));
    Eigen::Isometry3d T = center;
    T.linear() = center.linear() * Eigen::AngleAxisd(angle, axis).toRotationMatrix();
    T.translation() += options.position_spread_mm * Eigen::Vector3d(u(rng), u(rng), u(rng));
    const auto q = kinematics.inverseNearest(T, q_prev, &options.limits);
    if (!q || kinematics.singularity(*q, options.singularity).any()) continue;
    // Stay on the centre's branch: a branch flip would swing the arm through the workspace.
    if ((*q - q_center).cwiseAbs().maxCoeff() > 1.5) continue;
    out.q.push_back(*q);
    out.base_T_flange.push_back(kinematics.forward(*q));
    q_prev = *q;
  }
  if (static_cast<int>(out.q.size()) < options.count) {
    throw ComputationError("generateCalibrationPoses: only " + std::to_string(out.q.size()) + " of " +
                           std::to_string(options.count) +
                           " stations are reachable around this pose; start from a pose farther from the "
                           "workspace boundary and singularities, or lower tilt_rad/position_spread_mm");
  }
  return out;
}

}  // namespace mrsns::robot
