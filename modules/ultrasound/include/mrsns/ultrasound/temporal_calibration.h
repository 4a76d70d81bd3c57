#pragma once
// Temporal calibration: the lag between the tracker and the video streams,
// from a quasi-periodic motion of the probe over a flat target. The probe
// position along its main motion axis (tracker) is matched against the
// depth of the target line in the images (video) by normalised
// cross-correlation over candidate lags, refined below the lag step.
#include <cstddef>
#include <string>
#include <vector>

#include "mrsns/core/frame_poses.h"
#include "mrsns/core/tracked_frame.h"

namespace mrsns::ultrasound {

/// A scalar signal sampled at (increasing) times, seconds.
struct TimedSignal {
  std::vector<double> time_s;
  std::vector<double> value;
};

/// Position of the probe along the principal axis of its motion (mm), from
/// poses of e.g. ProbeToReference.
TimedSignal trackerPositionSignal(const std::vector<FramePose>& poses);

/// Depth (pixels along the image y axis) of the brightest horizontal line
/// in every frame: per column the smoothed intensity peak, median over the
/// columns. Frames with no clear line are skipped.
TimedSignal videoLineSignal(const TrackedSequence& sequence);

struct TemporalCalibrationOptions {
  double max_lag_s = 0.5;  ///< lags searched in [-max, max]
  double lag_step_s = 0.001;
  double min_tracker_motion_mm = 2.0;  ///< RMS of the tracker signal about its mean
  double min_video_motion_px = 2.0;    ///< RMS of the video signal about its mean
  double min_correlation = 0.5;        ///< below it the result is refused
  std::size_t min_samples = 20;
};

struct TemporalCalibrationResult {
  /// PLUS's TrackerLagSec: > 0 when the tracker data lags the video (the
  /// tracker reports an event later than the video shows it); subtract it
  /// from tracker timestamps to align them with the video.
  double tracker_lag_s = 0.0;
  double correlation = 0.0;  ///< NCC at the lag (sign of the motion coupling removed)
  int polarity = 1;          ///< +1 when the line goes deeper as the tracker signal grows
  double tracker_motion_rms = 0.0;
  double video_motion_rms = 0.0;
  std::size_t tracker_samples = 0;
  std::size_t video_samples = 0;
  std::vector<double> lags_s;  ///< the correlation curve searched
  std::vector<double> correlations;
};

/// Throws ComputationError for too few samples, too little motion in either
/// signal, no overlap, or a correlation below options.min_correlation.
TemporalCalibrationResult calibrateTemporal(const TimedSignal& tracker, const TimedSignal& video,
                                            const TemporalCalibrationOptions& options = {});

}  // namespace mrsns::ultrasound
