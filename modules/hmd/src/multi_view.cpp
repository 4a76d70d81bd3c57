#include "mrsns/hmd/multi_view.h"

#include <algorithm>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"

namespace mrsns::hmd {

MultiViewResult averageViews(std::span<const Eigen::Isometry3d> views, const RotationAverageOptions& options) {
  if (views.empty()) {
    throw InvalidArgumentError("averageViews: no view calibrations; calibrate at least one view");
  }
  const PoseAverageResult avg = averagePoses(views, options);
  MultiViewResult r;
  r.tracker_T_hololens = avg.mean;
  r.rotation_from_mean_rad = avg.rotation.residual_angles;
  r.translation_from_mean_mm = avg.translation_residuals;
  r.rotation_rms_rad = avg.rotation.rms_angle;
  r.translation_rms_mm = avg.translation_rms;
  r.converged = avg.rotation.converged;
  for (std::size_t i = 0; i < views.size(); ++i) {
    for (std::size_t j = i + 1; j < views.size(); ++j) {
      r.max_pairwise_rotation_rad =
          std::max(r.max_pairwise_rotation_rad, rotationAngleBetween(views[i].linear(), views[j].linear()));
      r.max_pairwise_translation_mm =
          std::max(r.max_pairwise_translation_mm, (views[i].translation() - views[j].translation()).norm());
    }
  }
  return r;
}

}  // namespace mrsns::hmd
