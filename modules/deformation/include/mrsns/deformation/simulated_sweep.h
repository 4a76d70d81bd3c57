#pragma once
// One case of the simulated protocol (paper 001 §III.A) as a recording: the
// PCA model, the held-out ground truth, and the freehand sweep as a PLUS-like
// tracked sequence (8-bit B-mode frames, ProbeToTracker and
// ReferenceToTracker per frame), the ImageToProbe calibration navigation
// believes (with the calibration error, pixel scale included as PLUS writes
// it), and the ideal contours an external segmenter would report per frame.
// The model and the ground truth are in the Reference frame.

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "mrsns/core/plane_intersection.h"
#include "mrsns/core/shape_model.h"
#include "mrsns/core/tracked_frame.h"
#include "mrsns/deformation/deformation_trial.h"

namespace mrsns::deformation {

struct SimulatedSweep {
  ShapeModel model;
  TriangleMesh truth;
  std::vector<int> fiducial_vertices;
  TrackedSequence sequence;
  /// probe_T_image with the pixel scale (maps pixels to probe mm), as believed.
  Eigen::Matrix4d image_to_probe = Eigen::Matrix4d::Identity();
  double pixel_spacing_mm = 0.2;
  /// Per frame: the ground truth's cut with the true image plane, in the
  /// image coordinates of Algorithm 1 (mm, z = 0).
  std::vector<std::vector<Polyline3d>> true_contours;
};

/// Simulates one case with the options of the trial (cases is ignored).
/// Deterministic for a seed. Throws InvalidArgumentError as runDeformationTrial.
[[nodiscard]] SimulatedSweep simulateSweep(const DeformationTrialOptions& options, std::uint64_t seed);

/// Frame `f` of `frames` of the trial's freehand sweep: model_T_probe (the
/// Reference frame is the model frame) and probe_T_image (mm).
struct SweepPose {
  Eigen::Isometry3d model_T_probe = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d probe_T_image = Eigen::Isometry3d::Identity();
};
[[nodiscard]] SweepPose sweepPose(const DeformationTrialOptions& options, int frame, const Eigen::Vector3d& phases);

}  // namespace mrsns::deformation
