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

/// Where the target line is looked for: a clip rectangle in MF image pixels
/// (0 size: the whole frame), e.g. to leave out the transducer's ringing
/// near the top.
struct LineSignalOptions {
  int clip_x = 0, clip_y = 0, clip_width = 0, clip_height = 0;
  int scanlines = 64;                 ///< columns sampled across the clip rectangle
  int min_valid_scanlines = 5;        ///< fewer: the frame has no line
  double max_line_residual_px = 3.0;  ///< scanline peaks further from the fitted line are outliers
  /// The line must be found in at least this fraction of the valid frames
  /// (a recording of the flat target shows it throughout), else
  /// ComputationError.
  double min_found_fraction = 0.5;
};

/// Depth (MF pixels along the image y axis) of the target line in every
/// frame whose image is valid (ComputationError when it is found in fewer
/// than `min_found_fraction` of them): per scanline the echo with the largest area
/// above half of the scanline's maximum (a thick bottom echo beats thin
/// speckle), its intensity centre, then a line fitted through the scanline
/// peaks with outliers dropped, evaluated at the middle of the clip
/// rectangle (a tilted target still gives one depth). Frames with no clear
/// line are skipped; UF/MN/UN frames are flipped to MF first.
TimedSignal videoLineSignal(const TrackedSequence& sequence, const LineSignalOptions& options = {});

struct TemporalCalibrationOptions {
  double max_lag_s = 2.0;  ///< lags searched in [-max, max] (PLUS's default range)
  double lag_step_s = 0.001;
  double min_tracker_motion_mm = 2.0;  ///< RMS of the tracker signal about its mean
  double min_video_motion_px = 2.0;    ///< RMS of the video signal about its mean
  double min_correlation = 0.5;        ///< below it the result is refused
  std::size_t min_samples = 20;
  /// A lag counts only where at least this fraction of the video samples
  /// has tracker data around it.
  double min_overlap_fraction = 0.5;
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
