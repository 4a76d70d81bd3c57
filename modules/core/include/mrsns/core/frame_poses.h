#pragma once
// Any transform of a recorded sequence, frame by frame: each frame's
// transforms are loaded into a transform repository and the requested one
// (e.g. "StylusToReference" from StylusToTracker and ReferenceToTracker) is
// read by path search, with the worst status along the path.
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "mrsns/core/tracked_frame.h"

namespace mrsns {

struct FramePose {
  std::size_t frame_index = 0;
  double timestamp = 0.0;
  Eigen::Isometry3d to_T_from = Eigen::Isometry3d::Identity();
  TransformStatus status = TransformStatus::Missing;
};

struct FramePoseExtraction {
  /// Poses of the frames where the transform could be computed (status Ok
  /// only, unless include_invalid was set).
  std::vector<FramePose> poses;
  /// Frames left out because a transform on the path was invalid or missing.
  std::size_t invalid_frames = 0;
  std::size_t missing_frames = 0;
  /// Frames whose matrices were not quite orthonormal (rounded in the file)
  /// and were projected onto the nearest rotation.
  std::size_t orthonormalized_frames = 0;
};

/// Extracts `transform_name` (PLUS style, "FromToTo") from every frame.
/// Throws FrameError when no frame can produce it at all (the message lists
/// the transform names the sequence has).
FramePoseExtraction extractFramePoses(const std::vector<TrackedFrame>& frames, const std::string& transform_name,
                                      bool include_invalid = false);

}  // namespace mrsns
