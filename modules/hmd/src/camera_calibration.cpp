// OpenCV behind camera_calibration.h (the only OpenCV calib3d/imgcodecs user of the module,
// with board_renderer.cpp).
#include "mrsns/hmd/camera_calibration.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "mrsns/core/error.h"
#include "mrsns/core/format.h"

namespace mrsns::hmd {
namespace {

cv::Mat wrap(const GrayImage& image) {
  if (image.width <= 0 || image.height <= 0 ||
      image.pixels.size() != static_cast<size_t>(image.width) * static_cast<size_t>(image.height)) {
    throw InvalidArgumentError("grey image of " + std::to_string(image.width) + " x " + std::to_string(image.height) +
                               " with " + std::to_string(image.pixels.size()) + " pixels: sizes do not match");
  }
  return cv::Mat(image.height, image.width, CV_8UC1, const_cast<std::uint8_t*>(image.pixels.data()));
}

cv::Mat cameraMatrix(const CameraIntrinsics& k) {
  return (cv::Mat_<double>(3, 3) << k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
}

cv::Mat distortion(const CameraIntrinsics& k) {
  return (cv::Mat_<double>(1, 5) << k.distortion[0], k.distortion[1], k.distortion[2], k.distortion[3],
          k.distortion[4]);
}

std::vector<cv::Point3f> objectPoints(const CheckerboardSpec& spec) {
  std::vector<cv::Point3f> out;
  for (const auto& p : idealGridCorners(spec)) out.emplace_back(float(p.x()), float(p.y()), float(p.z()));
  return out;
}

void checkCount(size_t count, const CheckerboardSpec& spec, const std::string& what) {
  if (count != static_cast<size_t>(spec.rows * spec.cols)) {
    throw InvalidArgumentError(what + ": " + std::to_string(count) + " corners for a " + std::to_string(spec.rows) +
                               " x " + std::to_string(spec.cols) + " checkerboard");
  }
}

}  // namespace

GrayImage readGrayImage(const std::filesystem::path& path) {
  const cv::Mat m = cv::imread(path.string(), cv::IMREAD_GRAYSCALE);
  if (m.empty()) {
    throw FileError("cannot read image '" + path.string() + "': missing, unreadable or not an image (PNG/JPEG/BMP)");
  }
  GrayImage out;
  out.width = m.cols;
  out.height = m.rows;
  out.pixels.resize(static_cast<size_t>(m.cols) * static_cast<size_t>(m.rows));
  for (int r = 0; r < m.rows; ++r) {
    std::copy(m.ptr<std::uint8_t>(r), m.ptr<std::uint8_t>(r) + m.cols, out.pixels.begin() + std::ptrdiff_t(r) * m.cols);
  }
  return out;
}

void writeGrayImage(const std::filesystem::path& path, const GrayImage& image) {
  bool ok = false;
  try {
    ok = cv::imwrite(path.string(), wrap(image));
  } catch (const cv::Exception&) {
    ok = false;
  }
  if (!ok) throw FileError("cannot write image '" + path.string() + "': check the folder and the extension (.png)");
}

std::optional<std::vector<Eigen::Vector2d>> detectCheckerboard(const GrayImage& image, const CheckerboardSpec& spec) {
  const cv::Mat m = wrap(image);
  std::vector<cv::Point2f> corners;
  const cv::Size pattern(spec.cols, spec.rows);
  if (!cv::findChessboardCorners(
          m, pattern, corners, cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_FAST_CHECK)) {
    return std::nullopt;
  }
  cv::cornerSubPix(m, corners, cv::Size(5, 5), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-3));
  std::vector<Eigen::Vector2d> out;
  for (const auto& c : corners) out.emplace_back(c.x, c.y);
  return out;
}

std::vector<Eigen::Vector2d> detectCheckerboardOrThrow(const GrayImage& image, const CheckerboardSpec& spec,
                                                       const std::string& image_name) {
  auto corners = detectCheckerboard(image, spec);
  if (!corners) {
    throw ComputationError("checkerboard of " + std::to_string(spec.rows) + " x " + std::to_string(spec.cols) +
                           " inner corners not found in image '" + image_name +
                           "': check that the whole board with its white border is in view, in focus, and that "
                           "--rows/--cols count inner corners; remove the image otherwise");
  }
  return *corners;
}

CameraCalibrationResult calibrateCamera(const std::vector<std::vector<Eigen::Vector2d>>& corners_per_image,
                                        const CheckerboardSpec& spec, int width, int height,
                                        const CameraCalibrationOptions& options) {
  if (static_cast<int>(corners_per_image.size()) < options.min_images) {
    throw InvalidArgumentError("camera calibration needs at least " + std::to_string(options.min_images) +
                               " images of the checkerboard, got " + std::to_string(corners_per_image.size()) +
                               ": add views with the board tilted in different directions");
  }
  std::vector<std::vector<cv::Point3f>> object;
  std::vector<std::vector<cv::Point2f>> image;
  for (size_t i = 0; i < corners_per_image.size(); ++i) {
    checkCount(corners_per_image[i].size(), spec, "camera calibration image " + std::to_string(i));
    object.push_back(objectPoints(spec));
    std::vector<cv::Point2f> pts;
    for (const auto& c : corners_per_image[i]) pts.emplace_back(float(c.x()), float(c.y()));
    image.push_back(pts);
  }
  cv::Mat K, D;
  std::vector<cv::Mat> rvecs, tvecs;
  cv::Mat std_intrinsics, std_extrinsics, per_view;
  int flags = options.estimate_k3 ? 0 : cv::CALIB_FIX_K3;
  const double rms = cv::calibrateCamera(object, image, cv::Size(width, height), K, D, rvecs, tvecs, std_intrinsics,
                                         std_extrinsics, per_view, flags);
  CameraCalibrationResult result;
  result.rms_reprojection_px = rms;
  result.images_used = static_cast<int>(image.size());
  auto& k = result.intrinsics;
  k.fx = K.at<double>(0, 0);
  k.fy = K.at<double>(1, 1);
  k.cx = K.at<double>(0, 2);
  k.cy = K.at<double>(1, 2);
  for (int i = 0; i < 5 && i < static_cast<int>(D.total()); ++i) k.distortion[static_cast<size_t>(i)] = D.at<double>(i);
  k.width = width;
  k.height = height;
  for (int i = 0; i < per_view.rows; ++i) result.per_image_rms_px.push_back(per_view.at<double>(i));
  return result;
}

BoardPose estimateBoardPose(const std::vector<Eigen::Vector2d>& corners, const CheckerboardSpec& spec,
                            const CameraIntrinsics& intrinsics) {
  checkCount(corners.size(), spec, "board pose");
  std::vector<cv::Point2f> pts;
  for (const auto& c : corners) pts.emplace_back(float(c.x()), float(c.y()));
  const auto object = objectPoints(spec);
  cv::Mat rvec, tvec;
  cv::solvePnP(object, pts, cameraMatrix(intrinsics), distortion(intrinsics), rvec, tvec, false,
               cv::SOLVEPNP_ITERATIVE);
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  BoardPose pose;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) pose.camera_T_grid.linear()(r, c) = R.at<double>(r, c);
    pose.camera_T_grid.translation()(r) = tvec.at<double>(r);
  }
  std::vector<cv::Point2f> projected;
  cv::projectPoints(object, rvec, tvec, cameraMatrix(intrinsics), distortion(intrinsics), projected);
  double sum = 0.0;
  for (size_t i = 0; i < pts.size(); ++i) {
    const double dx = projected[i].x - pts[i].x, dy = projected[i].y - pts[i].y;
    sum += dx * dx + dy * dy;
  }
  pose.rms_reprojection_px = std::sqrt(sum / static_cast<double>(pts.size()));
  return pose;
}

