#pragma once
// The tracker lag estimated from the spatial calibration data itself: every
// segmented frame is re-paired with the probe pose the tracker reported for
// the frame's instant under a trial lag, the calibration is solved again,
// and the lag that minimises its 3D reprojection error wins. A freehand
// calibration sweep moves the probe enough for the lag to show: a wrong lag
// pairs each image with a pose from a moment before or after it.
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "mrsns/core/frame_poses.h"
#include "mrsns/ultrasound/nwire_geometry.h"
#include "mrsns/ultrasound/spatial_calibration.h"

namespace mrsns::ultrasound {

struct TrackerLagOptions {
  /// Search for the lag; otherwise `lag_s` is applied as given.
  bool estimate = false;
  /// PLUS's TrackerLagSec convention: the tracker stamps an instant at
  /// video time + lag (see probePoseAtVideoTime).
  double lag_s = 0.0;
  double search_half_range_s = 1.0;
  double search_step_s = 0.02;
  /// When the search fails (best lag at the edge of the range, too few
  /// frames), apply no lag and say why in TrackerLagEstimate::note instead
  /// of throwing: for callers that estimate by default (`calibrate-us`).
  bool fall_back_to_zero = false;
  /// With `estimate` off: search the lag all the same and report it beside
  /// the calibration at `lag_s` (ProbeCalibrationRun::tracker_lag_check),
  /// without applying it.
  bool check = false;
};

struct LagSample {
  double lag_s = 0.0;
  double reprojection_3d_mean_mm = 0.0;  ///< calibration error (PLUS's figure) at this lag
  std::size_t frames = 0;
};

struct TrackerLagEstimate {
  double lag_s = 0.0;
  bool estimated = false;
  /// Second derivative of the error curve at the minimum (mm/s^2), from a
  /// parabola through the neighbouring samples: a flat curve means the
  /// recording does not pin the lag down.
  double curvature_mm_per_s2 = 0.0;
  std::vector<LagSample> curve;
  /// Why no lag was applied although an estimate was asked for (empty otherwise).
  std::string note;
};

/// `frames` paired again with the pose at their video time under `lag_s`.
/// `frame_times_s[i]` is the video timestamp of sequence frame i (indexed by
/// CalibrationFrame::frame_index); frames whose shifted time (or, with
/// `margin_s`, any time within +-margin of it) falls outside the pose
/// stream are left out.
std::vector<CalibrationFrame> pairWithTrackerLag(const std::vector<CalibrationFrame>& frames,
                                                 const std::vector<double>& frame_times_s,
                                                 const std::vector<FramePose>& reference_T_probe, double lag_s,
                                                 double margin_s = 0.0);

/// Grid search over [-range, +range] then parabolic refinement at the best
/// sample. Throws ComputationError when the minimum sits at the edge of the
/// search range (widen it) or too few frames remain.
TrackerLagEstimate estimateTrackerLag(const std::vector<CalibrationFrame>& frames,
                                      const std::vector<double>& frame_times_s,
                                      const std::vector<FramePose>& reference_T_probe,
                                      const std::vector<NWirePattern>& patterns,
                                      const Eigen::Isometry3d& reference_T_phantom,
                                      const SpatialCalibrationOptions& spatial, const TrackerLagOptions& options);

}  // namespace mrsns::ultrasound
