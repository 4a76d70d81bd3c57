#pragma once
// A checkerboard hand-eye data set on disk (paper 000 §2.4) and its solution.
// `mrsns-cli hmd-calibrate-checkerboard` reads it; the workflow's live
// hmd-camera-calibration step writes one while the headset sends its photos
// and solves it with the same function, so the offline verb gives the same
// numbers. Layout (documented in modules/hmd/doc/checkerboard.md):
//   images/*.png       headset camera images, in file-name order
//   hmd_poses.csv      HmdToTracker per image (io/pose_csv.h)
//   board_poses.csv    BoardToTracker per image
//   corners.csv        the board's inner corners in its marker's frame, mm, "x,y,z" per line, row-major
//   intrinsics.json    optional: the camera's intrinsics (mrsns-camera-intrinsics/1)
//   calibration/*.png  optional: images of a printed board, for the intrinsics
#include <filesystem>
#include <string>
#include <vector>

#include "mrsns/hmd/camera_calibration.h"
#include "mrsns/hmd/checkerboard_grid.h"
#include "mrsns/hmd/checkerboard_hand_eye.h"
#include "mrsns/hmd/retro_projection.h"

namespace mrsns::hmd {

struct CheckerboardDatasetFiles {
  std::filesystem::path images, hmd_poses, board_poses, corners;
  std::filesystem::path intrinsics;          ///< empty or missing: not given
  std::filesystem::path calibration_images;  ///< empty or missing: not given
};

/// The standard layout under `dir` (optional files only where they exist).
CheckerboardDatasetFiles checkerboardDatasetIn(const std::filesystem::path& dir);

struct CheckerboardDatasetOptions {
  CheckerboardSpec board{3, 5, 40.0};
  CheckerboardSpec calibration_board{6, 9, 25.0};
};

struct CheckerboardDatasetResult {
  std::vector<std::string> image_names;
  CameraCalibrationResult camera;
  /// "file" (intrinsics.json), "calibration images", or "views" (estimated from the hand-eye images).
  std::string intrinsics_source;
  GridFitResult grid;
  CheckerboardHandEyeResult hand_eye;
  RetroProjectionResult rpee;
};

/// Intrinsics from the file when given, else from the calibration images, else from the views; the corners
/// fitted to the ideal grid; the hand-eye calibration and its RPEE. Throws FileError/FormatError naming the
/// file, InvalidArgumentError for fewer than 3 images or pose counts that do not match, ComputationError
/// naming an image whose board is not found.
CheckerboardDatasetResult calibrateCheckerboardDataset(const CheckerboardDatasetFiles& files,
                                                       const CheckerboardDatasetOptions& options);

/// The images (PNG, JPEG, BMP) in a folder, in file-name order. Throws FileError when it is not a folder.
std::vector<std::filesystem::path> imagesInFolder(const std::filesystem::path& dir);

/// Board-frame points, "x,y,z" per line ('#' comments, an optional header line). Throws FileError, FormatError
/// naming the line.
std::vector<Eigen::Vector3d> readBoardCorners(const std::filesystem::path& path);
void writeBoardCorners(const std::filesystem::path& path, const std::vector<Eigen::Vector3d>& points);

/// {"format": "mrsns-camera-intrinsics/1", "fx", "fy", "cx", "cy", "distortion": [k1, k2, p1, p2, k3], "width",
/// "height"}. Throws FileError, FormatError naming the key (non-positive focal length or size, a principal
/// point outside the image).
CameraIntrinsics readCameraIntrinsics(const std::filesystem::path& path);
void writeCameraIntrinsics(const std::filesystem::path& path, const CameraIntrinsics& intrinsics);

/// The same intrinsics as text for a message's metadata: "fx fy cx cy k1 k2 p1 p2 k3 width height". Parsing
/// throws FormatError for anything else or values a camera cannot have.
std::string intrinsicsText(const CameraIntrinsics& intrinsics);
CameraIntrinsics intrinsicsFromText(const std::string& text);

}  // namespace mrsns::hmd
