// us-temporal-calibration with source=plus: PLUS's temporal calibration
// acquired live. The operator moves the tracked probe up and down over a flat
// target (the bottom of a water tank); the step records the tracker's own
// samples and every video frame from the PlusServer (or mrsns-sim) into the
// session, each stream with its own timestamps, and finds the lag between
// them as `mrsns-cli calibrate-temporal --tracker --video` does on the same
// files.
#include <algorithm>
#include <sstream>

#include "live_tracking_recording.h"
#include "live_us_recording.h"
#include "mrsns/core/error.h"
#include "mrsns/core/format.h"
#include "mrsns/core/frame_poses.h"
#include "mrsns/io/sequence_appender.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/ultrasound/temporal_calibration.h"
#include "step_internal.h"

namespace mrsns::workflow::detail {

namespace {

// ProbeToReference when the reference was tracked, else ProbeToTracker (as calibrate-temporal falls back).
std::string probeTransform(const std::vector<TrackedFrame>& frames, const std::string& wanted) {
  if (wanted != "ProbeToReference") return wanted;
  for (const auto& f : frames) {
    if (f.transforms.count("ReferenceToTracker") != 0 || f.transforms.count("ProbeToReference") != 0) return wanted;
  }
  return "ProbeToTracker";
}

}  // namespace

StepResult runLiveTemporalCalibration(Session& session, const Params& p, const StepContext& context) {
  LiveUsRecordingOptions o;
  sessionPlusServer(session, p, o.host, o.port);
  o.max_duration_s = p.number("duration_s", 15.0);
  o.idle_stop_s = p.number("idle_stop_s", o.idle_stop_s);
  o.connect_timeout_s = p.number("connect_timeout_s", o.connect_timeout_s);
  const std::string wanted = p.text("transform", "ProbeToReference");
  ultrasound::TemporalCalibrationOptions cal;
  cal.max_lag_s = p.number("max_lag_ms", 2000.0) * 1e-3;
  if (!(o.max_duration_s > 0.0 && o.max_duration_s <= 600.0) || !(o.idle_stop_s > 0.0) ||
      !(o.connect_timeout_s > 0.0) || !(cal.max_lag_s > 0.0)) {
    throw InvalidArgumentError(
        "us-temporal-calibration: duration_s must be in (0, 600] s; idle_stop_s, connect_timeout_s and max_lag_ms > 0");
  }
  context.report(0.05, "recording from " + o.host + ":" + std::to_string(o.port) +
                           ": move the probe up and down over the flat target, about 1 cm once a second");
  const auto live = recordLiveUltrasound(o, context);
  // Both streams into the session before anything is computed: a failed calibration keeps them.
  const std::string video_file = freeSessionName(session, "us-temporal-calibration", "temporal_video", ".igs.mha");
  io::writeSequence(session.resolve(video_file), live.sequence);
  const std::string tracker_file = freeSessionName(session, "us-temporal-calibration", "temporal_tracker", ".mhd");
  {
    io::SequenceAppender tracker(session.resolve(tracker_file), io::SequenceAppender::trackerOnlyLayout());
    for (const auto& f : live.tracker_frames) {
      if (!tracker.append(f)) throw FileError("recording the tracker buffer failed: " + tracker.lastError());
    }
    if (!tracker.sync()) throw FileError("recording the tracker buffer failed: " + tracker.lastError());
  }
  checkCancel(context);

  StepResult result;
  result.outputs = {video_file, tracker_file};
  const std::string transform = probeTransform(live.tracker_frames, wanted);
  const bool simulated = fromSimulatedRoom(live.device_identity);
  result.figures["simulated"] = simulated;
  result.figures["recorded"] = {{"video", video_file},
                                {"tracker", tracker_file},
                                {"video_frames", live.sequence.frames.size()},
                                {"tracker_frames", live.tracker_frames.size()},
                                {"frames_refused", live.frames_refused},
                                {"seconds", live.seconds},
                                {"device_identity", live.device_identity},
                                {"host", o.host},
                                {"port", o.port}};
  result.figures["transform"] = transform;
  result.figures["offline_command"] = "mrsns-cli calibrate-temporal --tracker " +
                                      session.resolve(tracker_file).string() + " --video " +
                                      session.resolve(video_file).string() + " --transform " + transform +
                                      " --max-lag-ms " + formatFixed(cal.max_lag_s * 1e3, 0);
  context.report(0.6, "finding the lag between the tracked motion and the target's line in the video");
  const auto poses = extractFramePoses(live.tracker_frames, transform).poses;
  ultrasound::TemporalCalibrationResult r;
  try {
    r = ultrasound::calibrateTemporal(ultrasound::trackerPositionSignal(poses),
                                      ultrasound::videoLineSignal(live.sequence), cal);
  } catch (const ComputationError& e) {
    result.ok = false;
    result.summary = std::string(e.what()) + " (the recordings are kept: " + video_file + ", " + tracker_file + ")";
    return result;
  }
  result.ok = true;
  result.figures["tracker_lag_ms"] = r.tracker_lag_s * 1e3;
  result.figures["tracker_lag_sign"] = "positive when the tracker data lags the video (PLUS TrackerLagSec)";
  result.figures["correlation"] = r.correlation;
  result.figures["polarity"] = r.polarity;
  result.figures["tracker_samples"] = r.tracker_samples;
  result.figures["video_samples"] = r.video_samples;
  result.figures["tracker_motion_rms_mm"] = r.tracker_motion_rms;
  result.figures["video_motion_rms_px"] = r.video_motion_rms;
  Json curve = Json::array();
  for (std::size_t i = 0; i < r.lags_s.size() && i < r.correlations.size(); ++i) {
    curve.push_back(Json{{"lag_ms", r.lags_s[i] * 1e3}, {"correlation", r.correlations[i]}});
  }
  result.figures["curve"] = curve;
  std::ostringstream s;
  s << "tracker lag " << formatFixed(r.tracker_lag_s * 1e3, 1) << " ms (NCC " << formatFixed(r.correlation, 3)
    << ") from " << live.sequence.frames.size() << " video frames and " << r.tracker_samples << " "
    << transform << " samples recorded live";
  result.summary = s.str();
  return result;
}

}  // namespace mrsns::workflow::detail
