#pragma once
// Simulated protocol of paper 000 (§2.4, §2.7, §3.3): a tracked HMD camera
// photographs a tracked, digitised checkerboard from `poses` random poses at
// 0.5-1.5 m; the camera images are rendered (board_renderer.h) and go through
// the real pipeline: pointer pivot calibration, digitisation, RANSAC grid fit,
// camera calibration from a separate set of close views of a larger board,
// corner detection, solvePnP, the chain T_c^h, averaging, Tables 1-2 and the
// retro-projection error.
//
// Noise model (defaults; every figure is written into the result):
// - optical tracker, every rigid body (HMD, board, pointer): per sample
//   0.35 mm 3D RMS position and 0.2 deg 3D RMS orientation, white; the HMD and
//   board poses of an image are the mean of `tracker_samples_per_image`
//   samples taken while the headset is held still (0.5 s at 60 Hz = 30);
// - digitisation: the pointer tip placed within 0.25 mm 3D RMS of the corner;
//   the tip rests still on each corner (paper 000 §2.3), so the pointer and
//   board poses are averaged over the same number of samples;
// - pointer pivot: 60 poses over +-25 deg;
// - camera image: 0.7 px Gaussian blur, 2 grey levels noise (of 200
//   contrast), 2x2 supersampled edges; HoloLens-like camera 1280x720,
//   f = 1000 px, k1 = -0.05, k2 = 0.02.
#include <Eigen/Geometry>
#include <vector>

#include "mrsns/hmd/board_renderer.h"
#include "mrsns/hmd/camera_calibration.h"
#include "mrsns/hmd/checkerboard_grid.h"
#include "mrsns/hmd/checkerboard_hand_eye.h"
#include "mrsns/hmd/retro_projection.h"

namespace mrsns::hmd {

struct CheckerboardTrialOptions {
  int poses = 10;
  unsigned seed = 1;
  double min_distance_mm = 500, max_distance_mm = 1500;
  CheckerboardSpec board{3, 5, 40.0};             // tracked, digitised board (paper: 3 x 5)
  CheckerboardSpec intrinsics_board{6, 9, 25.0};  // printed board for the camera intrinsics
  int intrinsics_images = 10;
  CameraIntrinsics camera{1000.0, 1000.0, 640.0, 360.0, {-0.05, 0.02, 0.0, 0.0, 0.0}, 1280, 720};
  double tracker_position_rms_mm = 0.35;  // 3D RMS per sample
  double tracker_rotation_rms_deg = 0.2;  // 3D RMS per sample
  int tracker_samples_per_image = 30;
  double digitisation_rms_mm = 0.25;  // 3D RMS of tip placement on a corner
  BoardRenderOptions render;
  /// Keep the rendered images and inputs in the result (to write them as a data set).
  bool keep_inputs = false;
};

struct CheckerboardTrialResult {
  CheckerboardTrialOptions options;
  CameraCalibrationResult camera;
  double pointer_pivot_rms_mm = 0, pointer_tip_error_mm = 0;
  GridFitResult grid;
  double grid_error_mm = 0;  // max |board_T_grid * corner - truth| over the corners
  CheckerboardHandEyeResult hand_eye;
  RetroProjectionResult rpee;
  Eigen::Isometry3d true_hmd_T_camera = Eigen::Isometry3d::Identity();
  double rotation_error_deg = 0, translation_error_mm = 0;  // estimate vs truth
  std::vector<double> distances_mm;                         // camera-board distance per pose
  /// With keep_inputs: the protocol images (one per view), the intrinsics images, the views
  /// (tracked poses, detected corners) and the digitised corners in the board frame.
  std::vector<GrayImage> images, intrinsics_images;
  std::vector<CheckerboardView> views;
  std::vector<Eigen::Vector3d> digitised_corners;
};

/// Runs the protocol. Throws like the pipeline steps (e.g. ComputationError when a rendered
/// board is not found, which the pose generator avoids).
CheckerboardTrialResult runCheckerboardTrial(const CheckerboardTrialOptions& options = {});

}  // namespace mrsns::hmd
