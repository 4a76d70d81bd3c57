#pragma once
// Latency between the external tracker and the HMD's own (SLAM) tracking,
// after paper 000 §2.2: the headset is recorded by both systems at once, at
// different rates, in different frames and with an unknown offset. Each
// position series is mapped to its own principal-component space, where the
// same physical motion shows in the same component (the third, the vertical
// bob of walking, in the paper) whatever the frame. Then:
// - events: extrema of that component in both series, matched in time, give
//   one latency per event (mean and standard deviation, as the paper's
//   49.84 +/- 0.98 ms);
// - normalised cross-correlation of the two components on a common uniform
//   grid, with parabolic sub-sample refinement of the peak.
// The latency is positive when the HMD lags: t_hmd = t_tracker + latency.
#include <Eigen/Core>
#include <span>
#include <vector>

namespace mrsns::hmd {

struct LatencyOptions {
  /// Principal component compared (0-based; 2 = the paper's third component).
  int component = 2;
  /// Largest |latency| searched (s).
  double max_latency_s = 0.5;
  /// Common grid rate (Hz); 0 = twice the faster stream's median rate.
  double resample_rate_hz = 0.0;
  /// Moving-average window applied before looking for extrema (s); 0 = none.
  double smoothing_s = 0.05;
  /// Extrema closer than this are one event (s): about half the motion's period.
  double min_event_separation_s = 0.25;
  /// An extremum counts when it lies beyond mean +/- this many standard deviations.
  double min_event_prominence_sd = 0.5;
};

struct LatencyEvent {
  double tracker_time_s = 0.0;
  double hmd_time_s = 0.0;
  double latency_s = 0.0;
  bool maximum = true;  ///< a maximum of the tracker's component (after sign alignment)
};

struct LatencyResult {
  std::vector<LatencyEvent> events;
  double event_mean_s = 0.0;
  double event_std_s = 0.0;  ///< sample standard deviation (0 with one event)
  double event_median_s = 0.0;
  double xcorr_latency_s = 0.0;
  /// Normalised cross-correlation at the peak, in [0, 1] after sign alignment.
  double xcorr_peak = 0.0;
  /// True when the HMD's component had the opposite sign (PCA axes have no preferred sign).
  bool component_sign_flipped = false;
  /// Fraction of variance on each principal axis, largest first.
  Eigen::Vector3d tracker_explained_variance = Eigen::Vector3d::Zero();
  Eigen::Vector3d hmd_explained_variance = Eigen::Vector3d::Zero();
  double grid_period_s = 0.0;
};

/// Throws InvalidArgumentError for fewer than 20 samples in a series, mismatched sizes,
/// non-finite values, times not strictly increasing, series that do not overlap in time, or
/// bad options; ComputationError when no event could be matched (too little motion).
LatencyResult estimateLatency(std::span<const double> tracker_times, std::span<const Eigen::Vector3d> tracker_positions,
                              std::span<const double> hmd_times, std::span<const Eigen::Vector3d> hmd_positions,
                              const LatencyOptions& options = {});

}  // namespace mrsns::hmd
