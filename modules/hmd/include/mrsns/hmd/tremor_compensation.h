#pragma once
// Hand-tremor compensation (paper 001, §II.C.1, Eq. 12-17). While the user
// holds the cube on its hologram, each fiducial is sampled many times. Tremor
// spreads the samples and sudden jerks leave isolated points. Each sample gets
// a normal by local PCA over its K_close nearest neighbours and the mean normal
// curvature to those neighbours (Eq. 12-13):
//
//   C_j^i = -sin(beta) / (|P_i P_j| * sin(alpha)),   C_i = mean_j C_j^i
//
// beta: angle between the normals at P_i and P_j (normals oriented alike, so
// beta is in [0, pi/2]); alpha: angle between the normal at P_i and P_i P_j.
// A sample far from the mean (d_i > omega * mean d) AND flatter than average
// (C_i > mean C: isolated points have distant neighbours, so C near 0) is
// dropped (Eq. 14-15); the fiducial is the centroid of the rest (Eq. 16).
#include <Eigen/Geometry>
#include <span>
#include <vector>

#include "mrsns/hmd/cube_calibration.h"

namespace mrsns::hmd {

struct TremorOptions {
  /// Neighbours for the normal and curvature (K_close of Eq. 13; the paper uses 4).
  int k_close = 4;
  /// Outlier weight omega of Eq. 14: larger keeps more points.
  double omega = 1.5;
};

struct TremorCompensationResult {
  /// Estimated fiducial centre (Eq. 16).
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  /// Plain mean of all samples (mu^Tra), for comparison.
  Eigen::Vector3d raw_mean = Eigen::Vector3d::Zero();
  /// Per sample: kept by the filter of Eq. 14.
  std::vector<bool> kept;
  int kept_count = 0;
  /// Per sample: C_i (Eq. 13) and d_i, with their means (Eq. 15).
  std::vector<double> curvature;
  std::vector<double> distance_mm;
  double mean_curvature = 0.0;
  double mean_distance_mm = 0.0;
  /// RMS distance of the kept samples from the centre (mm): the residual tremor spread.
  double kept_spread_mm = 0.0;
};

/// Needs at least k_close + 1 finite samples; throws InvalidArgumentError otherwise or when
/// k_close < 2 or omega <= 0.
TremorCompensationResult compensateTremor(std::span<const Eigen::Vector3d> samples, const TremorOptions& options = {});

struct ViewCalibrationResult {
  CubeCalibrationResult calibration;
  /// Compensated tracker-frame centre of each fiducial, in input order.
  std::vector<Eigen::Vector3d> fiducial_tracker;
  /// Samples dropped per fiducial.
  std::vector<int> dropped_samples;
};

/// Eq. 17 for one view: compensates each fiducial's samples (samples_tracker[i] belongs to
/// fiducial_hololens[i]) and calibrates the cube on the centres. The paper uses 8 fiducials.
ViewCalibrationResult calibrateViewWithTremorCompensation(std::span<const std::vector<Eigen::Vector3d>> samples_tracker,
                                                          std::span<const Eigen::Vector3d> fiducial_hololens,
                                                          const TremorOptions& tremor = {},
                                                          const CubeCalibrationOptions& cube = {});

}  // namespace mrsns::hmd
