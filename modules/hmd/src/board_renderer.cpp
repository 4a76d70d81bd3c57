// Ray casting of the board through the distorted camera (undistortPoints gives every
// sub-pixel sample its ray), then blur and noise with OpenCV.
#include "mrsns/hmd/board_renderer.h"

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "mrsns/core/error.h"

namespace mrsns::hmd {

GrayImage renderCheckerboard(const CheckerboardSpec& spec, const CameraIntrinsics& k,
                             const Eigen::Isometry3d& camera_T_grid, const BoardRenderOptions& options) {
  if (k.width <= 0 || k.height <= 0 || options.supersample < 1) {
    throw InvalidArgumentError("renderCheckerboard: image size and supersample must be positive");
  }
  idealGridCorners(spec);  // validates the spec
  const int s = options.supersample;
  const int W = k.width * s, H = k.height * s;
  // Rays of every sub-pixel sample (undistorted normalised coordinates); they depend on the
  // camera only, so they are cached across the images of one trial.
  struct RayCache {
    CameraIntrinsics k;
    int s = 0;
    std::vector<cv::Vec2f> rays;
  };
  thread_local RayCache cache;
  const bool same = cache.s == s && cache.k.fx == k.fx && cache.k.fy == k.fy && cache.k.cx == k.cx &&
                    cache.k.cy == k.cy && cache.k.distortion == k.distortion && cache.k.width == k.width &&
                    cache.k.height == k.height;
  if (!same) {
    const cv::Mat K = (cv::Mat_<double>(3, 3) << k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
    const cv::Mat D =
        (cv::Mat_<double>(1, 5) << k.distortion[0], k.distortion[1], k.distortion[2], k.distortion[3], k.distortion[4]);
    cache.rays.assign(static_cast<size_t>(W) * static_cast<size_t>(H), cv::Vec2f());
    cv::Mat row(1, W, CV_64FC2), out;
    for (int y = 0; y < H; ++y) {
      for (int x = 0; x < W; ++x) row.at<cv::Vec2d>(0, x) = cv::Vec2d((x + 0.5) / s - 0.5, (y + 0.5) / s - 0.5);
      cv::undistortPoints(row, out, K, D);
      for (int x = 0; x < W; ++x) {
        const cv::Vec2d m = out.at<cv::Vec2d>(0, x);
        cache.rays[static_cast<size_t>(y) * static_cast<size_t>(W) + static_cast<size_t>(x)] =
            cv::Vec2f(static_cast<float>(m[0]), static_cast<float>(m[1]));
      }
    }
    cache.k = k;
    cache.s = s;
  }
  // Board plane in the camera frame: n . X = d.
  const Eigen::Matrix3d R = camera_T_grid.linear();
  const Eigen::Vector3d t = camera_T_grid.translation();
  const Eigen::Vector3d n = R.col(2);
  const double d = n.dot(t);
  const Eigen::Isometry3d grid_T_camera = camera_T_grid.inverse();
  const double sq = spec.square_mm;
  cv::Mat hi(H, W, CV_32F);
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) {
      const cv::Vec2f m = cache.rays[static_cast<size_t>(y) * static_cast<size_t>(W) + static_cast<size_t>(x)];
      const Eigen::Vector3d ray(m[0], m[1], 1.0);
      float value = options.background;
      const double denom = n.dot(ray);
      if (std::abs(denom) > 1e-12) {
        const double lambda = d / denom;
        if (lambda > 0) {
          const Eigen::Vector3d g = grid_T_camera * (lambda * ray);
          // Squares (i, j) with i in [-1, rows], j in [-1, cols] in units of sq from corner (0,0);
          // the outer ring (i or j at -2 / rows+1) is the white border.
          const double u = g.x() / sq, v = g.y() / sq;
          const int j = static_cast<int>(std::floor(u)), i = static_cast<int>(std::floor(v));
          if (i >= -2 && i <= spec.rows && j >= -2 && j <= spec.cols) {
            const bool border = i == -2 || j == -2 || i == spec.rows || j == spec.cols;
            const bool dark = !border && ((i + j) % 2 == 0);
            value = dark ? options.dark : options.light;
          }
        }
      }
      hi.at<float>(y, x) = value;
    }
  }
  cv::Mat lo;
  cv::resize(hi, lo, cv::Size(k.width, k.height), 0, 0, cv::INTER_AREA);
  if (options.blur_sigma_px > 0) cv::GaussianBlur(lo, lo, cv::Size(0, 0), options.blur_sigma_px);
  if (options.noise_sigma > 0) {
    cv::Mat noise(lo.size(), CV_32F);
    cv::RNG rng(options.seed);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, options.noise_sigma);
    lo += noise;
  }
  cv::Mat out;
  lo.convertTo(out, CV_8U);  // saturating
  GrayImage image;
  image.width = k.width;
  image.height = k.height;
  image.pixels.assign(out.datastart, out.dataend);
  return image;
}

}  // namespace mrsns::hmd
