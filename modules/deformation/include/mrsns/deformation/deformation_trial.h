#pragma once
// The simulated phantom protocol of paper 001 §III.A: a carotid-like
// bifurcating vessel, a PCA model from 20 randomly stretched training shapes,
// a held-out stretched shape as ground truth, B-mode-like slices of it along a
// freehand sweep with speckle, attenuation, calibration and tracking error,
// lumen segmentation seeded by the model, Algorithm 1, and the errors of
// Table I: E^SD (Eq. 22, mean surface distance, plus max) and E^FP (Eq. 21,
// fiducial-vertex error) for the posterior and for the undeformed prior.

#include <cstdint>
#include <vector>

#include "mrsns/deformation/bmode.h"
#include "mrsns/deformation/shape_tracker.h"
#include "mrsns/deformation/vessel_phantom.h"

namespace mrsns::deformation {

struct DeformationTrialOptions {
  int cases = 6;
  std::uint64_t seed = 1;
  int training_shapes = 20;
  int frames = 90;
  /// Ultrasound calibration error: a fixed rigid error of the image plane per
  /// case, translation with this 3D RMS (mm) plus `calibration_rotation_deg`.
  double calibration_error_mm = 1.2;
  double calibration_rotation_deg = 1.0;
  /// Tracking noise per frame: translation 3D RMS (mm) and rotation (deg).
  double tracking_noise_mm = 0.35;
  double tracking_rotation_deg = 0.2;
  /// Freehand sweep: tilt of the probe about x and y (deg, amplitude).
  double sweep_tilt_deg = 10.0;
  /// Stretch amplitude of training and ground-truth shapes (mm RMS per axis).
  double stretch_mm = 2.0;
  /// Observation noise sigma of the posterior (mm): segmentation, calibration
  /// and tracking errors together. Overrides tracker.posterior.noise_sigma_mm.
  double noise_sigma_mm = 1.5;
  VesselPhantomOptions phantom;
  BModeSimulationOptions bmode;
  LumenSegmentationOptions segmentation;
  /// The built-in segmenter sometimes locks onto the wrong lumen: frames that
  /// make the posterior implausible are undone.
  ShapeTrackerOptions tracker = [] {
    ShapeTrackerOptions t;
    t.reject_implausible_frames = true;
    return t;
  }();
};

struct TrialCase {
  double posterior_sd_mean_mm = 0.0;
  double posterior_sd_max_mm = 0.0;
  double posterior_fp_mm = 0.0;
  double prior_sd_mean_mm = 0.0;
  double prior_sd_max_mm = 0.0;
  double prior_fp_mm = 0.0;
  int frames = 0;
  int frames_updated = 0;
  int contours_segmented = 0;
  int contours_refused = 0;
  int contours_split = 0;  ///< Segmented from overlapping branch loops (of contours_segmented)
  int observations = 0;
  int excluded = 0;
  double posterior_mahalanobis = 0.0;
  std::vector<double> update_ms;        ///< Algorithm 1 per updated frame
  std::vector<double> segmentation_ms;  ///< Lumen segmentation per frame
};

struct Summary {
  double mean = 0.0;
  double sd = 0.0;
  double max = 0.0;
};

struct DeformationTrialResult {
  std::vector<TrialCase> cases;
  Summary posterior_sd_mean_mm, posterior_sd_max_mm, posterior_fp_mm;
  Summary prior_sd_mean_mm, prior_sd_max_mm, prior_fp_mm;
  double update_ms_p50 = 0.0;
  double update_ms_p99 = 0.0;
  double segmentation_ms_p50 = 0.0;
  int model_modes = 0;
  int model_points = 0;
};

/// Runs the protocol; deterministic for a seed. Throws InvalidArgumentError
/// for fewer than 1 case, fewer than 3 training shapes or 1 frame.
[[nodiscard]] DeformationTrialResult runDeformationTrial(const DeformationTrialOptions& options);

}  // namespace mrsns::deformation
