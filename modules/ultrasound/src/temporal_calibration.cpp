#include "mrsns/ultrasound/temporal_calibration.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "mrsns/core/error.h"
#include "mrsns/ultrasound/probe_calibration.h"

namespace mrsns::ultrasound {
namespace {

double rmsAboutMean(const std::vector<double>& v) {
  if (v.empty()) return 0.0;
  const double mean = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
  double s = 0.0;
  for (const double x : v) s += (x - mean) * (x - mean);
  return std::sqrt(s / static_cast<double>(v.size()));
}

// Linear interpolation of `s` at time t; false outside its span.
bool sample(const TimedSignal& s, double t, double& out) {
  const auto& ts = s.time_s;
  if (t < ts.front() || t > ts.back()) return false;
  const auto it = std::upper_bound(ts.begin(), ts.end(), t);
  if (it == ts.end()) {
    out = s.value.back();
    return true;
  }
  const auto i = static_cast<std::size_t>(it - ts.begin());
  const double t0 = ts[i - 1], t1 = ts[i];
  const double a = t1 > t0 ? (t - t0) / (t1 - t0) : 0.0;
  out = (1.0 - a) * s.value[i - 1] + a * s.value[i];
  return true;
}

// NCC between video samples and the tracker signal shifted by `lag`
// (tracker read at video time + lag); nan when they overlap too little.
double ncc(const TimedSignal& tracker, const TimedSignal& video, double lag, std::size_t min_samples) {
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < video.time_s.size(); ++i) {
    double a = 0.0;
    if (!sample(tracker, video.time_s[i] + lag, a)) continue;
    const double b = video.value[i];
    sa += a;
    sb += b;
    saa += a * a;
    sbb += b * b;
    sab += a * b;
    ++n;
  }
  if (n < min_samples) return std::nan("");
  const double dn = static_cast<double>(n);
  const double cov = sab - sa * sb / dn, va = saa - sa * sa / dn, vb = sbb - sb * sb / dn;
  if (va <= 0.0 || vb <= 0.0) return std::nan("");
  return cov / std::sqrt(va * vb);
}

void checkSignal(const TimedSignal& s, const char* name) {
  if (s.time_s.size() != s.value.size()) {
    throw InvalidArgumentError(std::string("temporal calibration: the ") + name + " signal has " +
                               std::to_string(s.time_s.size()) + " times but " + std::to_string(s.value.size()) +
                               " values");
  }
  for (std::size_t i = 1; i < s.time_s.size(); ++i) {
    if (!(s.time_s[i] > s.time_s[i - 1])) {
      throw InvalidArgumentError(std::string("temporal calibration: the ") + name +
                                 " timestamps are not strictly increasing at sample " + std::to_string(i));
    }
  }
}

}  // namespace

TimedSignal trackerPositionSignal(const std::vector<FramePose>& poses) {
  TimedSignal s;
  if (poses.empty()) return s;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : poses) mean += p.to_T_from.translation();
  mean /= static_cast<double>(poses.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : poses) {
    const Eigen::Vector3d d = p.to_T_from.translation() - mean;
    cov += d * d.transpose();
  }
  const Eigen::Vector3d axis = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvectors().col(2);
  std::vector<std::pair<double, double>> samples;
  for (const auto& p : poses) samples.emplace_back(p.timestamp, axis.dot(p.to_T_from.translation() - mean));
  std::sort(samples.begin(), samples.end());
  for (const auto& [t, v] : samples) {
    if (!s.time_s.empty() && t <= s.time_s.back()) continue;  // repeated timestamps: keep the first
    s.time_s.push_back(t);
    s.value.push_back(v);
  }
  return s;
}

