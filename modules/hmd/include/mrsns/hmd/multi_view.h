#pragma once
// Multi-view averaging of cube calibrations (paper 001, §II.C.2, Eq. 18-20):
// the front, left, right and ground views each give tracker_T_hololens; their
// depth-perception errors lie along different view axes, so the average
// (Riemannian mean rotation, mean translation; core/rotation_average.h) is
// better than any one view. The spread between views is reported because a
// view far from the others points at a bad match.
#include <Eigen/Geometry>
#include <span>
#include <string>
#include <vector>

#include "mrsns/core/rotation_average.h"

namespace mrsns::hmd {

struct MultiViewResult {
  Eigen::Isometry3d tracker_T_hololens = Eigen::Isometry3d::Identity();
  /// Per view: angle (rad) and translation distance (mm) from the mean, in input order.
  std::vector<double> rotation_from_mean_rad;
  std::vector<double> translation_from_mean_mm;
  /// Largest pairwise angle (rad) and translation distance (mm) between two views.
  double max_pairwise_rotation_rad = 0.0;
  double max_pairwise_translation_mm = 0.0;
  double rotation_rms_rad = 0.0;
  double translation_rms_mm = 0.0;
  bool converged = true;
};

/// Eq. 18-20 over the per-view calibrations (at least one). Throws InvalidArgumentError on
/// empty input or a non-rigid pose (through averagePoses).
MultiViewResult averageViews(std::span<const Eigen::Isometry3d> tracker_T_hololens_per_view,
                             const RotationAverageOptions& options = {});

}  // namespace mrsns::hmd
