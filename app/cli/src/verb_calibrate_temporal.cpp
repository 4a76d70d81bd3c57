// `mrsns-cli calibrate-temporal`: lag between the tracker and video streams
// of PLUS recordings (probe moved up and down over a flat target).
#include <algorithm>
#include <sstream>
#include <vector>

#include "cli_context.h"
#include "mrsns/core/error.h"
#include "mrsns/core/frame_poses.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/ultrasound/temporal_calibration.h"

namespace mrsns::cli {
namespace {

struct CalibrateTemporalOptions {
  std::string tracker;
  std::string video;
  std::string sequence;
  std::string transform = "ProbeToReference";
  double max_lag_ms = 2000.0;
  std::vector<int> clip;  // x y width height, MF pixels
};

std::vector<FramePose> probePoses(const TrackedSequence& s, const std::string& name, std::string& used) {
  const auto names = s.transformNames();
  // PLUS tracker buffers often hold ProbeToTracker only: fall back to it.
  used = name;
  if (name == "ProbeToReference" && std::find(names.begin(), names.end(), "ReferenceToTracker") == names.end() &&
      std::find(names.begin(), names.end(), "ProbeToReference") == names.end()) {
    used = "ProbeToTracker";
  }
  return extractFramePoses(s.frames, used).poses;
}

Report run(const CalibrateTemporalOptions& options) {
  const bool combined = !options.sequence.empty() && options.tracker.empty() && options.video.empty();
  const bool separate = options.sequence.empty() && !options.tracker.empty() && !options.video.empty();
  if (!combined && !separate) {
    throw InvalidArgumentError("give either --tracker SEQ and --video SEQ, or --sequence SEQ");
  }
  std::string used;
  std::vector<FramePose> poses;
  TrackedSequence video;
  if (!options.sequence.empty()) {
    video = io::readSequence(options.sequence);
    poses = probePoses(video, options.transform, used);
  } else {
    poses = probePoses(io::readSequenceHeader(options.tracker), options.transform, used);
    video = io::readSequence(options.video);
  }
  ultrasound::TemporalCalibrationOptions cal;
  cal.max_lag_s = options.max_lag_ms / 1000.0;
  ultrasound::LineSignalOptions line;
  if (!options.clip.empty()) {
    line.clip_x = options.clip[0];
    line.clip_y = options.clip[1];
    line.clip_width = options.clip[2];
    line.clip_height = options.clip[3];
  }
  const auto video_signal = ultrasound::videoLineSignal(video, line);
  const auto r = ultrasound::calibrateTemporal(ultrasound::trackerPositionSignal(poses), video_signal, cal);
  Report report;
  report.json = Json{{"verb", "calibrate-temporal"},
                     {"transform", used},
                     {"tracker_lag_ms", r.tracker_lag_s * 1000.0},
                     {"tracker_lag_sign", "positive when the tracker data lags the video (PLUS TrackerLagSec)"},
                     {"correlation", r.correlation},
                     {"polarity", r.polarity},
                     {"tracker_samples", r.tracker_samples},
                     {"video_samples", r.video_samples},
                     {"video_frames", video.frames.size()},
                     {"tracker_motion_rms_mm", r.tracker_motion_rms},
                     {"video_motion_rms_px", r.video_motion_rms}};
  std::ostringstream text;
  text << "Tracker lag: " << r.tracker_lag_s * 1000.0 << " ms (> 0 when the tracker data lags the video), NCC "
       << r.correlation << "\n  " << r.tracker_samples << " tracker samples (" << used << "), line found in "
       << r.video_samples << " of " << video.frames.size() << " video frames; motion " << r.tracker_motion_rms
       << " mm / " << r.video_motion_rms << " px RMS\n";
  report.text = text.str();
  return report;
}

}  // namespace

void registerCalibrateTemporalVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto opts = std::make_shared<CalibrateTemporalOptions>();
  auto* sub = app.add_subcommand(
      "calibrate-temporal",
      "Lag between tracker and video (probe moved up and down over a flat target): probe position vs the target "
      "line's depth in the image, normalised cross-correlation; prints tracker_lag_ms with PLUS's sign");
  sub->add_option("--tracker", opts->tracker, "sequence of the tracker buffer (probe transforms)");
  sub->add_option("--video", opts->video, "sequence of the video buffer (B-mode frames)");
  sub->add_option("--sequence", opts->sequence, "one sequence holding both the frames and the probe transforms");
  sub->add_option("--transform", opts->transform, "probe transform (falls back to ProbeToTracker)")
      ->capture_default_str();
  sub->add_option("--max-lag-ms", opts->max_lag_ms, "lags searched in [-max, max]")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  sub->add_option("--clip-rectangle", opts->clip,
                  "X Y WIDTH HEIGHT: look for the target line only there (MF image pixels), e.g. below the "
                  "transducer's ringing")
      ->expected(4)
      ->check(CLI::NonNegativeNumber);
  addJsonFlag(*sub, options);
  verbs.emplace_back(sub, [opts] { return run(*opts); });
}

}  // namespace mrsns::cli