namespace {

// The centre (sub-pixel) of the echo with the largest area above half the
// profile's maximum; false when the profile is flat or dark.
bool largestEchoCentre(const std::vector<double>& profile, double& centre) {
  const double peak = *std::max_element(profile.begin(), profile.end());
  if (peak < 32.0) return false;  // no echo on this scanline
  const double threshold = 0.5 * peak;
  double best_area = 0.0;
  for (std::size_t i = 0; i < profile.size();) {
    if (profile[i] <= threshold) {
      ++i;
      continue;
    }
    double area = 0.0, moment = 0.0;
    for (; i < profile.size() && profile[i] > threshold; ++i) {
      area += profile[i] - threshold;
      moment += (profile[i] - threshold) * static_cast<double>(i);
    }
    if (area > best_area) {
      best_area = area;
      centre = moment / area;
    }
  }
  return best_area > 0.0;
}

// y = a + b x through the scanline peaks: the line through two peaks that
// most others lie near (every pair is tried: a few dozen peaks), then least
// squares on those inliers.
bool robustLine(const std::vector<Eigen::Vector2d>& points, double max_residual, std::size_t min_points, double& a,
                double& b) {
  if (points.size() < std::max<std::size_t>(min_points, 2)) return false;
  std::size_t best_count = 0;
  double best_a = 0.0, best_b = 0.0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    for (std::size_t j = i + 1; j < points.size(); ++j) {
      const double dx = points[j].x() - points[i].x();
      if (std::abs(dx) < 1e-9) continue;
      const double slope = (points[j].y() - points[i].y()) / dx;
      const double intercept = points[i].y() - slope * points[i].x();
      std::size_t count = 0;
      for (const auto& p : points) count += std::abs(p.y() - (intercept + slope * p.x())) <= max_residual ? 1 : 0;
      if (count > best_count) {
        best_count = count;
        best_a = intercept;
        best_b = slope;
      }
    }
  }
  if (best_count < min_points) return false;
  double sx = 0, sy = 0, sxx = 0, sxy = 0, n = 0;
  for (const auto& p : points) {
    if (std::abs(p.y() - (best_a + best_b * p.x())) > max_residual) continue;
    sx += p.x();
    sy += p.y();
    sxx += p.x() * p.x();
    sxy += p.x() * p.y();
    n += 1.0;
  }
  const double den = n * sxx - sx * sx;
  if (std::abs(den) < 1e-12) return false;
  b = (n * sxy - sx * sy) / den;
  a = (sy - b * sx) / n;
  return true;
}

}  // namespace

TimedSignal videoLineSignal(const TrackedSequence& sequence, const LineSignalOptions& options) {
  const auto& g = sequence.geometry;
  if (sequence.trackingOnly()) {
    throw InvalidArgumentError("line detection: the sequence has no images (a tracker buffer); give the video buffer");
  }
  if (sequence.pixel_format.scalar != PixelType::UInt8 || sequence.pixel_format.components != 1 || g.size[2] != 1) {
    throw UnsupportedError("line detection needs 8-bit single-component 2D frames");
  }
  const int w = static_cast<int>(g.size[0]), h = static_cast<int>(g.size[1]);
  cv::Rect roi(0, 0, w, h);
  if (options.clip_width > 0 && options.clip_height > 0) {
    roi &= cv::Rect(options.clip_x, options.clip_y, options.clip_width, options.clip_height);
  }
  if (roi.width < 1 || roi.height < 8) {
    throw InvalidArgumentError("line detection: the clip rectangle leaves " + std::to_string(roi.width) + "x" +
                               std::to_string(roi.height) + " pixels of the " + std::to_string(w) + "x" +
                               std::to_string(h) + " frames");
  }
  const int scanlines = std::clamp(options.scanlines, 2, roi.width);
  const double centre_x = roi.x + 0.5 * (roi.width - 1);
  TimedSignal s;
  std::vector<std::pair<double, double>> samples;
  std::vector<Eigen::Vector2d> peaks;
  std::vector<double> profile(static_cast<std::size_t>(roi.height));
  // MF frames are used in place; only other orientations are flipped (a copy).
  const bool mf_already =
      sequence.orientation.size() >= 2 && sequence.orientation[0] == 'M' && sequence.orientation[1] == 'F';
  std::vector<std::uint8_t> flipped;
  std::size_t valid = 0;
  for (const auto& frame : sequence.frames) {
    // PLUS marks dropped frames ImageStatus INVALID; no status means valid.
    if (!frame.image_status.empty() && frame.image_status != "OK") continue;
    ++valid;
    if (frame.pixels.size() != sequence.frameBytes()) {
      throw InvalidArgumentError("line detection: a frame has no pixels (read the sequence with its pixels)");
    }
    if (!mf_already) flipped = toMfPixels(sequence, frame);
    const std::uint8_t* pixels = mf_already ? frame.pixels.data() : flipped.data();
    const cv::Mat img(h, w, CV_8U, const_cast<std::uint8_t*>(pixels));
    cv::Mat smooth;
    // Vertical smoothing only: the line runs across, speckle does not.
    cv::GaussianBlur(img(roi), smooth, cv::Size(1, 7), 0.0, 2.0);
    peaks.clear();
    for (int k = 0; k < scanlines; ++k) {
      const int x = static_cast<int>(std::lround(k * (roi.width - 1) / static_cast<double>(scanlines - 1)));
      for (int y = 0; y < roi.height; ++y) profile[static_cast<std::size_t>(y)] = smooth.at<std::uint8_t>(y, x);
      double centre = 0.0;
      if (largestEchoCentre(profile, centre)) peaks.emplace_back(roi.x + x, roi.y + centre);
    }
    double a = 0.0, b = 0.0;
    if (!robustLine(peaks, options.max_line_residual_px, static_cast<std::size_t>(options.min_valid_scanlines), a, b)) {
      continue;
    }
    samples.emplace_back(frame.timestamp, a + b * centre_x);
  }
  if (static_cast<double>(samples.size()) < options.min_found_fraction * static_cast<double>(valid)) {
    throw ComputationError("line detection: the target line was found in " + std::to_string(samples.size()) + " of " +
                           std::to_string(valid) +
                           " valid frames; record the probe moving over a flat target (e.g. the water-tank floor) "
                           "that stays in view, or clip the frames to it");
  }
  std::sort(samples.begin(), samples.end());
  for (const auto& [t, v] : samples) {
    if (!s.time_s.empty() && t <= s.time_s.back()) continue;
    s.time_s.push_back(t);
    s.value.push_back(v);
  }
  return s;
}