std::vector<Eigen::Vector2d> projectPoints(const std::vector<Eigen::Vector3d>& camera_points,
                                           const CameraIntrinsics& intrinsics) {
  if (camera_points.empty()) return {};
  std::vector<cv::Point3d> pts;
  for (const auto& p : camera_points) pts.emplace_back(p.x(), p.y(), p.z());
  std::vector<cv::Point2d> projected;
  cv::projectPoints(pts, cv::Mat::zeros(3, 1, CV_64F), cv::Mat::zeros(3, 1, CV_64F), cameraMatrix(intrinsics),
                    distortion(intrinsics), projected);
  std::vector<Eigen::Vector2d> out;
  for (const auto& p : projected) out.emplace_back(p.x, p.y);
  return out;
}

std::vector<Eigen::Vector3d> pixelRays(const std::vector<Eigen::Vector2d>& pixels, const CameraIntrinsics& intrinsics) {
  if (pixels.empty()) return {};
  std::vector<cv::Point2d> in, out;
  for (const auto& p : pixels) in.emplace_back(p.x(), p.y());
  cv::undistortPoints(in, out, cameraMatrix(intrinsics), distortion(intrinsics), cv::noArray(), cv::noArray(),
                      cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 30, 1e-10));
  std::vector<Eigen::Vector3d> rays;
  for (const auto& p : out) rays.push_back(Eigen::Vector3d(p.x, p.y, 1.0).normalized());
  return rays;
}

}  // namespace mrsns::hmd
