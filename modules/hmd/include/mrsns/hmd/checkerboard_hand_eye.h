#pragma once
// The checkerboard hand-eye calibration of paper 000 (§2.4): for every image,
//
//   T_c^h = T_w^h  T_b^w  T_p^b  T_c^p                         (paper)
//   hmd_T_camera = inverse(tracker_T_hmd) * tracker_T_board * board_T_grid * grid_T_camera
//
// Frame names, paper -> MR-SNS: w (optical tracker, physical space) = tracker;
// h (marker body on the headset) = hmd; b (marker body on the calibration
// board) = board; p (checkerboard pattern, from the digitised corners) = grid;
// c (HMD RGB camera, the virtual camera) = camera. T_a^b of the paper maps a
// to b, i.e. b_T_a here.
//
// Each image gives one estimate; the estimates are averaged (Karcher mean of
// the rotations, mean translation) and their spread summarised with the
// directional statistics of Tables 1-2 (core/directional_stats.h).
//
// A checkerboard with an even number of squares along both sides (3 x 5 inner
// corners, as in the paper) looks the same turned by 180 deg, so OpenCV may
// number its corners from either end. The order that makes the per-image
// estimates agree is chosen (the wrong one scatters them by the board size).
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "mrsns/core/directional_stats.h"
#include "mrsns/hmd/camera_calibration.h"
#include "mrsns/hmd/checkerboard_grid.h"

namespace mrsns::hmd {

/// One camera image with the tracker poses recorded when it was taken.
struct CheckerboardView {
  std::string name;                                                   // for messages
  Eigen::Isometry3d tracker_T_hmd = Eigen::Isometry3d::Identity();    // T_h^w (HmdToTracker)
  Eigen::Isometry3d tracker_T_board = Eigen::Isometry3d::Identity();  // T_b^w (BoardToTracker)
  std::vector<Eigen::Vector2d> corners_px;                            // detected, row-major
};

struct CheckerboardHandEyeOptions {
  int min_views = 3;
  /// Try both corner orders of 180-deg symmetric boards (see the header comment).
  bool resolve_symmetric_order = true;
};

struct CheckerboardHandEyeResult {
  Eigen::Isometry3d hmd_T_camera = Eigen::Isometry3d::Identity();  // T_c^h, mean over views
  std::vector<Eigen::Isometry3d> per_view_hmd_T_camera;
  std::vector<double> per_view_pnp_rms_px;
  /// Per view: true when the detected corners were used in reverse order.
  std::vector<bool> corners_reversed;
  /// Tables 1-2 of paper 000 over the per-view estimates.
  TransformDispersion dispersion;
  /// Spread of the per-view estimates about the mean: RMS angle (rad) and distance (mm).
  double rotation_rms_rad = 0, translation_rms_mm = 0;
};

/// Throws InvalidArgumentError for fewer than min_views views or a view whose corner count does
/// not match the spec (naming it).
CheckerboardHandEyeResult calibrateCheckerboardHandEye(const std::vector<CheckerboardView>& views,
                                                       const Eigen::Isometry3d& board_T_grid,
                                                       const CheckerboardSpec& spec, const CameraIntrinsics& intrinsics,
                                                       const CheckerboardHandEyeOptions& options = {});

}  // namespace mrsns::hmd
