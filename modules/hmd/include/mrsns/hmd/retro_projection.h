#pragma once
// Retro-projection error estimation (RPEE) of paper 000 §2.7: the digitised
// corners are carried through the estimated calibration into each camera
// image,
//   camera_T_grid_i = inverse(hmd_T_camera) * inverse(tracker_T_hmd_i) * tracker_T_board_i * board_T_grid,
// projected with the camera model and compared with the corners detected in
// that image: in pixels, and in mm at the board (the detected corner's
// viewing ray intersected with the board plane, against the projected corner
// in 3D), the unit of the paper's 3.2 +- 1.6 mm.
#include <Eigen/Geometry>
#include <vector>

#include "mrsns/hmd/camera_calibration.h"
#include "mrsns/hmd/checkerboard_grid.h"
#include "mrsns/hmd/checkerboard_hand_eye.h"

namespace mrsns::hmd {

struct RetroProjectionResult {
  /// Every corner of every view (view-major), pixels and mm.
  std::vector<double> corner_error_px, corner_error_mm;
  std::vector<double> per_view_rms_px, per_view_rms_mm;
  /// Mean and sample std over all corners (the paper's "3.2 +- 1.6 mm over 150 patterns").
  double mean_px = 0, std_px = 0, mean_mm = 0, std_mm = 0;
  double rms_px = 0, rms_mm = 0;
};

/// `reversed` (optional, per view) says to read a view's detected corners in reverse order
/// (CheckerboardHandEyeResult::corners_reversed). Throws InvalidArgumentError on empty views or
/// corner counts that do not match the spec.
RetroProjectionResult retroProjectionError(const std::vector<CheckerboardView>& views,
                                           const Eigen::Isometry3d& hmd_T_camera, const Eigen::Isometry3d& board_T_grid,
                                           const CheckerboardSpec& spec, const CameraIntrinsics& intrinsics,
                                           const std::vector<bool>& reversed = {});

}  // namespace mrsns::hmd
