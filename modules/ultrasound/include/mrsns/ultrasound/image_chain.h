#pragma once
// Placing an ultrasound frame in 3D: ImageToReference (or ImageToCT, or any
// frame the repository reaches) at the frame's time, the probe pose taken
// from the tracker stream with the temporal calibration applied, and the
// frame's corner points in that space.
#include <Eigen/Geometry>
#include <array>
#include <string_view>
#include <vector>

#include "mrsns/core/frame_poses.h"
#include "mrsns/core/transform_repository.h"

namespace mrsns::ultrasound {

/// The probe pose (ProbeToReference) the tracker reported for the instant
/// the video frame at `frame_time_s` shows: with PLUS's TrackerLagSec the
/// tracker stamps that instant at frame_time + lag. Interpolated between the
/// two nearest samples (slerp); throws InvalidArgumentError when the time
/// is outside the tracker stream or the poses are not in time order.
Eigen::Isometry3d probePoseAtVideoTime(const std::vector<FramePose>& reference_T_probe, double frame_time_s,
                                       double tracker_lag_s);

struct ImagePlacement {
  Eigen::Matrix4d target_T_image = Eigen::Matrix4d::Identity();  ///< pixels -> mm in the target frame
  std::array<Eigen::Vector3d, 4> corners_mm{};                   ///< pixel corners (0,0), (w-1,0), (0,h-1), (w-1,h-1)
};

/// `repository` holds the rigid transforms between Reference and the target
/// frame (e.g. ReferenceToCT from a registration); the probe pose is set in
/// it as ProbeToReference, then target_T_image = target_T_probe * ImageToProbe.
ImagePlacement placeImage(TransformRepository& repository, const Eigen::Isometry3d& reference_T_probe,
                          const Eigen::Matrix4d& probe_T_image, int width, int height,
                          std::string_view target_frame = "Reference");

}  // namespace mrsns::ultrasound
