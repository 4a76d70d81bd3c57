// Ultrasound spatial (N-wire) and temporal (tracker lag) calibration steps,
// on the PLUS fCal recording of the shared data set unless told otherwise.
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>

#include "live_tracking_recording.h"
#include "live_us_recording.h"
#include "mrsns/core/data_dir.h"
#include "mrsns/core/format.h"
#include "mrsns/io/device_set.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/io/transform_io.h"
#include "mrsns/ultrasound/probe_calibration.h"
#include "mrsns/ultrasound/spatial_calibration.h"
#include "step_internal.h"

namespace mrsns::workflow::detail {

namespace {

constexpr const char* kConfig = "plus/PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml";
constexpr const char* kCalibration = "plus/fCal_Test_Calibration_3NWires.igs.mha";
constexpr const char* kValidation = "plus/fCal_Test_Validation_3NWires.igs.mha";
// Where a live calibration sweep is recorded in the session.

std::filesystem::path dataPath(const Params& p, const std::string& key, const char* relative) {
  if (p.has(key)) {
    std::filesystem::path path = p.text(key, "");
    if (!std::filesystem::exists(path)) {
      throw FileError("parameter '" + key + "': file '" + path.string() + "' does not exist");
    }
    return path;
  }
  if (auto found = findDataFile(relative)) return *found;
  throw FileError(std::string("the PLUS recording '") + relative + "' is not in the data directory '" +
                  dataDirectory().string() + "': set MRSNS_DATA_DIR or give config/calibration/validation parameters");
}

struct Inputs {
  io::DeviceSetConfiguration config;
  TrackedSequence calibration;
  TrackedSequence validation;
  std::filesystem::path calibration_path;
};

Inputs readInputs(const Params& p, const StepContext& context, const TrackedSequence* recorded = nullptr) {
  Inputs in;
  context.report(0.05, "reading the device set");
  in.config = io::readDeviceSet(dataPath(p, "config", kConfig));
  checkCancel(context);
  if (recorded != nullptr) {
    in.calibration = *recorded;
  } else {
    context.report(0.1, "reading the calibration recording");
    in.calibration_path = dataPath(p, "calibration", kCalibration);
    in.calibration = io::readSequence(in.calibration_path);
  }
  checkCancel(context);
  context.report(0.25, "reading the validation recording");
  in.validation = io::readSequence(dataPath(p, "validation", kValidation));
  checkCancel(context);
  return in;
}

Json errorFigures(const ultrasound::CalibrationErrorReport& e) {
  return Json{{"reprojection_3d_mean_mm", e.reprojection_3d_mean_mm},
              {"reprojection_3d_std_mm", e.reprojection_3d_std_mm},
              {"reprojection_3d_all_mean_mm", e.reprojection_3d_all_mean_mm},
              {"wire_distance_rms_mm", e.wire_distance_rms_mm},
              // Per frame (mean over the N patterns): the GUI's residual plot.
              {"residuals_mm", e.reprojection_3d_per_frame_mm},
              {"frames", e.frames}};
}


/// The phantom's place on its reference: the session's phantom registration (us-phantom-registration) replaces
/// the device set's PhantomToReference when `which` is "session" (the default for a live sweep: the phantom
/// was registered in this room), the file's is kept for "config" (a recording made with that file).
std::string usePhantomRegistration(const Session& session, const std::string& which, io::DeviceSetConfiguration& config) {
  if (which == "config") {
    if (!config.findTransform("Phantom", "Reference")) {
      throw InvalidArgumentError("us-spatial-calibration: " + config.source +
                                 " has no PhantomToReference: run us-phantom-registration and give "
                                 "phantom_to_reference=session");
    }
    return "device set " + config.source;
  }
  if (which != "session") {
    throw InvalidArgumentError("us-spatial-calibration: phantom_to_reference must be session or config, not '" +
                               which + "'");
  }
  const auto registration = session.step("us-phantom-registration");
  Eigen::Matrix4d reference_T_phantom;
  if (!registration.is_object() || registration.value("status", "") != "ok" ||
      !findRecordedTransform(session, "PhantomToReference", reference_T_phantom)) {
    throw InvalidArgumentError(
        "us-spatial-calibration: the session has no phantom registration: run us-phantom-registration (touch the "
        "N-wire phantom's landmarks with the calibrated stylus) first, or give phantom_to_reference=config to use "
        "the device set's");
  }
  std::erase_if(config.coordinate_definitions, [](const io::CoordinateDefinition& d) {
    return (d.from == "Phantom" && d.to == "Reference") || (d.from == "Reference" && d.to == "Phantom");
  });
  io::CoordinateDefinition d;
  d.from = "Phantom";
  d.to = "Reference";
  d.to_T_from = reference_T_phantom;
  config.coordinate_definitions.push_back(d);
  return "us-phantom-registration";
}

/// How far the middle wires' points spread across the image (mm): the square root of the smaller eigenvalue
/// of their 2D covariance, as the calibration's motion check measures it in the probe frame.
class MiddleWireSpread {
 public:
  void add(const Eigen::Vector2d& p_mm) {
    ++n_;
    sum_ += p_mm;
    sum2_ += p_mm * p_mm.transpose();
  }
  [[nodiscard]] double acrossMm() const {
    if (n_ < 2) return 0.0;
    const Eigen::Vector2d mean = sum_ / n_;
    const Eigen::Matrix2d cov = sum2_ / n_ - mean * mean.transpose();
    return std::sqrt(std::max(Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(cov).eigenvalues()[0], 0.0));
  }

