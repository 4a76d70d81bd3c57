#pragma once
// Robot-tracker calibration: a tracked marker on the flange, seen by the tracker while the robot visits
// a set of poses, gives both the marker's mounting (flange_T_marker) and where the tracker stands in the
// robot base (base_T_tracker) from base_T_flange_i * flange_T_marker = base_T_tracker * tracker_T_marker_i
// (the AX = YB problem, solved by registration/hand_eye.h). Also a generator of joint configurations
// whose rotations span three axes, so the problem is well conditioned.
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "mrsns/registration/hand_eye.h"
#include "mrsns/robot/ur5_kinematics.h"

namespace mrsns::robot {

struct RobotTrackerCalibrationOptions {
  HandEyeOptions hand_eye;
  /// Fewer stations cannot separate noise from the 12 unknowns reliably.
  std::size_t min_poses = 6;
};

struct RobotTrackerCalibrationResult {
  Eigen::Isometry3d flange_T_marker = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d base_T_tracker = Eigen::Isometry3d::Identity();
  /// Per station: |base_T_flange * flange_T_marker - base_T_tracker * tracker_T_marker| (translation, mm;
  /// rotation, rad).
  std::vector<double> translation_residual_mm;
  std::vector<double> rotation_residual_rad;
  double translation_rms_mm = 0;
  double rotation_rms_rad = 0;
  /// Spread of the flange rotation axes (registration/hand_eye.h): small means poorly conditioned.
  double axis_spread_rad = 0;
  int poses = 0;
};

/// Throws InvalidArgumentError for mismatched or too few poses, non-finite poses, or a degenerate pose set
/// (rotations about one axis only, too little rotation): the message says to add stations rotating about
/// other axes (see generateCalibrationPoses).
RobotTrackerCalibrationResult calibrateRobotTracker(const std::vector<Eigen::Isometry3d>& base_T_flange,
                                                    const std::vector<Eigen::Isometry3d>& tracker_T_marker,
                                                    const RobotTrackerCalibrationOptions& options = {});

struct CalibrationPoseOptions {
  int count = 12;
  /// Tilt of each station's flange from the centre pose (rad): ~25 deg keeps a marker in the tracker's view.
  double tilt_rad = 0.45;
  /// Position offsets of the stations around the centre (mm, uniform in a cube of this half-size).
  double position_spread_mm = 60.0;
  std::uint64_t seed = 1;
  JointLimits limits = ur5JointLimits();
  SingularityThresholds singularity;
};

struct CalibrationPoses {
  std::vector<Joints> q;
  std::vector<Eigen::Isometry3d> base_T_flange;
};

/// Stations around `q_center`'s flange pose whose tilt axes cycle through three orthogonal directions
/// (x, y, z of the flange, with alternating signs), each reached by the IK solution nearest q_center,
/// within the limits and away from singularities. Throws InvalidArgumentError when count < 3, and
/// ComputationError when fewer than `count` reachable stations are found.
CalibrationPoses generateCalibrationPoses(const Ur5Kinematics& kinematics, const Joints& q_center,
                                          const CalibrationPoseOptions& options = {});

}  // namespace mrsns::robot
