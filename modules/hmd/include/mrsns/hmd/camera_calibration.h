#pragma once
// The HMD's camera (paper 000 §2.4): checkerboard corners found in its
// images (cv::findChessboardCorners + cornerSubPix), intrinsics and lens
// distortion (cv::calibrateCamera), the board pose in each image
// (cv::solvePnP), and projection/back-projection with the same model.
// OpenCV stays in src/: images cross this boundary as GrayImage.
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "mrsns/hmd/checkerboard_grid.h"

namespace mrsns::hmd {

/// 8-bit grey image, row-major, width * height pixels.
struct GrayImage {
  int width = 0, height = 0;
  std::vector<std::uint8_t> pixels;
};

/// Reads PNG/JPEG/BMP as grey. Throws FileError naming the file when missing or not an image.
GrayImage readGrayImage(const std::filesystem::path& path);
/// Writes a PNG (or any extension OpenCV knows). Throws FileError.
void writeGrayImage(const std::filesystem::path& path, const GrayImage& image);

/// Pinhole camera with OpenCV's distortion model (k1, k2, p1, p2, k3), pixels.
struct CameraIntrinsics {
  double fx = 1000, fy = 1000, cx = 640, cy = 360;
  std::array<double, 5> distortion{0, 0, 0, 0, 0};
  int width = 1280, height = 720;
};

/// Inner corners of the checkerboard in the image, row-major (see checkerboard_grid.h), or
/// nullopt when the board is not found. Sub-pixel refined.
std::optional<std::vector<Eigen::Vector2d>> detectCheckerboard(const GrayImage& image, const CheckerboardSpec& spec);

/// As detectCheckerboard; throws ComputationError naming `image_name` when not found.
std::vector<Eigen::Vector2d> detectCheckerboardOrThrow(const GrayImage& image, const CheckerboardSpec& spec,
                                                       const std::string& image_name);

struct CameraCalibrationOptions {
  /// Estimate k3 (wide-angle lenses); otherwise k1, k2, p1, p2 only.
  bool estimate_k3 = false;
  int min_images = 4;
};

struct CameraCalibrationResult {
  CameraIntrinsics intrinsics;
  double rms_reprojection_px = 0;
  std::vector<double> per_image_rms_px;
  int images_used = 0;
};

/// Intrinsics from the corners of several views of one board (cv::calibrateCamera). Throws
/// InvalidArgumentError for fewer than min_images views or corner counts that do not match the
/// spec.
CameraCalibrationResult calibrateCamera(const std::vector<std::vector<Eigen::Vector2d>>& corners_per_image,
                                        const CheckerboardSpec& spec, int width, int height,
                                        const CameraCalibrationOptions& options = {});

struct BoardPose {
  Eigen::Isometry3d camera_T_grid = Eigen::Isometry3d::Identity();  // (T_c^p)^-1: grid -> camera
  double rms_reprojection_px = 0;
};

/// Board pose from its corners (cv::solvePnP, iterative). Throws InvalidArgumentError when the
/// corner count does not match the spec.
BoardPose estimateBoardPose(const std::vector<Eigen::Vector2d>& corners, const CheckerboardSpec& spec,
                            const CameraIntrinsics& intrinsics);

/// Pixels of camera-frame points (mm) through the distortion model.
std::vector<Eigen::Vector2d> projectPoints(const std::vector<Eigen::Vector3d>& camera_points,
                                           const CameraIntrinsics& intrinsics);

/// Undistorted viewing rays (unit vectors, camera frame) of pixels.
std::vector<Eigen::Vector3d> pixelRays(const std::vector<Eigen::Vector2d>& pixels, const CameraIntrinsics& intrinsics);

}  // namespace mrsns::hmd
