// Per-image chain T_c^h = T_w^h T_b^w T_p^b T_c^p, corner-order disambiguation, averaging and
// Tables 1-2, and the retro-projection error.
#include "mrsns/hmd/checkerboard_hand_eye.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/rotation_average.h"
#include "mrsns/hmd/retro_projection.h"

namespace mrsns::hmd {
namespace {

void checkViews(const std::vector<CheckerboardView>& views, const CheckerboardSpec& spec, size_t min_views) {
  if (views.size() < min_views) {
    throw InvalidArgumentError("checkerboard hand-eye calibration needs at least " + std::to_string(min_views) +
                               " images with tracked poses, got " + std::to_string(views.size()) +
                               ": take more images from different distances and directions");
  }
  for (size_t i = 0; i < views.size(); ++i) {
    if (views[i].corners_px.size() != static_cast<size_t>(spec.rows * spec.cols)) {
      throw InvalidArgumentError("image '" + views[i].name + "' has " + std::to_string(views[i].corners_px.size()) +
                                 " corners for a " + std::to_string(spec.rows) + " x " + std::to_string(spec.cols) +
                                 " checkerboard");
    }
  }
}

std::vector<Eigen::Vector2d> ordered(const std::vector<Eigen::Vector2d>& corners, bool reversed) {
  if (!reversed) return corners;
  return {corners.rbegin(), corners.rend()};
}

Eigen::Isometry3d chain(const CheckerboardView& v, const Eigen::Isometry3d& board_T_grid,
                        const Eigen::Isometry3d& camera_T_grid) {
  return v.tracker_T_hmd.inverse() * v.tracker_T_board * board_T_grid * camera_T_grid.inverse();
}

// Distance between two estimates in mm-equivalent: translation plus rotation at 1 m.
double poseDistance(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm() + 1000.0 * rotationAngleBetween(a.linear(), b.linear());
}

double sampleStd(const std::vector<double>& v, double mean) {
  if (v.size() < 2) return 0.0;
  double s = 0.0;
  for (double x : v) s += (x - mean) * (x - mean);
  return std::sqrt(s / static_cast<double>(v.size() - 1));
}

}  // namespace

CheckerboardHandEyeResult calibrateCheckerboardHandEye(const std::vector<CheckerboardView>& views,
                                                       const Eigen::Isometry3d& board_T_grid,
                                                       const CheckerboardSpec& spec, const CameraIntrinsics& intrinsics,
                                                       const CheckerboardHandEyeOptions& options) {
  checkViews(views, spec, static_cast<size_t>(std::max(options.min_views, 1)));
  // OpenCV's numbering of a board is only reliably anchored for boards that differ from their
  // 180-deg turn; trying both orders costs one solvePnP per view and is safe for any board.
  const bool try_both = options.resolve_symmetric_order;
  // Estimates for both corner orders of every view.
  std::vector<std::array<Eigen::Isometry3d, 2>> candidates(views.size());
  std::vector<std::array<double, 2>> pnp_rms(views.size());
  for (size_t i = 0; i < views.size(); ++i) {
    for (int r = 0; r < (try_both ? 2 : 1); ++r) {
      const BoardPose pose = estimateBoardPose(ordered(views[i].corners_px, r == 1), spec, intrinsics);
      candidates[i][static_cast<size_t>(r)] = chain(views[i], board_T_grid, pose.camera_T_grid);
      pnp_rms[i][static_cast<size_t>(r)] = pose.rms_reprojection_px;
    }
  }
  // Choose orders: for each seed (view 0 in either order) take, per view, the order nearest the
  // seed; keep the assignment with the smaller total spread.
  std::vector<bool> best_rev(views.size(), false);
  double best_cost = std::numeric_limits<double>::infinity();
  for (int seed = 0; seed < (try_both ? 2 : 1); ++seed) {
    const Eigen::Isometry3d& ref = candidates[0][static_cast<size_t>(seed)];
    std::vector<bool> rev(views.size(), false);
    double cost = 0.0;
    for (size_t i = 0; i < views.size(); ++i) {
      const double d0 = poseDistance(candidates[i][0], ref);
      const double d1 = try_both ? poseDistance(candidates[i][1], ref) : std::numeric_limits<double>::infinity();
      rev[i] = d1 < d0;
      cost += std::min(d0, d1);
    }
    if (cost < best_cost) {
      best_cost = cost;
      best_rev = rev;
    }
  }
  CheckerboardHandEyeResult result;
  result.corners_reversed = best_rev;
  for (size_t i = 0; i < views.size(); ++i) {
    const size_t r = best_rev[i] ? 1 : 0;
    result.per_view_hmd_T_camera.push_back(candidates[i][r]);
    result.per_view_pnp_rms_px.push_back(pnp_rms[i][r]);
  }
  const PoseAverageResult mean = averagePoses(result.per_view_hmd_T_camera);
  result.hmd_T_camera = mean.mean;
  result.rotation_rms_rad = mean.rotation.rms_angle;
  result.translation_rms_mm = mean.translation_rms;
  result.dispersion = transformDispersion(result.per_view_hmd_T_camera);
  return result;
}

RetroProjectionResult retroProjectionError(const std::vector<CheckerboardView>& views,
                                           const Eigen::Isometry3d& hmd_T_camera, const Eigen::Isometry3d& board_T_grid,
                                           const CheckerboardSpec& spec, const CameraIntrinsics& intrinsics,
                                           const std::vector<bool>& reversed) {
  checkViews(views, spec, 1);
  const std::vector<Eigen::Vector3d> grid = idealGridCorners(spec);
  RetroProjectionResult result;
  for (size_t i = 0; i < views.size(); ++i) {
    const auto& v = views[i];
    const auto detected = ordered(v.corners_px, i < reversed.size() && reversed[i]);
    const Eigen::Isometry3d camera_T_grid =
        hmd_T_camera.inverse() * v.tracker_T_hmd.inverse() * v.tracker_T_board * board_T_grid;
    std::vector<Eigen::Vector3d> in_camera;
    for (const auto& g : grid) in_camera.push_back(camera_T_grid * g);
    const auto projected = projectPoints(in_camera, intrinsics);
    const auto rays = pixelRays(detected, intrinsics);
    const Eigen::Vector3d n = camera_T_grid.linear().col(2);
    const double d = n.dot(camera_T_grid.translation());
    double sum_px = 0.0, sum_mm = 0.0;
    for (size_t c = 0; c < grid.size(); ++c) {
      const double e_px = (projected[c] - detected[c]).norm();
      const double denom = n.dot(rays[c]);
      // A ray parallel to the board (grazing view) has no intersection: count the 3D offset of
      // the corner from the ray instead.
      double e_mm = 0.0;
      if (std::abs(denom) > 1e-9) {
        e_mm = ((d / denom) * rays[c] - in_camera[c]).norm();
      } else {
        e_mm = (in_camera[c] - in_camera[c].dot(rays[c]) * rays[c]).norm();
      }
      result.corner_error_px.push_back(e_px);
      result.corner_error_mm.push_back(e_mm);
      sum_px += e_px * e_px;
      sum_mm += e_mm * e_mm;
    }
    result.per_view_rms_px.push_back(std::sqrt(sum_px / static_cast<double>(grid.size())));
    result.per_view_rms_mm.push_back(std::sqrt(sum_mm / static_cast<double>(grid.size())));
  }
  const auto n = static_cast<double>(result.corner_error_px.size());
  double sp = 0, sm = 0, qp = 0, qm = 0;
  for (size_t k = 0; k < result.corner_error_px.size(); ++k) {
    sp += result.corner_error_px[k];
    sm += result.corner_error_mm[k];
    qp += result.corner_error_px[k] * result.corner_error_px[k];
    qm += result.corner_error_mm[k] * result.corner_error_mm[k];
  }
  result.mean_px = sp / n;
  result.mean_mm = sm / n;
  result.std_px = sampleStd(result.corner_error_px, result.mean_px);
  result.std_mm = sampleStd(result.corner_error_mm, result.mean_mm);
  result.rms_px = std::sqrt(qp / n);
  result.rms_mm = std::sqrt(qm / n);
  return result;
}

}  // namespace mrsns::hmd
