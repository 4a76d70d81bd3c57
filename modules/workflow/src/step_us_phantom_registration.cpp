// The N-wire phantom's registration to its reference (PLUS fCal's "phantom
// registration"): the operator touches the landmarks of the phantom's
// definition with the calibrated stylus, each captured when the tip holds
// still. Touches are matched to the landmarks by their geometry, so the order
// does not matter and a stray touch is ignored; PhantomToReference is the
// paired-point registration of the matched touches. Live, the tracking is
// recorded into the session first; the same step with source=file finds the
// held-still moments in that recording, or in a PLUS recording of landmark
// touches, and gives the same numbers.
#include <sstream>

#include "landmark_touch_step.h"
#include "live_tracking_recording.h"
#include "mrsns/core/data_dir.h"
#include "mrsns/core/error.h"
#include "mrsns/core/format.h"
#include "mrsns/io/device_set.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/io/transform_io.h"
#include "registration_acquisition.h"
#include "step_internal.h"

namespace mrsns::workflow::detail {

namespace {

constexpr const char* kPhantomConfig = "plus/PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml";

io::DeviceSetConfiguration phantomConfig(const Params& p) {
  std::filesystem::path path;
  if (p.has("config")) {
    path = p.text("config", "");
    if (!std::filesystem::exists(path)) {
      throw FileError("us-phantom-registration: config '" + path.string() + "' does not exist");
    }
  } else if (auto found = findDataFile(kPhantomConfig)) {
    path = *found;
  } else {
    throw FileError(std::string("us-phantom-registration: the device set '") + kPhantomConfig +
                    "' is not in the data directory '" + dataDirectory().string() +
                    "': set MRSNS_DATA_DIR or give config (a PLUS device set with a PhantomDefinition)");
  }
  auto config = io::readDeviceSet(path);
  if (config.requirePhantom().landmarks.size() < 3) {
    throw InvalidArgumentError("us-phantom-registration: the phantom of " + path.string() + " defines " +
                               std::to_string(config.phantom->landmarks.size()) +
                               " landmarks; at least 3 are needed");
  }
  return config;
}

std::string phantomProgress(const RegistrationAcquisition& a, const RegistrationTargets& t, const std::string& tool) {
  std::ostringstream s;
  s << "touch the phantom's landmarks with the " << tool << " tip, holding each still for a second: " << a.matched
    << " of " << t.labels.size() << " matched";
  if (a.landmarks) s << " (FRE " << formatFixed(a.landmarks->fre_rms_mm, 2) << " mm)";
  s << ", " << a.captures.size() << " touches";
  if (a.matched >= 3) s << "; still to touch: " << untouchedLabels(a, t);
  return s.str();
}

}  // namespace

StepResult runUsPhantomRegistration(Session& session, const Json& params, const StepContext& context) {
  const Params p("us-phantom-registration", params,
                 {"source", "host", "port", "recording", "config", "tool", "duration_s",
                  "connect_timeout_s", "dwell_s", "dwell_radius_mm", "match_tolerance_mm", "min_landmarks"});
  checkCancel(context);  // cancelled before it started: nothing to check or acquire
  // The phantom's marker is the device set's Reference: PhantomToReference is what the calibration reads.
  const std::string tool = p.text("tool", "Stylus"), reference = "Reference";
  if (tool.empty() || tool == reference) {
    throw InvalidArgumentError("us-phantom-registration: tool must name the stylus (Stylus), not the Reference");
  }
  RegistrationAcquisitionOptions a;
  a.transform = tool + "To" + reference;
  a.dwell_s = p.number("dwell_s", a.dwell_s);
  a.dwell_radius_mm = p.number("dwell_radius_mm", a.dwell_radius_mm);
  // The phantom is machined: a touch more than 3 mm from where the others put its landmark is not that landmark.
  a.match_tolerance_mm = p.number("match_tolerance_mm", 3.0);
  if (!(a.dwell_s >= 0.2) || !(a.dwell_radius_mm > 0.0) || !(a.match_tolerance_mm > 0.0)) {
    throw InvalidArgumentError(
        "us-phantom-registration: dwell_s must be >= 0.2 s, dwell_radius_mm and match_tolerance_mm > 0");
  }
  const auto config = phantomConfig(p);
  const auto& phantom = *config.phantom;
  RegistrationTargets targets;
  for (const auto& l : phantom.landmarks) {
    targets.labels.push_back(l.name);
    targets.fiducials_ct.push_back(l.position_phantom);
  }
  const int n = static_cast<int>(targets.labels.size());
  const int min_landmarks = p.integer("min_landmarks", n);
  if (min_landmarks < 3 || min_landmarks > n) {
    throw InvalidArgumentError("us-phantom-registration: min_landmarks must be in [3, " + std::to_string(n) +
                               "] (the phantom's landmarks)");
  }
  a.tip_marker = calibratedTip(session, tool, "us-phantom-registration");
  const std::string source = p.text("source", "plus");

  StepResult result;
  std::vector<TrackedFrame> frames;
  std::string recording;
  Json recorded;
  if (source == "plus") {
    const LiveTrackingOptions live =
        touchRecordingOptions(session, p, "us-phantom-registration", "PhantomLandmarks", 120.0, recording);
    context.report(0.05, "connecting to the tracker at " + live.host + ":" + std::to_string(live.port));
    auto last = std::chrono::steady_clock::now() - std::chrono::seconds(1);
    std::string shown;
    bool done = false;
    const auto monitor = [&](const std::vector<TrackedFrame>& so_far, std::string& message) {
      const auto now = std::chrono::steady_clock::now();
      if (now - last >= std::chrono::milliseconds(500)) {
        last = now;
        try {
          const auto state = analyseRegistrationFrames(so_far, targets, a);
          shown = !so_far.empty() && state.frames_without_pose + 30 <= so_far.size()
                      ? phantomProgress(state, targets, tool)
                      : a.transform + " not tracked: bring the " + tool + " and the " + reference +
                            " markers into the camera's view";
          done = state.matched == n;
        } catch (const FrameError&) {
          shown = a.transform + " not tracked yet: the stream has no " + tool + " or no " + reference;
        }
      }
      message = shown;
      return done;
    };
    auto r = recordLiveTracking(live, monitor, context);
    recorded = recordedFigures(r, recording, live);
    frames = std::move(r.frames);
    result.figures["simulated"] = fromSimulatedRoom(r.device_identity);
    result.outputs.push_back(recording);
  } else if (source == "file") {
    for (const char* key : {"host", "port", "duration_s", "connect_timeout_s"}) {
      if (p.has(key)) throw InvalidArgumentError(std::string("us-phantom-registration: ") + key + " is for source=plus");
    }
    if (!p.has("recording")) {
      throw InvalidArgumentError("us-phantom-registration: source=file needs recording (a PLUS sequence with " +
                                 a.transform + " or the transforms it is computed from)");
    }
    recording = p.text("recording", "");
    frames = io::readSequenceHeader(recordingPath(session, recording), {}).frames;
    recorded = {{"file", recording}, {"frames", frames.size()}};
  } else {
    throw InvalidArgumentError("us-phantom-registration: source must be plus (live) or file, not '" + source + "'");
  }
  checkCancel(context);
  context.report(0.8, "matching the touches to the phantom's landmarks");
  const auto acq = analyseRegistrationFrames(frames, targets, a);
  recorded["frames_without_pose"] = acq.frames_without_pose;
  result.figures["recorded"] = recorded;
  result.figures["source"] = source;
  result.figures["transform"] = a.transform;
  result.figures["phantom"] = phantom.name;
  result.figures["offline_command"] = "mrsns-cli session run " + session.folder().string() +
                                      " us-phantom-registration --param source=file --param recording=" +
                                      recordingPath(session, recording).string();
  Json landmarks = Json::array();
  for (std::size_t f = 0; f < targets.labels.size(); ++f) {
    const int c = acq.capture_of_fiducial[f];
    const auto& q = targets.fiducials_ct[f];
    Json entry = {{"name", targets.labels[f]}, {"phantom_mm", {q.x(), q.y(), q.z()}}, {"touched", c >= 0}};
    if (c >= 0) {
      const auto& cap = acq.captures[static_cast<std::size_t>(c)];
      entry["reference_mm"] = {cap.tip_patient.x(), cap.tip_patient.y(), cap.tip_patient.z()};
      entry["hold_s"] = cap.end_s - cap.start_s;
    }
    landmarks.push_back(entry);
  }
  int unmatched = 0;
  for (const auto& cap : acq.captures) unmatched += cap.fiducial < 0 ? 1 : 0;
  result.figures["touches"] = acq.captures.size();
  result.figures["unmatched_touches"] = unmatched;
  result.figures["matched"] = acq.matched;
  const std::string kept = " (the recording is kept: " + recording + ")";
  if (acq.matched < min_landmarks) {
    result.figures["landmarks"] = landmarks;
    result.ok = false;
    result.summary = std::to_string(acq.matched) + " of " + std::to_string(n) + " phantom landmarks matched from " +
                     std::to_string(acq.captures.size()) + " touches, " + std::to_string(min_landmarks) + " needed" +
                     (acq.matched >= 3 ? "; not touched: " + untouchedLabels(acq, targets) : std::string()) + kept;
    return result;
  }
  const auto& pp = *acq.landmarks;
  std::vector<std::string> matched_labels;
  for (std::size_t f = 0; f < acq.capture_of_fiducial.size(); ++f) {
    if (acq.capture_of_fiducial[f] >= 0) matched_labels.push_back(targets.labels[f]);
  }
  Json suspects = Json::array();
  for (int i : pp.suspect_points) {
    suspects.push_back({{"name", matched_labels[static_cast<std::size_t>(i)]},
                        {"leave_one_out_mm", pp.leave_one_out_mm[static_cast<std::size_t>(i)]}});
  }
  std::size_t k = 0;
  for (auto& entry : landmarks) {
    if (entry["touched"].get<bool>()) entry["fre_mm"] = pp.fre_mm[k++];
  }
  const Eigen::Isometry3d& reference_T_phantom = acq.landmark_patient_T_ct;
  const std::string output = "us-phantom-registration/PhantomToReference.tfm";
  std::filesystem::create_directories(session.resolve("us-phantom-registration"));
  // The node PhantomToReference (io/transform_io.h: the .tfm holds the inverse of its ToParent).
  io::writeChildToParent(reference_T_phantom.matrix(), session.resolve(output));
  result.outputs.push_back(output);
  result.figures["landmarks"] = landmarks;
  result.figures["fre_rms_mm"] = pp.fre_rms_mm;
  result.figures["fle_estimate_mm"] = pp.fle_rms_estimate_mm;
  result.figures["suspects"] = suspects;
  result.figures["transforms"] = {{"PhantomToReference", matrixJson(reference_T_phantom.matrix())}};
  result.ok = true;
  std::ostringstream s;
  s << "PhantomToReference from " << acq.matched << " of " << n << " landmarks, FRE "
    << formatFixed(pp.fre_rms_mm, 2) << " mm";
  if (unmatched > 0) s << "; " << unmatched << " touches matched no landmark and were ignored";
  if (!suspects.empty()) {
    s << "; suspect: " << suspects[0]["name"].get<std::string>() << " ("
      << formatFixed(suspects[0]["leave_one_out_mm"].get<double>(), 1)
      << " mm from where the others put it): touch it again";
  }
  if (acq.matched < n) s << "; not touched: " << untouchedLabels(acq, targets);
  if (acq.frames_without_pose > 0) {
    s << "; " << acq.frames_without_pose << " frames without " << a.transform << " left out";
  }
  result.summary = s.str();
  return result;
}

}  // namespace mrsns::workflow::detail