TemporalCalibrationResult calibrateTemporal(const TimedSignal& tracker, const TimedSignal& video,
                                            const TemporalCalibrationOptions& options) {
  checkSignal(tracker, "tracker");
  checkSignal(video, "video");
  TemporalCalibrationResult r;
  r.tracker_samples = tracker.time_s.size();
  r.video_samples = video.time_s.size();
  if (r.tracker_samples < options.min_samples || r.video_samples < options.min_samples) {
    throw ComputationError("temporal calibration: " + std::to_string(r.tracker_samples) + " tracker and " +
                           std::to_string(r.video_samples) + " video samples, at least " +
                           std::to_string(options.min_samples) + " of each needed");
  }
  r.tracker_motion_rms = rmsAboutMean(tracker.value);
  r.video_motion_rms = rmsAboutMean(video.value);
  if (r.tracker_motion_rms < options.min_tracker_motion_mm || r.video_motion_rms < options.min_video_motion_px) {
    throw ComputationError("temporal calibration: too little motion (tracker " + std::to_string(r.tracker_motion_rms) +
                           " mm RMS, need " + std::to_string(options.min_tracker_motion_mm) + "; image line " +
                           std::to_string(r.video_motion_rms) + " px RMS, need " +
                           std::to_string(options.min_video_motion_px) +
                           "); move the probe up and down over the flat target for several cycles (when the "
                           "image line stands still, clip the frames to the target: the transducer's ringing or "
                           "another echo may be what was followed)");
  }
  // A lag that leaves most of the video without tracker data is not
  // trusted: short overlaps correlate by chance.
  const auto min_overlap = std::max(
      options.min_samples, static_cast<std::size_t>(std::ceil(options.min_overlap_fraction * r.video_samples)));
  const int steps = static_cast<int>(std::ceil(options.max_lag_s / options.lag_step_s));
  for (int i = -steps; i <= steps; ++i) {
    const double lag = i * options.lag_step_s;
    r.lags_s.push_back(lag);
    r.correlations.push_back(ncc(tracker, video, lag, min_overlap));
  }
  // The sign of the coupling between the two signals is unknown (probe axis
  // direction, image orientation): the peak of |NCC| is taken, and among
  // near-equal peaks (a periodic motion repeats every half period with the
  // sign flipped) the one nearest zero lag.
  double best_abs = 0.0;
  for (const double c : r.correlations) {
    if (!std::isnan(c)) best_abs = std::max(best_abs, std::abs(c));
  }
  if (best_abs <= 0.0)
    throw ComputationError("temporal calibration: the tracker and video signals do not overlap in time");
  std::size_t best = 0;
  double best_lag = 1e300;
  for (std::size_t i = 0; i < r.correlations.size(); ++i) {
    const double c = r.correlations[i];
    if (std::isnan(c) || std::abs(c) < 0.97 * best_abs) continue;
    // Local maximum of |NCC| only.
    const bool left = i == 0 || std::isnan(r.correlations[i - 1]) || std::abs(r.correlations[i - 1]) <= std::abs(c);
    const bool right = i + 1 == r.correlations.size() || std::isnan(r.correlations[i + 1]) ||
                       std::abs(r.correlations[i + 1]) <= std::abs(c);
    if (left && right && std::abs(r.lags_s[i]) < std::abs(best_lag)) {
      best_lag = r.lags_s[i];
      best = i;
    }
  }
  r.polarity = r.correlations[best] >= 0.0 ? 1 : -1;
  r.correlation = std::abs(r.correlations[best]);
  r.tracker_lag_s = r.lags_s[best];
  if (best > 0 && best + 1 < r.correlations.size() && !std::isnan(r.correlations[best - 1]) &&
      !std::isnan(r.correlations[best + 1])) {
    const double a = std::abs(r.correlations[best - 1]), b = r.correlation, c = std::abs(r.correlations[best + 1]);
    const double den = a - 2.0 * b + c;
    if (den < 0.0) r.tracker_lag_s += 0.5 * (a - c) / den * options.lag_step_s;
  }
  if (r.correlation < options.min_correlation) {
    throw ComputationError("temporal calibration: the best correlation is " + std::to_string(r.correlation) +
                           " (need " + std::to_string(options.min_correlation) +
                           "); the image line was not followed reliably or the motion is not shared");
  }
  return r;
}

}  // namespace mrsns::ultrasound
