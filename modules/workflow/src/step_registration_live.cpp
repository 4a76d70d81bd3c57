// Patient registration acquired from the tracker, as a navigation system does
// it: the operator touches the fiducial screws with the calibrated stylus
// (each captured when the tip holds still; no order needed: the touches are
// matched to the fiducials found in the CT by their geometry), then sweeps
// the tip over the exposed bone; landmarks start the surface registration
// (ICP). The stream is recorded into the session first, so the same step with
// source=file recomputes it from the recording with the same numbers.
#include <Eigen/Geometry>
#include <chrono>
#include <memory>
#include <optional>
#include <filesystem>
#include <sstream>

#include "landmark_touch_step.h"
#include "live_tracking_recording.h"
#include "mrsns/core/error.h"
#include "mrsns/core/format.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/registration/paired_point.h"
#include "mrsns/registration/surface_registration.h"
#include "registration_acquisition.h"
#include "registration_ct.h"
#include "mrsns/core/mesh_locator.h"
#include "step_internal.h"

namespace mrsns::workflow::detail {

namespace {

struct LiveRegistrationOptions {
  std::string tool = "Stylus";
  std::string reference = "Patient";
  int min_landmarks = 4;
  int surface_points = 200;
  int min_surface_points = 30;
  double idle_s = 1.5;
  double max_correspondence_mm = 5.0;
};

/// What the operator sees while working.
std::string progressText(const RegistrationAcquisition& a, const RegistrationTargets& t,
                         const LiveRegistrationOptions& o) {
  std::ostringstream s;
  const auto n = t.fiducials_ct.size();
  if (a.matched < static_cast<int>(n)) {
    s << "touch each fiducial screw with the " << o.tool << " tip and hold it still for a second: " << a.matched
      << " of " << n << " matched";
    if (a.landmarks) s << " (FRE " << formatFixed(a.landmarks->fre_rms_mm, 2) << " mm)";
    s << ", " << a.captures.size() << " touches";
    if (a.matched >= 3) s << "; still to touch: " << untouchedLabels(a, t);
  } else {
    s << "all " << n << " fiducials matched (FRE " << formatFixed(a.landmarks->fre_rms_mm, 2)
      << " mm): sweep the tip over the exposed bone, then lift it: " << a.surface_patient.size() << " of "
      << o.surface_points << " surface points";
  }
  return s.str();
}


}  // namespace

StepResult runAcquiredRegistration(Session& session, const Json& params, const StepContext& context) {
  const Params p("registration",
                 params, {"source", "host", "port", "recording", "connect_timeout_s", "duration_s", "tool", "reference",
                          "dwell_s", "dwell_radius_mm", "match_tolerance_mm", "min_landmarks",
                          "surface_points", "surface_gate_mm", "idle_s"});
  LiveRegistrationOptions o;
  o.tool = p.text("tool", o.tool);
  o.reference = p.text("reference", o.reference);
  o.min_landmarks = p.integer("min_landmarks", o.min_landmarks);
  o.surface_points = p.integer("surface_points", o.surface_points);
  o.idle_s = p.number("idle_s", o.idle_s);
  RegistrationAcquisitionOptions a;
  a.transform = o.tool + "To" + o.reference;
  a.dwell_s = p.number("dwell_s", a.dwell_s);
  a.dwell_radius_mm = p.number("dwell_radius_mm", a.dwell_radius_mm);
  a.match_tolerance_mm = p.number("match_tolerance_mm", a.match_tolerance_mm);
  a.surface_gate_mm = p.number("surface_gate_mm", a.surface_gate_mm);
  if (o.tool.empty() || o.reference.empty() || o.tool == o.reference) {
    throw InvalidArgumentError("registration: tool and reference must be two tool names (Stylus, Patient)");
  }
  if (o.min_landmarks < 3 || o.surface_points < 0 || !(o.idle_s > 0.0) || !(a.dwell_s >= 0.2) ||
      !(a.dwell_radius_mm > 0.0) || !(a.match_tolerance_mm > 0.0) || !(a.surface_gate_mm > 0.0)) {
    throw InvalidArgumentError(
        "registration: min_landmarks must be >= 3, surface_points >= 0, idle_s > 0, dwell_s >= 0.2 s, and "
        "dwell_radius_mm, match_tolerance_mm, surface_gate_mm > 0");
  }
  a.tip_marker = calibratedTip(session, o.tool, "registration");
  const std::string source = p.text("source", "plus");
  if (source != "plus" && source != "file") {
    throw InvalidArgumentError("registration: source must be plus (live), file or simulated, not '" + source + "'");
  }

  // The session's CT: its bone models and fiducials are what the touches are matched and fitted to.
  context.report(0.02, "reading the CT's bone models and fiducials");
  const SessionRegistrationTargets anatomy = sessionRegistrationTargets(session, "registration");
  const MeshLocator bone_locator(anatomy.bone);
  RegistrationTargets targets;
  targets.labels = anatomy.labels;
  targets.fiducials_ct = anatomy.fiducials_ct;
  targets.fiducial_axes_ct = anatomy.fiducial_axes_ct;
  targets.bone = &bone_locator;
  if (static_cast<int>(targets.fiducials_ct.size()) < o.min_landmarks) {
    throw InvalidArgumentError("registration: the session's CT has " + std::to_string(targets.fiducials_ct.size()) +
                               " fiducial(s) and min_landmarks is " + std::to_string(o.min_landmarks) +
                               ": find or place more fiducials (find-fiducials, place-fiducial), or lower min_landmarks");
  }

  StepResult result;
  std::vector<TrackedFrame> frames;
  std::string recording;
  Json recorded;
  if (source == "plus") {
    const LiveTrackingOptions live =
        touchRecordingOptions(session, p, "registration", "PatientRegistration", 180.0, recording);
    context.report(0.1, "connecting to the tracker at " + live.host + ":" + std::to_string(live.port));
    // The analysis of everything so far, twice a second: feedback and the end of the acquisition.
    auto last = std::chrono::steady_clock::now() - std::chrono::seconds(1);
    std::string shown;
    bool done = false;
    const auto monitor = [&](const std::vector<TrackedFrame>& so_far, std::string& message) {
      const auto now = std::chrono::steady_clock::now();
      if (now - last >= std::chrono::milliseconds(500)) {
        last = now;
        try {
          const auto state = analyseRegistrationFrames(so_far, targets, a);
          if (!so_far.empty() && state.frames_without_pose + 30 <= so_far.size()) {
            shown = progressText(state, targets, o);
          } else {
            shown = a.transform + " not tracked: bring the " + o.tool + " and the " + o.reference +
                    " markers into the camera's view";
          }
          done = state.matched == static_cast<int>(targets.fiducials_ct.size()) &&
                 static_cast<int>(state.surface_patient.size()) >= o.surface_points &&
                 state.last_time_s - state.last_surface_time_s >= o.idle_s;
        } catch (const FrameError&) {
          shown = a.transform + " not tracked yet: the stream has no " + o.tool + " or no " + o.reference;
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
    if (!p.has("recording")) {
      throw InvalidArgumentError("registration: source=file needs recording (a PLUS sequence with " + a.transform +
                                 " or the transforms it is computed from)");
    }
    recording = p.text("recording", "");
    frames = io::readSequenceHeader(recordingPath(session, recording), {}).frames;
    recorded = {{"file", recording}, {"frames", frames.size()}};
  } else {
    throw InvalidArgumentError("registration: source must be plus (live), file or simulated, not '" + source + "'");
  }
  checkCancel(context);
  context.report(0.6, "matching the touches to the CT's fiducials");

  const auto acq = analyseRegistrationFrames(frames, targets, a);
  recorded["frames_without_pose"] = acq.frames_without_pose;
  result.figures["recorded"] = recorded;
  result.figures["source"] = source;
  result.figures["transform"] = a.transform;
  result.figures["tip_marker_mm"] = {a.tip_marker.x(), a.tip_marker.y(), a.tip_marker.z()};
  result.figures["offline_command"] =
      "mrsns-cli session run " + session.folder().string() + " registration --param source=file --param recording=" +
      recordingPath(session, recording).string();
  Json fiducials = Json::array();
  for (std::size_t f = 0; f < targets.fiducials_ct.size(); ++f) {
    const Eigen::Vector3d& position = targets.fiducials_ct[f];
    const int c = acq.capture_of_fiducial[f];
    Json entry = {{"label", targets.labels[f]},
                  {"ct_mm", {position.x(), position.y(), position.z()}},
                  {"ct_confidence", anatomy.confidences[f]},
                  {"touched", c >= 0}};
    if (c >= 0) {
      const auto& cap = acq.captures[static_cast<std::size_t>(c)];
      entry["patient_mm"] = {cap.tip_patient.x(), cap.tip_patient.y(), cap.tip_patient.z()};
      entry["hold_s"] = cap.end_s - cap.start_s;
    }
    fiducials.push_back(entry);
  }
  int unmatched = 0;
  for (const auto& cap : acq.captures) unmatched += cap.fiducial < 0 ? 1 : 0;
  const std::string kept = recording.empty() ? "" : " (the recording is kept: " + recording + ")";
  const std::string left_out =
      acq.frames_without_pose > 0
          ? "; " + std::to_string(acq.frames_without_pose) + " frames without " + a.transform +
                " (stylus or reference not tracked) left out"
          : "";
  if (acq.matched < o.min_landmarks) {
    result.figures["landmarks"] = {{"fiducials", fiducials}, {"touches", acq.captures.size()}, {"matched", acq.matched}};
    result.ok = false;
    result.summary = std::to_string(acq.matched) + " of " + std::to_string(targets.fiducials_ct.size()) +
                     " fiducials matched from " + std::to_string(acq.captures.size()) + " touches, " +
                     std::to_string(o.min_landmarks) + " needed" +
                     (acq.matched >= 3 ? "; not touched: " + untouchedLabels(acq, targets) : std::string()) + left_out +
                     kept;
    return result;
  }
  const auto& pp = *acq.landmarks;
  Json suspects = Json::array();
  std::vector<Eigen::Vector3d> matched_ct;
  std::vector<std::string> matched_labels;
  for (std::size_t f = 0; f < acq.capture_of_fiducial.size(); ++f) {
    if (acq.capture_of_fiducial[f] >= 0) {
      matched_ct.push_back(targets.fiducials_ct[f]);
      matched_labels.push_back(targets.labels[f]);
    }
  }
  for (int i : pp.suspect_points) {
    suspects.push_back({{"label", matched_labels[static_cast<std::size_t>(i)]},
                        {"leave_one_out_mm", pp.leave_one_out_mm[static_cast<std::size_t>(i)]}});
  }
  Json fre_per_point = Json::object();
  for (std::size_t i = 0; i < matched_labels.size(); ++i) fre_per_point[matched_labels[i]] = pp.fre_mm[i];
  result.figures["landmarks"] = {{"fiducials", fiducials},
                                 {"touches", acq.captures.size()},
                                 {"unmatched_touches", unmatched},
                                 {"matched", acq.matched},
                                 {"fre_rms_mm", pp.fre_rms_mm},
                                 {"fre_mm", fre_per_point},
                                 {"fle_estimate_mm", pp.fle_rms_estimate_mm},
                                 {"suspects", suspects}};

  Eigen::Isometry3d patient_T_ct = acq.landmark_patient_T_ct;
  std::string method = "landmarks";
  if (static_cast<int>(acq.surface_patient.size()) >= o.min_surface_points) {
    context.report(0.8, "surface registration (ICP) from the landmarks");
    registration::IcpOptions icp_options;
    icp_options.max_correspondence_distance_mm = o.max_correspondence_mm;
    const auto icp =
        registration::registerSurface(acq.surface_patient, anatomy.bone, acq.landmark_patient_T_ct.inverse(), icp_options);
    result.figures["surface"] = {{"points", acq.surface_patient.size()},
                                 {"rms_mm", icp.rms_mm},
                                 {"iterations", icp.iterations},
                                 {"converged", icp.converged},
                                 {"inlier_fraction", icp.inlier_fraction}};
    if (icp.converged || icp.rms_mm < 1.5) {
      patient_T_ct = icp.fixed_T_moving.inverse();
      method = "landmarks then surface (ICP)";
    }
  } else {
    result.figures["surface"] = {{"points", acq.surface_patient.size()},
                                 {"skipped", "fewer than " + std::to_string(o.min_surface_points) + " surface points"}};
  }
  // Where the landmarks' uncertainty puts the planned screws (Fitzpatrick-West, from the FRE's FLE).
  Json targets_json = Json::array();
  std::vector<double> predicted;
  for (const auto& screw : anatomy.plans) {
    for (const auto& [what, point] : {std::pair{"entry", screw.entry}, std::pair{"target", screw.target}}) {
      predicted.push_back(registration::predictTreRms(matched_ct, point, pp.fle_rms_estimate_mm));
      targets_json.push_back({{"path", screw.name}, {"point", what}, {"tre_predicted_mm", predicted.back()}});
    }
  }
  result.figures["method"] = method;
  result.figures["targets"] = targets_json;
  if (!predicted.empty()) result.figures["tre_predicted_at_screws"] = statsJson(predicted);
  result.figures["ct"] = anatomy.ct_name;
  result.figures["transforms"] = {{"CTToPatient", matrixJson(patient_T_ct.matrix())},
                                  {"CTToPatientLandmarks", matrixJson(acq.landmark_patient_T_ct.matrix())}};
  result.ok = true;
  std::ostringstream s;
  s << acq.matched << " of " << targets.fiducials_ct.size() << " fiducials, FRE " << formatFixed(pp.fre_rms_mm, 2) << " mm";
  if (result.figures["surface"].contains("rms_mm")) {
    s << ", " << acq.surface_patient.size() << " surface points, ICP RMS "
      << formatFixed(result.figures["surface"]["rms_mm"].get<double>(), 2) << " mm";
  }
  if (!predicted.empty()) {
    s << "; predicted TRE at the screws " << formatFixed(result.figures["tre_predicted_at_screws"]["rms"].get<double>(), 2)
      << " mm RMS";
  }
  if (!suspects.empty()) {
    s << "; suspect: " << suspects[0]["label"].get<std::string>() << " ("
      << formatFixed(suspects[0]["leave_one_out_mm"].get<double>(), 1)
      << " mm from where the others put it): touch it again";
  }
  if (acq.matched < static_cast<int>(targets.fiducials_ct.size())) s << "; not touched: " << untouchedLabels(acq, targets);
  s << left_out;
  result.summary = s.str();
  return result;
}

}  // namespace mrsns::workflow::detail
