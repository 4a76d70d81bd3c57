#include "mrsns/ultrasound/tracker_lag.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "mrsns/core/error.h"
#include "mrsns/core/format.h"
#include "mrsns/ultrasound/image_chain.h"

namespace mrsns::ultrasound {

std::vector<CalibrationFrame> pairWithTrackerLag(const std::vector<CalibrationFrame>& frames,
                                                 const std::vector<double>& frame_times_s,
                                                 const std::vector<FramePose>& reference_T_probe, double lag_s,
                                                 double margin_s) {
  std::vector<CalibrationFrame> out;
  if (reference_T_probe.size() < 2) return out;
  const double first = reference_T_probe.front().timestamp, last = reference_T_probe.back().timestamp;
  out.reserve(frames.size());
  for (const auto& f : frames) {
    if (f.frame_index >= frame_times_s.size()) {
      throw InvalidArgumentError("frame " + std::to_string(f.frame_index) + " has no video timestamp (" +
                                 std::to_string(frame_times_s.size()) + " given)");
    }
    const double t = frame_times_s[f.frame_index] + lag_s;
    if (t - margin_s < first || t + margin_s > last) continue;
    CalibrationFrame g = f;
    g.reference_T_probe = probePoseAtVideoTime(reference_T_probe, frame_times_s[f.frame_index], lag_s);
    out.push_back(std::move(g));
  }
  return out;
}

namespace {

LagSample sampleAt(double lag_s, const std::vector<CalibrationFrame>& frames, const std::vector<double>& times,
                   const std::vector<FramePose>& poses, const std::vector<NWirePattern>& patterns,
                   const Eigen::Isometry3d& reference_T_phantom, const SpatialCalibrationOptions& spatial,
                   double margin_s) {
  // The same frames at every trial lag (margin = the search range), so the
  // error curve compares like with like.
  const auto paired = pairWithTrackerLag(frames, times, poses, lag_s, margin_s);
  LagSample s;
  s.lag_s = lag_s;
  s.frames = paired.size();
  const auto r = calibrateSpatial(paired, patterns, reference_T_phantom, spatial);
  s.reprojection_3d_mean_mm = r.calibration.reprojection_3d_mean_mm;
  return s;
}

}  // namespace

TrackerLagEstimate estimateTrackerLag(const std::vector<CalibrationFrame>& frames,
                                      const std::vector<double>& frame_times_s,
                                      const std::vector<FramePose>& reference_T_probe,
                                      const std::vector<NWirePattern>& patterns,
                                      const Eigen::Isometry3d& reference_T_phantom,
                                      const SpatialCalibrationOptions& spatial, const TrackerLagOptions& options) {
  TrackerLagEstimate est;
  if (!options.estimate) {
    est.lag_s = options.lag_s;
    return est;
  }
  const double range = options.search_half_range_s, step = options.search_step_s;
  if (!(range > 0.0) || !(step > 0.0) || step > range) {
    throw InvalidArgumentError("tracker lag search: the half range (" + formatGeneral(range) + " s) and step (" +
                               formatGeneral(step) + " s) must be positive, the step no larger than the range");
  }
  const int n = static_cast<int>(std::floor(range / step));
  for (int k = -n; k <= n; ++k) {
    est.curve.push_back(
        sampleAt(k * step, frames, frame_times_s, reference_T_probe, patterns, reference_T_phantom, spatial, range));
  }
  const auto best = std::min_element(est.curve.begin(), est.curve.end(), [](const LagSample& a, const LagSample& b) {
    return a.reprojection_3d_mean_mm < b.reprojection_3d_mean_mm;
  });
  const auto i = static_cast<std::size_t>(best - est.curve.begin());
  if (i == 0 || i + 1 == est.curve.size()) {
    throw ComputationError("the tracker lag that fits the calibration best lies at the edge of the search range (" +
                           formatGeneral(best->lag_s * 1e3) +
                           " ms): widen the range, or check that the probe poses belong to these frames");
  }
  // Parabola through the best sample and its neighbours (equal spacing).
  const double e0 = est.curve[i - 1].reprojection_3d_mean_mm, e1 = est.curve[i].reprojection_3d_mean_mm,
               e2 = est.curve[i + 1].reprojection_3d_mean_mm;
  const double denom = e0 - 2.0 * e1 + e2;
  double offset = 0.0;
  if (denom > 0.0) offset = std::clamp(0.5 * (e0 - e2) / denom, -0.5, 0.5);
  est.lag_s = est.curve[i].lag_s + offset * step;
  est.curvature_mm_per_s2 = denom / (step * step);
  est.estimated = true;
  return est;
}

}  // namespace mrsns::ultrasound
