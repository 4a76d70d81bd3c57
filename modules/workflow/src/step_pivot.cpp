// The pivot-calibration step: the tip of a tracked tool (the stylus, the drill)
// from the operator pivoting it in a divot, acquired live from the session's
// PlusServer (or mrsns-sim) with the swing shown while it is recorded, as
// SlicerIGT's Pivot Calibration and PLUS's fCal do; or recomputed from a PLUS
// recording or a pose CSV. The acquisition is recorded into the session first, so
// `mrsns-cli calibrate-pivot --sequence` on it gives the same tip.
#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "live_tracking_recording.h"
#include "mrsns/core/error.h"
#include "mrsns/core/format.h"
#include "mrsns/core/frame_poses.h"
#include "mrsns/core/units.h"
#include "mrsns/io/pose_csv.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/io/transform_io.h"
#include "mrsns/registration/pivot_calibration.h"
#include "step_internal.h"

namespace mrsns::workflow::detail {

namespace {

struct PivotStepOptions {
  std::string tool = "Stylus";
  std::string reference = "Reference";
  int min_poses = 100;
  double target_swing_deg = 30.0;
  double min_rotation_deg = 20.0;
  bool robust = true;
  double inlier_threshold_mm = 1.0;
  [[nodiscard]] std::string transform() const { return tool + "To" + reference; }
};

std::vector<Eigen::Isometry3d> posesOf(const std::vector<TrackedFrame>& frames, const std::string& transform,
                                       FramePoseExtraction* extraction = nullptr) {
  auto e = extractFramePoses(frames, transform);
  std::vector<Eigen::Isometry3d> poses;
  poses.reserve(e.poses.size());
  for (const auto& p : e.poses) poses.push_back(p.to_T_from);
  if (extraction) *extraction = std::move(e);
  return poses;
}

std::string swingText(const registration::PivotCoverage& c) {
  return formatFixed(c.first_range / kDeg, 0) + " x " + formatFixed(c.second_range / kDeg, 0) + " deg";
}

}  // namespace

namespace {

/// pivot-calibration (the stylus) and drill-calibration (the drill on the robot's flange, pivoted by hand in
/// freedrive): the same acquisition and calibration, each with its own place in the session.
StepResult runPivotStep(Session& session, const Json& params, const StepContext& context, const std::string& step,
                        const std::string& default_tool) {
  const Params p(step, params,
                 {"source", "host", "port", "recording", "tool", "reference", "duration_s", "connect_timeout_s",
                  "min_poses", "target_swing_deg", "min_rotation_deg", "robust", "inlier_threshold_mm"});
  PivotStepOptions o;
  o.tool = p.text("tool", default_tool);
  o.reference = p.text("reference", o.reference);
  o.min_poses = p.integer("min_poses", o.min_poses);
  o.target_swing_deg = p.number("target_swing_deg", o.target_swing_deg);
  o.min_rotation_deg = p.number("min_rotation_deg", o.min_rotation_deg);
  o.robust = p.boolean("robust", o.robust);
  o.inlier_threshold_mm = p.number("inlier_threshold_mm", o.inlier_threshold_mm);
  if (o.tool.empty() || o.reference.empty() || o.tool == o.reference) {
    throw InvalidArgumentError(step + ": tool and reference must be two tool names (Stylus, Reference)");
  }
  if (o.min_poses < 10 || !(o.target_swing_deg > 0.0 && o.target_swing_deg <= 120.0) ||
      !(o.min_rotation_deg > 0.0 && o.min_rotation_deg <= o.target_swing_deg) || !(o.inlier_threshold_mm > 0.0)) {
    throw InvalidArgumentError(
        step + ": min_poses must be >= 10, target_swing_deg in (0, 120], min_rotation_deg in (0, "
        "target_swing_deg], inlier_threshold_mm > 0");
  }
  const std::string transform = o.transform();
  const std::string source = p.text("source", "plus");

  StepResult result;
  std::vector<TrackedFrame> frames;
  std::string recording;
  Json recorded;
  if (source == "plus") {
    if (p.has("recording")) throw InvalidArgumentError(step + ": recording is for source=file");
    LiveTrackingOptions live;
    sessionPlusServer(session, p, live.host, live.port);
    live.max_duration_s = p.number("duration_s", live.max_duration_s);
    live.connect_timeout_s = p.number("connect_timeout_s", live.connect_timeout_s);
    if (!(live.max_duration_s > 0.0 && live.max_duration_s <= 600.0) || !(live.connect_timeout_s > 0.0)) {
      throw InvalidArgumentError(step + ": duration_s must be in (0, 600] s, connect_timeout_s > 0");
    }
    recording = freeSessionName(session, step, o.tool + "Pivot", ".mhd");
    live.recording = session.resolve(recording);
    context.report(0.05, "connecting to the tracker at " + live.host + ":" + std::to_string(live.port) +
                             ": put the " + o.tool + "'s tip in the divot");
    // The operator sees the swing grow and the step ends by itself once it covers two directions.
    const auto monitor = [&](const std::vector<TrackedFrame>& so_far, std::string& message) {
      FramePoseExtraction e;
      const auto poses = posesOf(so_far, transform, &e);
      if (!so_far.empty() && (e.poses.empty() || e.poses.back().frame_index + 30 < so_far.size())) {
        message = transform + " not tracked: bring the " + o.tool + " and the " + o.reference +
                  " markers into the camera's view";
        return false;
      }
      const auto c = registration::pivotCoverage(poses);
      message = "pivot the " + o.tool + " about its tip in two directions: " + std::to_string(poses.size()) +
                " poses, swing " + swingText(c) + " (aim for " + formatFixed(o.target_swing_deg, 0) + " x " +
                formatFixed(o.target_swing_deg, 0) + ")";
      // Done only once the calibration will accept it: the swing in both directions and the rotation it checks
      // (5 % above its limit, so the last poses' noise cannot tip it back).
      return static_cast<int>(poses.size()) >= o.min_poses && c.second_range >= o.target_swing_deg * kDeg &&
             registration::pivotRotationRange(poses) >= 1.05 * o.min_rotation_deg * kDeg;
    };
    auto r = recordLiveTracking(live, monitor, context);
    recorded = recordedFigures(r, recording, live);
    frames = std::move(r.frames);
    const bool simulated = fromSimulatedRoom(r.device_identity);
    result.figures["simulated"] = simulated;
    result.outputs.push_back(recording);
  } else if (source == "file") {
    if (!p.has("recording")) {
      throw InvalidArgumentError(step + ": source=file needs recording (a PLUS sequence with " + transform +
                                 " or the transforms it is computed from)");
    }
    recording = p.text("recording", "");
    const std::filesystem::path path = recordingPath(session, recording);
    if (path.extension() == ".csv") {
      // A pose CSV holds the poses of `transform` themselves (one 4x4 per line), as calibrate-pivot --csv reads.
      const auto csv = io::readPoseCsv(path);
      for (std::size_t i = 0; i < csv.poses.size(); ++i) {
        TrackedFrame f;
        f.timestamp = i < csv.timestamps.size() ? csv.timestamps[i] : static_cast<double>(i);
        f.transforms[transform] = FrameTransform{csv.poses[i].matrix(), TransformStatus::Ok};
        frames.push_back(std::move(f));
      }
    } else {
      frames = io::readSequenceHeader(path, {}).frames;
    }
    recorded = {{"file", recording}, {"frames", frames.size()}};
  } else {
    throw InvalidArgumentError(step + ": source must be plus (live) or file, not '" + source + "'");
  }
  checkCancel(context);

  FramePoseExtraction extraction;
  const auto poses = posesOf(frames, transform, &extraction);
  recorded["poses"] = poses.size();
  recorded["skipped_invalid"] = extraction.invalid_frames;
  recorded["skipped_missing"] = extraction.missing_frames;
  const auto coverage = registration::pivotCoverage(poses);
  result.figures["recorded"] = recorded;
  result.figures["tool"] = o.tool;
  result.figures["reference"] = o.reference;
  result.figures["transform"] = transform;
  result.figures["swing_deg"] = {coverage.first_range / kDeg, coverage.second_range / kDeg};
  std::ostringstream offline;
  const std::string recording_path = recordingPath(session, recording).string();
  const bool csv = std::filesystem::path(recording).extension() == ".csv";
  offline << "mrsns-cli calibrate-pivot " << (csv ? "--csv " : "--sequence ") << recording_path
          << (csv ? "" : " --transform " + transform)
          << (o.robust ? " --robust" : "") << " --inlier-threshold " << o.inlier_threshold_mm
          << " --min-rotation-deg " << o.min_rotation_deg;
  result.figures["offline_command"] = offline.str();
  const std::string kept = recording.empty() ? "" : " (the recording is kept: " + recording + ")";

  registration::PivotOptions po;
  po.robust = o.robust;
  po.inlier_threshold_mm = o.inlier_threshold_mm;
  po.min_rotation_range = o.min_rotation_deg * kDeg;
  registration::PivotResult r;
  try {
    r = registration::calibratePivot(poses, po);
  } catch (const ComputationError& e) {
    result.ok = false;
    result.summary = std::string(e.what()) + kept;
    return result;
  }

  // StylusTipToStylus: the tip's frame, at the tip with the marker's axes (PLUS's convention).
  Eigen::Isometry3d marker_T_tip = Eigen::Isometry3d::Identity();
  marker_T_tip.translation() = r.tip_marker;
  const std::string tip_name = o.tool + "TipTo" + o.tool;
  const std::string output = step + "/" + tip_name + ".tfm";
  std::filesystem::create_directories(session.resolve(step));
  // The node StylusTipToStylus (io/transform_io.h: the .tfm holds the inverse of its ToParent, as Slicer
  // reads it), as mrsns-cli calibrate-pivot --output writes it.
  io::writeChildToParent(marker_T_tip.matrix(), session.resolve(output));
  result.outputs.insert(result.outputs.begin(), output);
  result.ok = true;
  result.figures["tip_marker_mm"] = {r.tip_marker.x(), r.tip_marker.y(), r.tip_marker.z()};
  result.figures["tip_length_mm"] = r.tip_marker.norm();
  result.figures["pivot_point_mm"] = {r.pivot_tracker.x(), r.pivot_tracker.y(), r.pivot_tracker.z()};
  result.figures["rms_mm"] = r.rms_mm;
  result.figures["max_residual_mm"] = r.max_residual_mm;
  result.figures["inliers"] = r.inlier_count;
  result.figures["outliers"] = static_cast<int>(poses.size()) - r.inlier_count;
  result.figures["rotation_range_deg"] = r.rotation_range / kDeg;
  result.figures["condition_number"] = r.condition_number;
  result.figures["residuals_mm"] = r.residuals_mm;
  result.figures["transforms"] = {{tip_name, matrixJson(marker_T_tip.matrix())}};
  std::ostringstream s;
  s << o.tool << " tip " << formatFixed(r.tip_marker.norm(), 2) << " mm from its marker, RMS "
    << formatFixed(r.rms_mm, 3) << " mm over " << r.inlier_count << " of " << poses.size() << " poses (swing "
    << swingText(coverage) << ")";
  if (extraction.invalid_frames + extraction.missing_frames > 0) {
    s << "; " << extraction.invalid_frames + extraction.missing_frames << " frames without " << transform
      << " left out";
  }
  result.summary = s.str();
  return result;
}

}  // namespace

StepResult runPivotCalibration(Session& session, const Json& params, const StepContext& context) {
  return runPivotStep(session, params, context, "pivot-calibration", "Stylus");
}

StepResult runDrillCalibration(Session& session, const Json& params, const StepContext& context) {
  return runPivotStep(session, params, context, "drill-calibration", "Flange");
}

}  // namespace mrsns::workflow::detail