 private:
  double n_ = 0.0;
  Eigen::Vector2d sum_ = Eigen::Vector2d::Zero();
  Eigen::Matrix2d sum2_ = Eigen::Matrix2d::Zero();
};

/// A live sweep's frames split into calibration and validation, as fCal acquires them apart: every third block
/// of 25 consecutive frames (1 s at 25 Hz) validates. Blocks, not single frames: a frame 40 ms from a
/// calibration frame shows nearly the same image and pose, and would not test the calibration; every third
/// block, so both sets still cover the whole sweep.
bool isCalibrationFrame(std::size_t index) {
  constexpr std::size_t kBlock = 25;
  return (index / kBlock) % 3 != 2;
}

void splitSweep(const TrackedSequence& sweep, TrackedSequence& calibration, TrackedSequence& validation) {
  calibration = sweep;
  calibration.frames.clear();
  validation = calibration;
  for (std::size_t i = 0; i < sweep.frames.size(); ++i) {
    (isCalibrationFrame(i) ? calibration : validation).frames.push_back(sweep.frames[i]);
  }
}

}  // namespace

StepResult runUsSpatialCalibration(Session& session, const Json& params, const StepContext& context) {
  const Params p("us-spatial-calibration", params,
                 {"config", "calibration", "validation", "tracker_lag_ms", "source", "host", "port", "duration_s",
                  "idle_stop_s", "connect_timeout_s", "segmented_frames", "phantom_to_reference"});
  const std::string source = p.text("source", "file");
  if (source != "file" && source != "plus") {
    throw InvalidArgumentError("us-spatial-calibration: source must be file or plus, not '" + source + "'");
  }
  Inputs in;
  context.report(0.02, "reading the device set");
  in.config = io::readDeviceSet(dataPath(p, "config", kConfig));
  const std::string phantom_choice = p.text("phantom_to_reference", source == "plus" ? "session" : "config");
  const std::string phantom_source = usePhantomRegistration(session, phantom_choice, in.config);
  // source=plus: the calibration sweep is recorded live from a PlusServer (or mrsns-sim) into the session first,
  // as fCal does: until enough frames show all the wires (fCal's 140 calibration and 70 validation images);
  // the step then calibrates on that recording, which the offline verbs can recompute.
  std::optional<LiveUsRecording> live;
  std::string live_sweep;
  std::size_t segmented_live = 0, seen_live = 0;
  if (source == "plus") {
    if (p.has("calibration")) {
      throw InvalidArgumentError(
          "us-spatial-calibration: calibration is a recording (source=file); source=plus records the sweep");
    }
    LiveUsRecordingOptions o;
    sessionPlusServer(session, p, o.host, o.port);
    o.max_duration_s = p.number("duration_s", o.max_duration_s);
    o.idle_stop_s = p.number("idle_stop_s", o.idle_stop_s);
    o.connect_timeout_s = p.number("connect_timeout_s", o.connect_timeout_s);
    const int wanted = p.integer("segmented_frames", 210);
    if (!(o.max_duration_s > 0.0 && o.max_duration_s <= 3600.0) || !(o.idle_stop_s > 0.0) ||
        !(o.connect_timeout_s > 0.0) || wanted < 6 || wanted > 3000) {
      throw InvalidArgumentError(
          "us-spatial-calibration: duration_s must be in (0, 3600] s, idle_stop_s and connect_timeout_s > 0, "
          "segmented_frames in [6, 3000]");
    }
    const io::PhantomDefinition& phantom = in.config.requirePhantom();
    const auto segmentation = in.config.segmentation ? ultrasound::segmentationOptionsFrom(*in.config.segmentation)
                                                     : ultrasound::NWireSegmentationOptions{};
    // Each frame segmented as it arrives: the operator sees how many frames show every wire (fCal's count).
    // The calibration needs the middle wires' points spread across the image (spatial_calibration's check,
    // 2 mm, on the frames that calibrate): a sweep that stayed in one place is not done when it has its frames.
    // Measured here on the frames splitSweep will give the calibration, in pixels times the device set's
    // approximate spacing, with a quarter more for what that approximation and the probe frame may differ by.
    const double spread_needed_mm = 1.25 * ultrasound::SpatialCalibrationOptions{}.min_point_spread_mm;
    MiddleWireSpread spread;
    o.on_frame = [&](const tracking::TrackedImage& image, std::string& message) {
      const bool calibrates = isCalibrationFrame(seen_live);
      ++seen_live;
      const bool gray = image.format.scalar == PixelType::UInt8 && image.format.components == 1 &&
                        image.geometry.size[2] == 1;
      if (gray) {
        const ultrasound::GrayImageView view{static_cast<int>(image.geometry.size[0]),
                                             static_cast<int>(image.geometry.size[1]), image.pixels};
        ultrasound::NWireSegmentation seg;
        try {
          seg = ultrasound::segmentNWires(view, phantom, segmentation);
        } catch (const Error& e) {
          // Not this frame's fault (a phantom the segmentation cannot read): said, and the sweep is still kept.
          message = std::string("the N-wires cannot be segmented: ") + e.what();
          return false;
        }
        if (seg.ok()) {
          ++segmented_live;
          for (std::size_t k = 1; calibrates && k < seg.wire_points_px.size(); k += 3) {
            spread.add(seg.wire_points_px[k] * segmentation.approximate_spacing_mm);
          }
        }
      }
      const double across_mm = spread.acrossMm();
      message = gray ? "sweep the probe over the N-wires, tilting it: all wires found in " +
                           std::to_string(segmented_live) + " of " + std::to_string(wanted) + " frames needed (" +
                           std::to_string(seen_live) + " received), wire points " + formatFixed(across_mm, 1) +
                           " of " + formatFixed(spread_needed_mm, 1) + " mm across the image"
                     : "the PlusServer sends no 8-bit grey B-mode frames: the N-wires cannot be segmented";
      return static_cast<int>(segmented_live) >= wanted && across_mm >= spread_needed_mm;
    };
    context.report(0.05, "recording the calibration sweep from " + o.host + ":" + std::to_string(o.port));
    live = recordLiveUltrasound(o, context);
    live_sweep = freeSessionName(session, "us-spatial-calibration", "calibration_sweep", ".igs.mha");
    io::writeSequence(session.resolve(live_sweep), live->sequence);
    // The stream ended (a replayed recording) or the time ran out short of the target: what was segmented is
    // used when it is enough for a calibration, and said.
    const int least = std::min(wanted, 30);
    if (!live->complete && static_cast<int>(segmented_live) < least) {
      StepResult failed;
      failed.ok = false;
      failed.outputs = {live_sweep};
      failed.figures = {{"recorded", {{"file", live_sweep}, {"frames", live->sequence.frames.size()}}},
                        {"segmented_frames", segmented_live},
                        {"segmented_frames_needed", least},
                        {"simulated", fromSimulatedRoom(live->device_identity)}};
      failed.summary = "only " + std::to_string(segmented_live) + " of " + std::to_string(seen_live) +
                       " frames showed all the N-wires, " + std::to_string(least) +
                       " needed: keep the probe in the water bath over the wires and sweep slowly (the recording "
                       "is kept: " + live_sweep + ")";
      return failed;
    }
    if (p.has("validation")) {
      // A separate validation recording (fCal acquires one apart): the whole sweep calibrates.
      in.calibration = live->sequence;
      context.report(0.25, "reading the validation recording");
      in.validation = io::readSequence(dataPath(p, "validation", kValidation));
    } else {
      splitSweep(live->sequence, in.calibration, in.validation);
    }
  } else {
    for (const char* key : {"host", "port", "duration_s", "idle_stop_s", "connect_timeout_s", "segmented_frames"}) {
      if (p.has(key)) throw InvalidArgumentError(std::string("us-spatial-calibration: ") + key + " is for source=plus");
    }
    const bool has_calibration = p.has("calibration"), has_validation = p.has("validation");
    context.report(0.1, "reading the calibration recording");
    in.calibration_path = dataPath(p, "calibration", kCalibration);
    in.calibration = io::readSequence(in.calibration_path);
    checkCancel(context);
    if (has_calibration && !has_validation) {
      // A user's own recording without a separate validation sweep: validate on every third block of it.
      const TrackedSequence whole = std::move(in.calibration);
      splitSweep(whole, in.calibration, in.validation);
    } else {
      context.report(0.25, "reading the validation recording");
      in.validation = io::readSequence(dataPath(p, "validation", kValidation));
    }
  }
  checkCancel(context);
  // tracker_lag_ms: a number (ms), or "auto" (estimated from the
  // calibration sweep, none when the sweep does not pin it down). Without
  // it, PLUS's workflow: the lag of this session's temporal calibration when
  // it has run, else the streams as recorded; the sweep's own lag is then
  // searched and reported (tracker_lag_check) but not applied.
  ultrasound::TrackerLagOptions lag;
  std::string lag_source = "given";
  const bool auto_lag = params.contains("tracker_lag_ms") && params["tracker_lag_ms"].is_string();
  if (auto_lag) {
    if (p.text("tracker_lag_ms", "auto") != "auto") {
      throw InvalidArgumentError("us-spatial-calibration: tracker_lag_ms must be a number of milliseconds or \"auto\"");
    }
    lag.estimate = true;
    lag.fall_back_to_zero = true;
    lag_source = "estimated";
  } else if (p.has("tracker_lag_ms")) {
    lag.lag_s = p.number("tracker_lag_ms", 0.0) * 1e-3;
  } else {
    const auto recorded = recordedStepFigure(session, "us-temporal-calibration", "tracker_lag_ms");
    lag.lag_s = recorded ? *recorded * 1e-3 : 0.0;
    lag_source = recorded ? "us-temporal-calibration" : "none";
  }
  lag.check = !lag.estimate;
  context.report(0.3, "segmenting the N-wires, searching the tracker lag and calibrating");
  const auto run = ultrasound::calibrateProbe(in.config, in.calibration, in.validation, {}, lag);
  checkCancel(context);
  const auto& r = run.result;
  const std::string output = "us-spatial-calibration/ImageToProbe.tfm";
  std::filesystem::create_directories(session.resolve("us-spatial-calibration"));
  // The node ImageToProbe, an affine with the mm/pixel scale (io/transform_io.h: the .tfm holds the inverse
  // of its ToParent, so Slicer places the image pixels in the probe's frame).
  io::writeChildToParent(r.probe_T_image, session.resolve(output));

  StepResult result;
  result.ok = true;
  result.figures = {
      {"calibration", errorFigures(r.calibration)},
      {"validation", errorFigures(run.validation_errors)},
      {"pixel_spacing_mm", {r.pixel_spacing_mm.x(), r.pixel_spacing_mm.y()}},
      // The frames this calibration holds for: navigation refuses frames of another size (another probe or depth).
      {"image_size_px", {in.calibration.geometry.size[0], in.calibration.geometry.size[1]}},
      // The tracked probe (ProbeToReference in the sweep): navigation refuses a source whose probe is another.
      {"probe_tool", "Probe"},
      {"frames_used", r.frames_used},
      {"frames_rejected", r.rejected_frames.size()},
      {"segmented_frames", run.calibration.segmented_frames},
      {"total_frames", run.calibration.total_frames},
      {"seconds", run.seconds},
      {"tracker_lag_ms", run.tracker_lag.lag_s * 1e3},
      {"tracker_lag_estimated", run.tracker_lag.estimated},
      {"tracker_lag_source", lag_source},
      {"phantom_to_reference_source", phantom_source},
      {"transforms", {{"ImageToProbe", matrixJson(r.probe_T_image)}}}};
  const bool plus_files = !live && !p.has("calibration") && !p.has("validation") && !p.has("config") &&
                          phantom_choice == "config";
  if (plus_files) {
    // PLUS's own result on the same files (data/README.md).
    result.figures["plus_reference"] = {{"calibration_reprojection_3d_mean_mm", 1.15532},
                                        {"validation_reprojection_3d_mean_mm", 1.24684}};
  }
  if (!run.tracker_lag.note.empty()) result.figures["tracker_lag_note"] = run.tracker_lag.note;
  if (run.tracker_lag_check) {
    const auto& c = *run.tracker_lag_check;
    Json check{{"estimated", c.estimate.estimated}, {"significant", c.significant}};
    if (c.estimate.estimated) {
      check["lag_ms"] = c.estimate.lag_s * 1e3;
      check["calibration_error_at_lag_mm"] = c.error_at_estimate_mm;
      check["calibration_error_as_applied_mm"] = c.error_as_applied_mm;
    }
    if (!c.estimate.note.empty()) check["note"] = c.estimate.note;
    if (c.significant) check["advice"] = c.advice + " (run the US temporal calibration step, then this one again)";
    result.figures["tracker_lag_check"] = check;
  }
  result.outputs = {output};
  if (live) {
    const bool simulated = fromSimulatedRoom(live->device_identity);
    result.outputs.push_back(live_sweep);
    result.figures["recorded"] = {{"file", live_sweep},
                                  {"frames", live->sequence.frames.size()},
                                  {"frames_refused", live->frames_refused},
                                  {"tool_samples", live->tool_samples},
                                  {"seconds", live->seconds},
                                  {"segmented_while_recording", segmented_live},
                                  {"device_identity", live->device_identity}};
    result.figures["offline_command"] = "mrsns-cli session run " + session.folder().string() +
                                        " us-spatial-calibration --param calibration=" +
                                        session.resolve(live_sweep).string() +
                                        " --param phantom_to_reference=" + phantom_choice +
                                        (p.has("config") ? " --param config=" + p.text("config", "") : std::string()) +
                                        (p.has("validation") ? " --param validation=" + p.text("validation", "")
                                                             : std::string());
    result.figures["simulated"] = simulated;
  }
  std::ostringstream s;
  s.precision(3);
  if (live) {
    s << "recorded " << live->sequence.frames.size() << " frames live (" << segmented_live
      << " with every wire" << (live->complete ? "" : ", fewer than the target: the stream ended or the time ran out")
      << "); ";
  }
  s << "ImageToProbe from " << r.frames_used << " frames, tracker lag " << run.tracker_lag.lag_s * 1e3 << " ms"
    << (lag_source == "estimated"                 ? " (estimated)"
        : lag_source == "us-temporal-calibration" ? " (from the temporal calibration)"
                                                  : "")
    << ": validation 3D reprojection " << run.validation_errors.reprojection_3d_mean_mm << " +/- "
    << run.validation_errors.reprojection_3d_std_mm << " mm" << (plus_files ? " (PLUS 1.25 +/- 0.49, without a lag)" : "")
    << "; phantom from " << phantom_source;
  if (run.tracker_lag_check && run.tracker_lag_check->significant) {
    s << "; the sweep fits better with a tracker lag of " << run.tracker_lag_check->estimate.lag_s * 1e3
      << " ms: run the US temporal calibration, then this step again";
  }
  result.summary = s.str();
  return result;
}

StepResult runUsTemporalCalibration(Session& session, const Json& params, const StepContext& context) {
  const Params p("us-temporal-calibration", params,
                 {"config", "calibration", "validation", "search_half_range_ms", "search_step_ms", "source", "host",
                  "port", "duration_s", "idle_stop_s", "connect_timeout_s", "transform", "max_lag_ms"});
  const std::string source = p.text("source", "file");
  if (source == "plus") {
    for (const char* key : {"config", "calibration", "validation", "search_half_range_ms", "search_step_ms"}) {
      if (p.has(key)) {
        throw InvalidArgumentError(std::string("us-temporal-calibration: ") + key +
                                   " is for the N-wire recording (source=file), not a live up/down motion");
      }
    }
    return runLiveTemporalCalibration(session, p, context);
  }
  if (source != "file") {
    throw InvalidArgumentError("us-temporal-calibration: source must be file or plus, not '" + source + "'");
  }
  for (const char* key : {"host", "port", "duration_s", "idle_stop_s", "connect_timeout_s", "transform", "max_lag_ms"}) {
    if (p.has(key)) {
      throw InvalidArgumentError(std::string("us-temporal-calibration: ") + key + " is for source=plus");
    }
  }
  const Inputs in = readInputs(p, context);
  ultrasound::TrackerLagOptions lag;
  lag.estimate = true;
  lag.search_half_range_s = p.number("search_half_range_ms", 1000.0) * 1e-3;
  lag.search_step_s = p.number("search_step_ms", 20.0) * 1e-3;
  if (!(lag.search_half_range_s > 0.0) || !(lag.search_step_s > 0.0) || lag.search_step_s > lag.search_half_range_s) {
    throw InvalidArgumentError(
        "us-temporal-calibration: search_step_ms must be > 0 and at most search_half_range_ms (> 0)");
  }
  context.report(0.3, "searching the tracker lag (calibration error over lags)");
  // The spatial step's objective, so this lag is the one its lag check
  // reports and the one it applies once this step has run.
  const auto run = ultrasound::calibrateProbe(in.config, in.calibration, in.validation, {}, lag);
  checkCancel(context);
  Json curve = Json::array();
  for (const auto& c : run.tracker_lag.curve) {
    curve.push_back(Json{{"lag_ms", c.lag_s * 1e3}, {"reprojection_3d_mean_mm", c.reprojection_3d_mean_mm}});
  }
  StepResult result;
  result.ok = true;
  result.figures = {{"tracker_lag_ms", run.tracker_lag.lag_s * 1e3},
                    {"curvature_mm_per_s2", run.tracker_lag.curvature_mm_per_s2},
                    {"validation_reprojection_3d_mean_mm_at_lag", run.validation_errors.reprojection_3d_mean_mm},
                    {"curve", curve},
                    {"seconds", run.seconds}};
  std::ostringstream s;
  s.precision(3);
  s << "tracker lag " << run.tracker_lag.lag_s * 1e3 << " ms (validation 3D reprojection "
    << run.validation_errors.reprojection_3d_mean_mm << " mm at that lag)";
  result.summary = s.str();
  return result;
}

}  // namespace mrsns::workflow::detail
