#pragma once
// Simulated reproduction of paper 001 Fig. 7: virtual-physical calibration by
// three methods, each repeated over `trials` independent trials, scored by the
// fusion RMS error of Eq. 23 on 6 patient fiducials:
// - compensated:   four views (front, left, right, ground), tremor compensation
//                  (Eq. 12-17) per view, multi-view averaging (Eq. 18-20);
// - uncompensated: four matches from the front view, each fiducial taken from
//                  the single tracker sample at the moment the user confirms,
//                  the four calibrations averaged;
// - pointer:       a tracked stylus touches each hologram fiducial once from
//                  the front view (Sun et al., the paper's reference [23]).
// The noise model (CubeNoiseModel) is written beside every result.
#include <cstdint>
#include <string>
#include <vector>

#include "mrsns/hmd/tremor_compensation.h"

namespace mrsns::hmd {

/// What the simulation injects. Defaults are no kinder than the paper's situation: a NDI
/// Polaris Vega (0.35 mm), a HoloLens 2 whose users misjudge depth by 1.5-2 mm, hand tremor.
struct CubeNoiseModel {
  // Hand tremor while holding the cube (rigid motion of the cube).
  double tremor_amplitude_mm = 0.5;  ///< per axis, sinusoid amplitude
  double tremor_min_hz = 8.0;
  double tremor_max_hz = 12.0;
  double tremor_rotation_deg = 0.1;  ///< per axis, sinusoid amplitude
  double drift_mm_per_s = 0.25;      ///< slow drift speed during a hold, random direction
  double jerk_probability = 0.04;    ///< per sample: a sudden slip of the hand
  double jerk_min_mm = 2.0;          ///< slip magnitude, uniform in [min, max]
  double jerk_max_mm = 4.0;
  // Perception of the hologram when matching (whole-cube alignment error).
  double depth_bias_mm = 1.5;           ///< per trial (the user's habit), along the view axis
  double depth_error_mm = 1.0;          ///< per match, along the view axis (1.8 mm RMS with the bias)
  double lateral_error_mm = 0.5;        ///< per match, per axis across the view axis
  double alignment_rotation_deg = 0.3;  ///< per match, per axis
  double slam_jitter_mm = 0.3;          ///< per match, per axis: the hologram anchor wanders
  double slam_jitter_deg = 0.05;
  // Measurement.
  double tracking_mm = 0.35;  ///< per axis per sample, on every tracked point
  double sample_rate_hz = 60.0;
  double hold_s = 2.0;
  // Pointer method: a stylus tip on a hologram fiducial floating in the air.
  double pointer_depth_error_mm = 2.5;    ///< per point, along the view axis (no haptic contact)
  double pointer_lateral_error_mm = 0.7;  ///< per point, per axis across
  double pointer_tip_error_mm = 0.3;      ///< per trial, per axis: stylus pivot calibration error
};

struct CubeTrialOptions {
  int trials = 12;
  std::uint64_t seed = 1;
  CubeNoiseModel noise;
  TremorOptions tremor;
  double cube_edge_mm = 60.0;
  /// Distance of the user's head from the cube (only orients the view axes).
  int uncompensated_matches = 4;
};

struct MethodResult {
  std::string name;
  /// Eq. 23 RMS error of each trial, mm.
  std::vector<double> rms_mm;
  double mean_rms_mm = 0.0;
  double std_rms_mm = 0.0;  ///< sample standard deviation over trials
  /// Mean absolute error along the hologram frame's x, y, z (z = the front view axis), mm
  /// (the reprojection errors of Fig. 7(c)).
  Eigen::Vector3d mean_abs_axis_error_mm = Eigen::Vector3d::Zero();
};

struct CubeTrialResult {
  MethodResult compensated;
  MethodResult uncompensated;
  MethodResult pointer;
  /// Ablation, not in the paper: four matches from the front view WITH tremor compensation,
  /// averaged: what the tremor filter alone gains over `uncompensated`.
  MethodResult front_only_compensated;
  double improvement_vs_uncompensated_percent = 0.0;
  double improvement_vs_pointer_percent = 0.0;
  /// Mean over trials of the largest pairwise difference between the four compensated views.
  double mean_view_spread_deg = 0.0;
  /// ... and of the distance between where two views put the cube centre (mm).
  double mean_view_spread_mm = 0.0;
  /// Mean fraction of samples the tremor filter dropped.
  double mean_dropped_fraction = 0.0;
  CubeTrialOptions options;
};

/// Runs the three methods over options.trials trials. Throws InvalidArgumentError when
/// trials < 2 or a noise figure is negative or not finite.
CubeTrialResult runCubeTrial(const CubeTrialOptions& options = {});

}  // namespace mrsns::hmd
