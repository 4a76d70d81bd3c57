#include "mrsns/ultrasound/probe_calibration.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <mutex>
#include <thread>

#include "mrsns/core/error.h"
#include "mrsns/core/format.h"
#include "mrsns/core/frame_poses.h"
#include "mrsns/core/log.h"
#include "mrsns/core/rigid.h"

namespace mrsns::ultrasound {

std::vector<std::uint8_t> toMfPixels(const TrackedSequence& sequence, const TrackedFrame& frame) {
  const auto& g = sequence.geometry;
  if (sequence.pixel_format.scalar != PixelType::UInt8 || sequence.pixel_format.components != 1 || g.size[2] != 1) {
    throw UnsupportedError("N-wire segmentation needs 8-bit single-component 2D B-mode frames");
  }
  if (frame.pixels.size() != sequence.frameBytes()) {
    throw InvalidArgumentError("a frame holds " + std::to_string(frame.pixels.size()) + " bytes, expected " +
                               std::to_string(sequence.frameBytes()) + " (read the sequence with its pixels)");
  }
  const std::string o = sequence.orientation;
  if (o.size() < 2 || (o[0] != 'M' && o[0] != 'U') || (o[1] != 'F' && o[1] != 'N')) {
    throw UnsupportedError("ultrasound image orientation '" + o + "' is not supported (expected MF, UF, MN or UN)");
  }
  const bool flip_x = o[0] == 'U', flip_y = o[1] == 'N';
  if (!flip_x && !flip_y) return frame.pixels;
  const auto w = static_cast<std::size_t>(g.size[0]), h = static_cast<std::size_t>(g.size[1]);
  std::vector<std::uint8_t> out(frame.pixels.size());
  for (std::size_t y = 0; y < h; ++y) {
    const std::size_t sy = flip_y ? h - 1 - y : y;
    for (std::size_t x = 0; x < w; ++x) out[y * w + x] = frame.pixels[sy * w + (flip_x ? w - 1 - x : x)];
  }
  return out;
}

SequenceSegmentation segmentCalibrationSequence(const TrackedSequence& sequence, const io::PhantomDefinition& phantom,
                                                const NWireSegmentationOptions& options,
                                                const std::string& probe_to_reference, unsigned threads) {
  const auto start = std::chrono::steady_clock::now();
  SequenceSegmentation out;
  out.total_frames = sequence.frames.size();
  const auto poses = extractFramePoses(sequence.frames, probe_to_reference);
  std::vector<const FramePose*> pose_of(sequence.frames.size(), nullptr);
  for (const auto& p : poses.poses) pose_of[p.frame_index] = &p;

  const int w = static_cast<int>(sequence.geometry.size[0]), h = static_cast<int>(sequence.geometry.size[1]);
  std::vector<NWireSegmentation> segs(sequence.frames.size());
  std::atomic<std::size_t> next{0};
  std::exception_ptr failure;
  std::mutex failure_mutex;
  const auto worker = [&] {
    for (std::size_t i = next++; i < sequence.frames.size(); i = next++) {
      try {
        const auto pixels = toMfPixels(sequence, sequence.frames[i]);
        segs[i] = segmentNWires({w, h, pixels}, phantom, options);
      } catch (...) {
        const std::lock_guard lock(failure_mutex);
        if (!failure) failure = std::current_exception();
      }
    }
  };
  unsigned n = threads ? threads : std::max(1u, std::thread::hardware_concurrency());
  n = std::min<unsigned>(n, static_cast<unsigned>(std::max<std::size_t>(sequence.frames.size(), 1)));
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < n; ++t) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);

  for (std::size_t i = 0; i < sequence.frames.size(); ++i) {
    FrameSegmentationReport r;
    r.frame_index = i;
    r.status = segs[i].status;
    r.pose_valid = pose_of[i] != nullptr;
    r.reason = segs[i].reason;
    if (segs[i].ok()) ++out.segmented_frames;
    if (!r.pose_valid) {
      ++out.frames_without_pose;
      if (r.reason.empty()) r.reason = probe_to_reference + " is missing or invalid in this frame";
    }
    if (segs[i].ok() && r.pose_valid) {
      CalibrationFrame f;
      f.frame_index = i;
      f.wire_points_px = segs[i].wire_points_px;
      f.reference_T_probe = pose_of[i]->to_T_from;
      out.frames.push_back(std::move(f));
    }
    out.reports.push_back(std::move(r));
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

Eigen::Isometry3d phantomToReference(const io::DeviceSetConfiguration& config) {
  const auto t = config.findTransform("Phantom", "Reference");
  if (!t) {
    throw FormatError(
        config.source +
        ": no PhantomToReference in CoordinateDefinitions; register the phantom (register-phantom) first");
  }
  return orthonormalize(t->to_T_from);
}

std::vector<std::string> wireNames(const io::PhantomDefinition& phantom) {
  std::vector<std::string> names;
  for (const auto& p : phantom.patterns) {
    for (const auto& w : p.wires) names.push_back(w.name);
  }
  return names;
}

ProbeCalibrationRun calibrateProbe(const io::DeviceSetConfiguration& config, const TrackedSequence& calibration,
                                   const TrackedSequence& validation, const SpatialCalibrationOptions& options) {
  return calibrateProbe(config, calibration, validation, options, TrackerLagOptions{});
}

namespace {

std::vector<double> frameTimes(const TrackedSequence& sequence) {
  std::vector<double> t;
  t.reserve(sequence.frames.size());
  for (const auto& f : sequence.frames) t.push_back(f.timestamp);
  return t;
}

// A sequence's video timestamps and probe poses, read once for the lag
// search and the re-pairing.
struct SequenceTiming {
  std::vector<double> frame_times_s;
  std::vector<FramePose> reference_T_probe;
};

SequenceTiming timingOf(const TrackedSequence& sequence) {
  return {frameTimes(sequence), extractFramePoses(sequence.frames, "ProbeToReference").poses};
}

// The segmented frames paired with the pose at (video time + lag); as they
// are when there is no lag to apply.
std::vector<CalibrationFrame> shifted(const SequenceSegmentation& seg, const SequenceTiming& timing, double lag_s) {
  if (lag_s == 0.0) return seg.frames;
  return pairWithTrackerLag(seg.frames, timing.frame_times_s, timing.reference_T_probe, lag_s);
}

// The lag search run beside a calibration at another lag: the curve's
// sample nearest the applied lag is the like-for-like error to compare with.
TrackerLagCheck checkTrackerLag(const std::vector<CalibrationFrame>& frames, const SequenceTiming& timing,
                                const std::vector<NWirePattern>& patterns, const Eigen::Isometry3d& reference_T_phantom,
                                const SpatialCalibrationOptions& options, const TrackerLagOptions& lag) {
  TrackerLagCheck check;
  TrackerLagOptions search = lag;
  search.estimate = true;
  // The search grid lies around 0: the applied lag must be on it to compare like with like.
  if (std::abs(lag.lag_s) > search.search_half_range_s - search.search_step_s) {
    check.estimate.note = "the applied lag (" + formatGeneral(lag.lag_s * 1e3, 4) +
                          " ms) lies outside the lag check's search range (+-" +
                          formatGeneral(search.search_half_range_s * 1e3, 4) + " ms): widen the range to check it";
    return check;
  }
  try {
    check.estimate = estimateTrackerLag(frames, timing.frame_times_s, timing.reference_T_probe, patterns,
                                        reference_T_phantom, options, search);
  } catch (const ComputationError& e) {
    check.estimate.note = e.what();
    return check;
  }
  const auto& curve = check.estimate.curve;
  const auto nearest = [&](double t) {
    return std::min_element(curve.begin(), curve.end(), [t](const LagSample& a, const LagSample& b) {
      return std::abs(a.lag_s - t) < std::abs(b.lag_s - t);
    });
  };
  check.error_at_estimate_mm = nearest(check.estimate.lag_s)->reprojection_3d_mean_mm;
  check.error_as_applied_mm = nearest(lag.lag_s)->reprojection_3d_mean_mm;
  const double gain = 1.0 - check.error_at_estimate_mm / std::max(check.error_as_applied_mm, 1e-12);
  check.significant =
      std::abs(check.estimate.lag_s - lag.lag_s) > search.search_step_s && gain > TrackerLagCheck::kSignificantGain;
  if (check.significant) {
    check.advice =
        "the calibration sweep fits best with a tracker lag of " + formatGeneral(check.estimate.lag_s * 1e3, 3) +
        " ms (calibration error " + formatGeneral(check.error_at_estimate_mm, 3) + " mm against " +
        formatGeneral(check.error_as_applied_mm, 3) + " mm at the applied " + formatGeneral(lag.lag_s * 1e3, 3) +
        " ms): calibrate the tracker lag (temporal calibration) or apply the estimate";
  }
  return check;
}

}  // namespace

ProbeCalibrationRun calibrateProbe(const io::DeviceSetConfiguration& config, const TrackedSequence& calibration,
                                   const TrackedSequence& validation, const SpatialCalibrationOptions& options,
                                   const TrackerLagOptions& lag) {
  const auto start = std::chrono::steady_clock::now();
  const auto& phantom = config.requirePhantom();
  const auto patterns = nwireGeometry(phantom);
  const auto reference_T_phantom = phantomToReference(config);
  const auto seg_options =
      config.segmentation ? segmentationOptionsFrom(*config.segmentation) : NWireSegmentationOptions{};
  ProbeCalibrationRun run;
  run.calibration = segmentCalibrationSequence(calibration, phantom, seg_options);
  run.validation = segmentCalibrationSequence(validation, phantom, seg_options);
  const SequenceTiming calibration_timing = timingOf(calibration);
  try {
    run.tracker_lag =
        estimateTrackerLag(run.calibration.frames, calibration_timing.frame_times_s,
                           calibration_timing.reference_T_probe, patterns, reference_T_phantom, options, lag);
  } catch (const ComputationError& e) {
    if (!lag.estimate || !lag.fall_back_to_zero) throw;
    run.tracker_lag = TrackerLagEstimate{};
    run.tracker_lag.note = std::string("no tracker lag applied: ") + e.what();
    logger()->warn("{}", run.tracker_lag.note);
  }
  if (lag.check && !lag.estimate) {
    run.tracker_lag_check =
        checkTrackerLag(run.calibration.frames, calibration_timing, patterns, reference_T_phantom, options, lag);
  }
  const auto calibration_frames = shifted(run.calibration, calibration_timing, run.tracker_lag.lag_s);
  const auto validation_frames = shifted(run.validation, timingOf(validation), run.tracker_lag.lag_s);
  run.calibration_frames_paired = calibration_frames.size();
  run.validation_frames_paired = validation_frames.size();
  run.result = calibrateSpatial(calibration_frames, patterns, reference_T_phantom, options);
  // The calibration report again with the wire names (on the frames used).
  std::vector<CalibrationFrame> used;
  for (const auto& f : calibration_frames) {
    if (!std::binary_search(run.result.rejected_frames.begin(), run.result.rejected_frames.end(), f.frame_index)) {
      used.push_back(f);
    }
  }
  run.result.calibration =
      evaluateSpatialCalibration(run.result.probe_T_image, used, patterns, reference_T_phantom, wireNames(phantom));
  if (validation_frames.empty()) {
    throw ComputationError("no validation frame could be segmented with a valid probe pose (" +
                           std::to_string(run.validation.total_frames) + " frames)");
  }
  run.validation_errors = evaluateSpatialCalibration(run.result.probe_T_image, validation_frames, patterns,
                                                     reference_T_phantom, wireNames(phantom));
  run.validation_paired = validation_frames;
  run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return run;
}

}  // namespace mrsns::ultrasound
