// The spin-calibration steps: the shaft of a tracked tool (the stylus; the drill on the robot's flange) from the
// operator turning it about its shaft with the tip held in the divot, acquired live from the session's PlusServer
// (or mrsns-sim) or recomputed from a recording, as SlicerIGT's Pivot Calibration module does after a pivot. With
// the tip from the pivot calibration it gives the tip's whole frame (PLUS's convention: z along the shaft, away
// from the marker), which a needle's or a drill's direction needs.
//
// The acquisition usually starts while the tool still pivots (the steps run one after the other and the operator
// does not wait for the software), so the spin is the stretch of `window_s` seconds in which the tool turned far
// enough about one axis, most cleanly, with its shaft's direction and its tip still. The same search runs on a
// recording, so the offline verb on the frames it names gives the same shaft.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>
#include <sstream>

#include "landmark_touch_step.h"
#include "live_tracking_recording.h"
#include "mrsns/core/error.h"
#include "mrsns/core/format.h"
#include "mrsns/core/frame_poses.h"
#include "mrsns/core/units.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/io/transform_io.h"
#include "mrsns/registration/spin_calibration.h"
#include "step_internal.h"

namespace mrsns::workflow::detail {

namespace {

struct SpinStepOptions {
  std::string tool = "Stylus";
  std::string reference = "Reference";
  double window_s = 3.0;
  int min_poses = 30;
  double target_spin_deg = 45.0;
  double max_axis_rms_deg = 1.5;
  /// The shaft's direction in the tracker may sway this far from its mean (a pivot's tilts are larger).
  double max_shaft_sway_deg = 3.0;
  double max_tip_travel_mm = 3.0;
  /// A shaft this far from the line marker -> tip is a tilt about the tip (a one-axis pivot), not a spin.
  double max_shaft_to_tip_line_deg = 45.0;
  /// Where that line starts (marker frame): the marker's origin, or the flange's for the drill.
  Eigen::Vector3d line_start = Eigen::Vector3d::Zero();
  [[nodiscard]] std::string transform() const { return tool + "To" + reference; }
};

/// The shaft's sway (deg) below which the ends of a stretch are never trimmed: a few times what 0.05 deg of
/// orientation noise per sample (an optical tracker's) gives.
constexpr double kMinTrimDeg = 0.3;

/// A stretch of the recording that is a spin, with its calibration.
struct SpinWindow {
  std::size_t first = 0;  ///< index into the poses
  std::size_t last = 0;   ///< inclusive
  registration::SpinResult result;
  double tip_travel_mm = 0.0;
  double shaft_sway_deg = 0.0;
};

/// Why the latest stretch is not a spin yet, or the stretch found: the operator's feedback and the step's refusal.
struct SpinSearch {
  std::optional<SpinWindow> window;
  std::string why_not = "no poses yet";
  double best_spin_deg = 0.0;
};

double tipTravel(const std::vector<FramePose>& poses, std::size_t first, std::size_t last, const Eigen::Vector3d& tip) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (std::size_t i = first; i <= last; ++i) mean += poses[i].to_T_from * tip;
  mean /= static_cast<double>(last - first + 1);
  double worst = 0.0;
  for (std::size_t i = first; i <= last; ++i) worst = std::max(worst, (poses[i].to_T_from * tip - mean).norm());
  return worst;
}

/// The angle (deg) between the shaft and the line from `line_start` to the tip.
double shaftToLineDeg(const Eigen::Vector3d& shaft, const Eigen::Vector3d& tip, const Eigen::Vector3d& line_start) {
  const Eigen::Vector3d line = (tip - line_start).normalized();
  return std::acos(std::clamp(shaft.dot(line), -1.0, 1.0)) / kDeg;
}

/// The spin of poses first..last, or why not (in `search`).
std::optional<registration::SpinResult> calibrateStretch(const std::vector<FramePose>& poses, std::size_t first,
                                                         std::size_t last, const SpinStepOptions& o,
                                                         const Eigen::Vector3d& tip, SpinSearch& search) {
  if (poses[last].timestamp - poses[first].timestamp < 0.8 * o.window_s) {
    search.why_not = poses[last].timestamp - poses.front().timestamp < o.window_s
                         ? "recording the first " + formatFixed(o.window_s, 0) + " s"
                         : "the turn about the shaft lasted under " + formatFixed(0.8 * o.window_s, 1) +
                               " s once its tilted ends were left out: keep turning it";
    return std::nullopt;
  }
  if (static_cast<int>(last - first + 1) < o.min_poses) {
    search.why_not = "only " + std::to_string(last - first + 1) + " poses in " + formatFixed(o.window_s, 0) +
                     " s (at least " + std::to_string(o.min_poses) +
                     "): keep the markers in the camera's view, or check the tracker's rate";
    return std::nullopt;
  }
  std::vector<Eigen::Isometry3d> marker_poses;
  marker_poses.reserve(last - first + 1);
  for (std::size_t i = first; i <= last; ++i) marker_poses.push_back(poses[i].to_T_from);
  registration::SpinOptions so;
  so.min_poses = o.min_poses;
  so.min_spin_angle = o.target_spin_deg * kDeg;
  try {
    // Its sign: towards the tip along the line the shaft is judged against.
    const Eigen::Vector3d towards_tip = tip - o.line_start;
    auto result = registration::calibrateSpin(marker_poses, so, &towards_tip);
    search.best_spin_deg = std::max(search.best_spin_deg, result.spin_angle / kDeg);
    return result;
  } catch (const ComputationError& e) {
    // How far it turned, for the operator, even when it is not yet enough.
    double spin = 0.0;
    for (const auto& p : marker_poses) {
      spin = std::max(spin, Eigen::AngleAxisd(marker_poses.front().linear().transpose() * p.linear()).angle());
    }
    search.best_spin_deg = std::max(search.best_spin_deg, spin / kDeg);
    search.why_not = e.what();
    return std::nullopt;
  }
}

/// The median of non-empty values (the upper one of an even count).
double median(std::vector<double> values) {
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

/// Angles (deg) of the shaft's direction in the tracker, pose by pose, from their mean over the poses that
/// agree (one reweighting: a tilted end does not pull the mean).
std::vector<double> shaftDeviations(const std::vector<FramePose>& poses, std::size_t first, std::size_t last,
                                    const Eigen::Vector3d& shaft_marker) {
  const auto deviations = [&](const Eigen::Vector3d& mean) {
    std::vector<double> d;
    for (std::size_t i = first; i <= last; ++i) {
      const double c = std::clamp((poses[i].to_T_from.linear() * shaft_marker).dot(mean), -1.0, 1.0);
      d.push_back(std::acos(c) / kDeg);
    }
    return d;
  };
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (std::size_t i = first; i <= last; ++i) mean += poses[i].to_T_from.linear() * shaft_marker;
  auto d = deviations(mean.normalized());
  const double cut = 3.0 * median(d);
  Eigen::Vector3d agreed = Eigen::Vector3d::Zero();
  for (std::size_t i = first; i <= last; ++i) {
    if (d[i - first] <= cut) agreed += poses[i].to_T_from.linear() * shaft_marker;
  }
  return agreed.norm() > 0.0 ? deviations(agreed.normalized()) : d;
}

/// The stretch ending at pose `last` (the poses of the `window_s` seconds before it), judged as a spin. Its ends
/// are trimmed while the shaft there points elsewhere than in the rest (the end of a pivot, the tool being
/// lifted): those poses are not a turn about the shaft.
std::optional<SpinWindow> spinEndingAt(const std::vector<FramePose>& poses, std::size_t last,
                                       const SpinStepOptions& o, const Eigen::Vector3d& tip, SpinSearch& search) {
  std::size_t first = last;
  // A timestamp that goes backwards (a restarted server) ends the stretch too.
  while (first > 0 && poses[first - 1].timestamp <= poses[first].timestamp &&
         poses[last].timestamp - poses[first - 1].timestamp <= o.window_s) {
    --first;
  }
  auto result = calibrateStretch(poses, first, last, o, tip, search);
  if (!result) return std::nullopt;
  // A tilted end biases the shaft, which makes every turn look tilted; so trim, recalibrate and trim again until
  // the stretch stops shrinking (a few rounds: each brings the shaft closer to the clean turns').
  std::size_t kept_first = first, kept_last = last;
  for (int round = 0; round < 5; ++round) {
    const auto deviation = shaftDeviations(poses, kept_first, kept_last, result->shaft_marker);
    // Three times the typical sway, and never below what the tracker's orientation noise alone gives.
    const double keep_deg = std::max(kMinTrimDeg, 3.0 * median(deviation));
    const std::size_t was_first = kept_first, was_last = kept_last;
    while (kept_first < kept_last && deviation[kept_first - was_first] > keep_deg) ++kept_first;
    while (kept_last > kept_first && deviation[kept_last - was_first] > keep_deg) --kept_last;
    if (kept_first == was_first && kept_last == was_last) break;
    result = calibrateStretch(poses, kept_first, kept_last, o, tip, search);
    if (!result) return std::nullopt;
  }
  SpinWindow w;
  w.first = kept_first;
  w.last = kept_last;
  w.result = *result;
  w.tip_travel_mm = tipTravel(poses, w.first, w.last, tip);
  const double off_line = shaftToLineDeg(w.result.shaft_marker, tip, o.line_start);
  if (off_line > o.max_shaft_to_tip_line_deg) {
    search.why_not = "it turned about an axis " + formatFixed(off_line, 0) + " deg from the line to its tip (at most " +
                     formatFixed(o.max_shaft_to_tip_line_deg, 0) +
                     ", max_shaft_to_tip_line_deg): that tilts the shaft; turn it about the shaft";
    return std::nullopt;
  }
  if (w.result.axis_rms_angle > o.max_axis_rms_deg * kDeg) {
    search.why_not = "the tool turned about more than its shaft (axis wobble " +
                     formatFixed(w.result.axis_rms_angle / kDeg, 1) + " deg RMS, at most " +
                     formatFixed(o.max_axis_rms_deg, 1) + ")";
    return std::nullopt;
  }
  // The shaft keeps its direction in the tracker while the tool turns about it.
  for (double d : shaftDeviations(poses, w.first, w.last, w.result.shaft_marker)) {
    w.shaft_sway_deg = std::max(w.shaft_sway_deg, d);
  }
  if (w.shaft_sway_deg > o.max_shaft_sway_deg) {
    search.why_not = "the shaft tilted " + formatFixed(w.shaft_sway_deg, 1) + " deg (at most " +
                     formatFixed(o.max_shaft_sway_deg, 1) + "): hold its direction while turning it";
    return std::nullopt;
  }
  if (w.tip_travel_mm > o.max_tip_travel_mm) {
    search.why_not = "the tip moved " + formatFixed(w.tip_travel_mm, 1) + " mm (at most " +
                     formatFixed(o.max_tip_travel_mm, 1) + "): keep it in the divot";
    return std::nullopt;
  }
  return w;
}

/// Of the stretches that are a spin, the one turning most cleanly about one axis (the least wobble): the
/// transitions into and out of the spin, which any rule of thumb would let in, are left out.
SpinSearch findSpin(const std::vector<FramePose>& poses, const SpinStepOptions& o, const Eigen::Vector3d& tip) {
  SpinSearch search;
  for (std::size_t last = 0; last < poses.size(); ++last) {
    auto w = spinEndingAt(poses, last, o, tip, search);
    if (w && (!search.window || w->result.axis_rms_angle < search.window->result.axis_rms_angle)) {
      search.window = std::move(w);
    }
  }
  return search;
}

Eigen::Vector3d sessionTip(const Session& session, const Params& p, const std::string& step, const std::string& tool,
                           const std::string& pivot_step) {
  Eigen::Vector3d tip;
  if (p.has("tip_mm")) {
    std::istringstream in(p.text("tip_mm", ""));
    char a = 0, b = 0;
    std::string rest;
    if (!(in >> tip.x() >> a >> tip.y() >> b >> tip.z()) || a != ',' || b != ',' || (in >> rest) || !tip.allFinite()) {
      throw InvalidArgumentError(step + ": tip_mm must be \"x,y,z\" in the marker's frame (mm)");
    }
  } else {
    tip = pivotTip(session, tool, pivot_step, step, "the spin is about the shaft through the tip; or give tip_mm");
  }
  // The shaft's sign and the tip's stillness are judged from the tip: one at the marker's origin says neither.
  if (tip.norm() < 1.0) {
    throw InvalidArgumentError(step + ": the tip is " + formatFixed(tip.norm(), 2) +
                               " mm from the marker's origin: a spin about it cannot be told from a turn of the marker");
  }
  return tip;
}

/// Where the line the shaft is judged against starts, in the marker's frame: the marker's origin (a stylus's
/// marker sits on its handle, near the shaft's line), or for the drill the flange's origin when the robot
/// calibration placed the marker on the flange (a drill's marker sits on a bracket beside its axis).
Eigen::Vector3d shaftLineStart(const Session& session, const std::string& step) {
  if (step != "drill-spin-calibration") return Eigen::Vector3d::Zero();
  const auto calibration = session.step("robot-calibration");
  const bool has = calibration.is_object() && calibration.value("status", "") == "ok" &&
                   calibration.contains("figures") && calibration["figures"].contains("transforms") &&
                   calibration["figures"]["transforms"].contains("MarkerToFlange");
  if (!has) return Eigen::Vector3d::Zero();
  const Eigen::Isometry3d flange_T_marker(
      matrixFromJson(calibration["figures"]["transforms"]["MarkerToFlange"], "robot-calibration MarkerToFlange"));
  return flange_T_marker.inverse().translation();
}

StepResult runSpinStep(Session& session, const Json& params, const StepContext& context, const std::string& step,
                       const std::string& default_tool, const std::string& pivot_step) {
  const Params p(step, params,
                 {"source", "host", "port", "recording", "tool", "reference", "tip_mm", "duration_s",
                  "connect_timeout_s", "window_s", "min_poses", "target_spin_deg", "max_axis_rms_deg",
                  "max_tip_travel_mm", "max_shaft_to_tip_line_deg", "max_shaft_sway_deg"});
  SpinStepOptions o;
  o.tool = p.text("tool", default_tool);
  o.reference = p.text("reference", o.reference);
  o.window_s = p.number("window_s", o.window_s);
  o.min_poses = p.integer("min_poses", o.min_poses);
  o.target_spin_deg = p.number("target_spin_deg", o.target_spin_deg);
  o.max_axis_rms_deg = p.number("max_axis_rms_deg", o.max_axis_rms_deg);
  o.max_tip_travel_mm = p.number("max_tip_travel_mm", o.max_tip_travel_mm);
  o.max_shaft_to_tip_line_deg = p.number("max_shaft_to_tip_line_deg", o.max_shaft_to_tip_line_deg);
  o.max_shaft_sway_deg = p.number("max_shaft_sway_deg", o.max_shaft_sway_deg);
  if (o.tool.empty() || o.reference.empty() || o.tool == o.reference) {
    throw InvalidArgumentError(step + ": tool and reference must be two tool names (Stylus, Reference)");
  }
  if (!(o.window_s >= 0.5 && o.window_s <= 60.0) || o.min_poses < 10 ||
      !(o.target_spin_deg >= 10.0 && o.target_spin_deg <= 170.0) ||
      !(o.max_axis_rms_deg > 0.0 && o.max_axis_rms_deg <= 20.0) || !(o.max_tip_travel_mm > 0.0) ||
      !(o.max_shaft_to_tip_line_deg > 0.0 && o.max_shaft_to_tip_line_deg <= 90.0) ||
      !(o.max_shaft_sway_deg > 0.0 && o.max_shaft_sway_deg <= 45.0)) {
    throw InvalidArgumentError(step + ": window_s must be in [0.5, 60] s, min_poses >= 10, target_spin_deg in "
                                      "[10, 170], max_axis_rms_deg in (0, 20], max_tip_travel_mm > 0, "
                                      "max_shaft_to_tip_line_deg in (0, 90], max_shaft_sway_deg in (0, 45]");
  }
  checkCancel(context);  // cancelled before it started: nothing is asked of the session yet
  const Eigen::Vector3d tip = sessionTip(session, p, step, o.tool, pivot_step);
  o.line_start = shaftLineStart(session, step);
  if ((tip - o.line_start).norm() < 1.0) {
    throw InvalidArgumentError(step + ": the tip lies on the flange's origin: its line gives no direction");
  }
  const std::string transform = o.transform();
  const std::string source = p.text("source", "plus");

  StepResult result;
  std::vector<TrackedFrame> frames;
  std::string recording;
  Json recorded;
  if (source == "plus") {
    // The recording as the touch acquisitions make theirs: the session's PlusServer, a new file per acquisition.
    const LiveTrackingOptions live = touchRecordingOptions(session, p, step, o.tool + "Spin", 60.0, recording);
    context.report(0.05, "connecting to the tracker at " + live.host + ":" + std::to_string(live.port) +
                             ": keep the " + o.tool + "'s tip in the divot and turn it about its shaft");
    // Only the latest stretch is judged live (the whole search runs once at the end).
    const auto monitor = [&](const std::vector<TrackedFrame>& so_far, std::string& message) {
      FramePoseExtraction e;
      try {
        e = extractFramePoses(so_far, transform);
      } catch (const Error&) {
        e = {};
      }
      if (!so_far.empty() && (e.poses.empty() || e.poses.back().frame_index + 30 < so_far.size())) {
        message = transform + " not tracked: bring the " + o.tool + " and the " + o.reference +
                  " markers into the camera's view";
        return false;
      }
      if (e.poses.empty()) return false;
      SpinSearch search;
      const bool done = spinEndingAt(e.poses, e.poses.size() - 1, o, tip, search).has_value();
      message = "turn the " + o.tool + " about its shaft, tip in the divot: " +
                formatFixed(search.best_spin_deg, 0) + " of " + formatFixed(o.target_spin_deg, 0) + " deg" +
                (done ? "" : " (" + search.why_not + ")");
      return done;
    };
    auto r = recordLiveTracking(live, monitor, context);
    recorded = recordedFigures(r, recording, live);
    frames = std::move(r.frames);
    result.figures["simulated"] = fromSimulatedRoom(r.device_identity);
    result.outputs.push_back(recording);
  } else if (source == "file") {
    if (!p.has("recording")) {
      throw InvalidArgumentError(step + ": source=file needs recording (a PLUS sequence with " + transform +
                                 " or the transforms it is computed from)");
    }
    recording = p.text("recording", "");
    frames = io::readSequenceHeader(recordingPath(session, recording), {}).frames;
    recorded = {{"file", recording}, {"frames", frames.size()}};
  } else {
    throw InvalidArgumentError(step + ": source must be plus (live) or file, not '" + source + "'");
  }
  checkCancel(context);

  FramePoseExtraction extraction;
  try {
    extraction = extractFramePoses(frames, transform);
  } catch (const Error& e) {
    result.ok = false;
    result.summary = std::string(e.what()) + (source == "plus" ? " (the recording is kept: " + recording + ")" : "");
    result.figures["recorded"] = recorded;
    return result;
  }
  recorded["poses"] = extraction.poses.size();
  recorded["skipped_invalid"] = extraction.invalid_frames;
  recorded["skipped_missing"] = extraction.missing_frames;
  result.figures["recorded"] = recorded;
  result.figures["tool"] = o.tool;
  result.figures["reference"] = o.reference;
  result.figures["transform"] = transform;
  result.figures["tip_marker_mm"] = {tip.x(), tip.y(), tip.z()};
  const std::string kept = source == "plus" ? " (the recording is kept: " + recording + ")" : "";

  const auto search = findSpin(extraction.poses, o, tip);
  result.figures["spin_deg"] = search.best_spin_deg;
  if (!search.window) {
    result.ok = false;
    result.summary = "no " + formatFixed(o.window_s, 0) + " s of the recording is a spin of the " + o.tool +
                     " about its shaft of at least " + formatFixed(o.target_spin_deg, 0) + " deg (largest turn " +
                     formatFixed(search.best_spin_deg, 0) + " deg; last: " + search.why_not + ")" + kept;
    return result;
  }
  const auto& w = *search.window;
  const std::size_t first_frame = extraction.poses[w.first].frame_index;
  const std::size_t last_frame = extraction.poses[w.last].frame_index;
  const Eigen::Isometry3d marker_T_tip = registration::tipFrame(tip, w.result.shaft_marker);
  const std::string tip_name = o.tool + "TipTo" + o.tool;
  const std::string output = step + "/" + tip_name + ".tfm";
  std::filesystem::create_directories(session.resolve(step));
  // The node StylusTipToStylus (io/transform_io.h: the .tfm holds the inverse of its ToParent).
  io::writeChildToParent(marker_T_tip.matrix(), session.resolve(output));
  result.outputs.insert(result.outputs.begin(), output);
  result.ok = true;
  const Eigen::Vector3d& s = w.result.shaft_marker;
  result.figures["shaft_marker"] = {s.x(), s.y(), s.z()};
  // How far the shaft is from the line marker-origin -> tip: what a pivot alone would have had to assume.
  result.figures["shaft_to_tip_line_deg"] = shaftToLineDeg(s, tip, o.line_start);
  result.figures["shaft_line_from"] = o.line_start.isZero() ? "the marker's origin" : "the flange's origin";
  result.figures["spin_deg"] = w.result.spin_angle / kDeg;
  result.figures["axis_rms_deg"] = w.result.axis_rms_angle / kDeg;
  result.figures["axis_distinctness"] = w.result.axis_distinctness;
  result.figures["tip_travel_mm"] = w.tip_travel_mm;
  result.figures["shaft_sway_deg"] = w.shaft_sway_deg;
  result.figures["window"] = {{"first_frame", first_frame},
                              {"last_frame", last_frame},
                              {"poses", w.last - w.first + 1},
                              {"from_s", extraction.poses[w.first].timestamp},
                              {"to_s", extraction.poses[w.last].timestamp}};
  result.figures["transforms"] = {{tip_name, matrixJson(marker_T_tip.matrix())}};
  std::ostringstream offline;
  offline << "mrsns-cli calibrate-spin --sequence " << recordingPath(session, recording).string() << " --transform "
          << transform << " --first-frame " << first_frame << " --last-frame " << last_frame << " --tip "
          << formatGeneral(tip.x(), 17) << ' ' << formatGeneral(tip.y(), 17) << ' ' << formatGeneral(tip.z(), 17)
          << " --min-spin-deg " << formatGeneral(o.target_spin_deg, 17);
  if (!o.line_start.isZero()) {
    offline << " --line-start " << formatGeneral(o.line_start.x(), 17) << ' ' << formatGeneral(o.line_start.y(), 17)
            << ' ' << formatGeneral(o.line_start.z(), 17);
  }
  result.figures["offline_command"] = offline.str();
  std::ostringstream summary;
  summary << o.tool << " shaft " << formatFixed(result.figures["shaft_to_tip_line_deg"].get<double>(), 2)
          << " deg from its tip's line, turned " << formatFixed(w.result.spin_angle / kDeg, 0) << " deg over "
          << w.last - w.first + 1 << " poses (axis wobble " << formatFixed(w.result.axis_rms_angle / kDeg, 2)
          << " deg RMS, tip still within " << formatFixed(w.tip_travel_mm, 2) << " mm)";
  result.summary = summary.str();
  return result;
}

}  // namespace

StepResult runSpinCalibration(Session& session, const Json& params, const StepContext& context) {
  return runSpinStep(session, params, context, "spin-calibration", "Stylus", "pivot-calibration");
}

StepResult runDrillSpinCalibration(Session& session, const Json& params, const StepContext& context) {
  return runSpinStep(session, params, context, "drill-spin-calibration", "Flange", "drill-calibration");
}

}  // namespace mrsns::workflow::detail
