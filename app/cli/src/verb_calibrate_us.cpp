// `mrsns-cli calibrate-us`: N-wire spatial calibration of a tracked
// ultrasound probe (ImageToProbe) from PLUS recordings, with PLUS's error
// figures on a calibration and a validation sequence.
#include <array>
#include <cmath>
#include <sstream>

#include "cli_context.h"
#include "mrsns/core/error.h"
#include "mrsns/io/device_set.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/ultrasound/calibration_config.h"
#include "mrsns/ultrasound/probe_calibration.h"

namespace mrsns::cli {
namespace {

struct CalibrateUsOptions {
  std::string config;
  std::string calibration;
  std::string validation;
  std::string output_config;
  std::string reference_results;
  std::string objective = "both";
  std::string tracker_lag = "0";  // ms, or "auto"
  double lag_range_ms = 1000.0;
  bool no_lag_check = false;
};

Json matrixJson(const Eigen::Matrix4d& m) {
  Json out = Json::array();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) out.push_back(m(r, c));
  }
  return out;
}

Json errorsJson(const ultrasound::CalibrationErrorReport& e) {
  Json wires = Json::array();
  for (const auto& w : e.wires) {
    wires.push_back(Json{{"name", w.wire_name},
                         {"mean_px", {w.mean_px.x(), w.mean_px.y()}},
                         {"std_px", {w.std_px.x(), w.std_px.y()}},
                         {"mean_distance_mm", w.mean_distance_mm},
                         {"frames", w.count}});
  }
  return Json{{"frames", e.frames},
              {"reprojection_3d_mm",
               {{"mean", e.reprojection_3d_mean_mm},
                {"std", e.reprojection_3d_std_mm},
                {"kept", e.reprojection_3d_count},
                {"all_mean", e.reprojection_3d_all_mean_mm},
                {"all_std", e.reprojection_3d_all_std_mm}}},
              {"wire_distance_rms_mm", e.wire_distance_rms_mm},
              {"reprojection_2d_px", wires}};
}

Json segmentationJson(const ultrasound::SequenceSegmentation& s) {
  Json rejected = Json::array();
  for (const auto& r : s.reports) {
    if (!r.reason.empty()) rejected.push_back(Json{{"frame", r.frame_index}, {"reason", r.reason}});
  }
  return Json{{"total", s.total_frames},   {"segmented", s.segmented_frames}, {"without_pose", s.frames_without_pose},
              {"usable", s.frames.size()}, {"not_usable", rejected},          {"seconds", s.seconds}};
}

Report run(const CalibrateUsOptions& options) {
  const auto config = io::readDeviceSet(options.config);
  const auto calibration = io::readSequence(options.calibration);
  const auto validation = io::readSequence(options.validation);
  ultrasound::SpatialCalibrationOptions cal_options;
  cal_options.objective = options.objective == "middle-wire" ? ultrasound::CalibrationObjective::MiddleWirePoints
                          : options.objective == "distance-to-wires" ? ultrasound::CalibrationObjective::DistanceToWires
                                                                     : ultrasound::CalibrationObjective::Both;
  ultrasound::TrackerLagOptions lag;
  if (options.tracker_lag == "auto") {
    lag.estimate = true;
    lag.search_half_range_s = options.lag_range_ms * 1e-3;
    // The default: a recording that does not pin the lag down is calibrated
    // without one, and the JSON says why.
    lag.fall_back_to_zero = true;
  } else {
    try {
      std::size_t used = 0;
      lag.lag_s = std::stod(options.tracker_lag, &used) * 1e-3;
      if (used != options.tracker_lag.size() || !std::isfinite(lag.lag_s)) throw std::invalid_argument("trailing");
    } catch (const std::exception&) {
      throw InvalidArgumentError("--tracker-lag-ms: '" + options.tracker_lag +
                                 "' is neither a number of milliseconds nor 'auto'");
    }
    lag.check = !options.no_lag_check;
    lag.search_half_range_s = options.lag_range_ms * 1e-3;
  }
  const auto run = ultrasound::calibrateProbe(config, calibration, validation, cal_options, lag);
  const auto& r = run.result;

  Report report;
  auto& j = report.json;
  j["verb"] = "calibrate-us";
  j["config"] = options.config;
  j["objective"] = options.objective;
  j["image_to_probe"] = matrixJson(r.probe_T_image);
  j["pixel_spacing_mm"] = {r.pixel_spacing_mm.x(), r.pixel_spacing_mm.y()};
  j["calibration"] = errorsJson(r.calibration);
  j["calibration"]["sequence"] = options.calibration;
  j["calibration"]["segmentation"] = segmentationJson(run.calibration);
  j["calibration"]["frames_used"] = r.frames_used;
  j["calibration"]["frames_rejected"] = r.rejected_frames;
  j["validation"] = errorsJson(run.validation_errors);
  j["validation"]["sequence"] = options.validation;
  j["validation"]["segmentation"] = segmentationJson(run.validation);
  j["validation"]["frames_paired"] = run.validation_frames_paired;
  j["tracker_lag_ms"] = run.tracker_lag.lag_s * 1e3;
  j["tracker_lag_estimated"] = run.tracker_lag.estimated;
  if (run.tracker_lag.estimated) {
    Json curve = Json::array();
    for (const auto& c : run.tracker_lag.curve) {
      curve.push_back(Json{
          {"lag_ms", c.lag_s * 1e3}, {"reprojection_3d_mean_mm", c.reprojection_3d_mean_mm}, {"frames", c.frames}});
    }
    j["tracker_lag_curve"] = curve;
    j["tracker_lag_curvature_mm_per_s2"] = run.tracker_lag.curvature_mm_per_s2;
  }
  if (!run.tracker_lag.note.empty()) j["tracker_lag_note"] = run.tracker_lag.note;
  // What to do about a lag the sweep points to, in this tool's terms.
  const std::string lag_advice =
      run.tracker_lag_check && run.tracker_lag_check->significant
          ? run.tracker_lag_check->advice + " (mrsns-cli calibrate-temporal, or --tracker-lag-ms auto)"
          : std::string();
  if (run.tracker_lag_check) {
    const auto& c = *run.tracker_lag_check;
    Json check{{"estimated", c.estimate.estimated}, {"significant", c.significant}};
    if (c.estimate.estimated) {
      check["lag_ms"] = c.estimate.lag_s * 1e3;
      check["curvature_mm_per_s2"] = c.estimate.curvature_mm_per_s2;
      check["calibration_error_at_lag_mm"] = c.error_at_estimate_mm;
      check["calibration_error_as_applied_mm"] = c.error_as_applied_mm;
    }
    if (!c.estimate.note.empty()) check["note"] = c.estimate.note;
    if (c.significant) check["advice"] = lag_advice;
    j["tracker_lag_check"] = check;
  }
  j["seconds"] = run.seconds;

  std::ostringstream text;
  text << "ImageToProbe (" << options.objective << "), pixel spacing " << r.pixel_spacing_mm.x() << " x "
       << r.pixel_spacing_mm.y() << " mm:\n"
       << r.probe_T_image << "\n"
       << "  tracker lag " << run.tracker_lag.lag_s * 1e3 << " ms ("
       << (run.tracker_lag.estimated ? "estimated" : "given") << ")\n"
       << "  calibration: " << r.frames_used << " frames used (" << r.rejected_frames.size() << " outliers, "
       << run.calibration.total_frames - run.calibration.frames.size() << " not usable), 3D reprojection "
       << r.calibration.reprojection_3d_mean_mm << " +/- " << r.calibration.reprojection_3d_std_mm << " mm\n"
       << "  validation: " << run.validation_frames_paired << "/" << run.validation.total_frames
       << " frames, 3D reprojection " << run.validation_errors.reprojection_3d_mean_mm << " +/- "
       << run.validation_errors.reprojection_3d_std_mm << " mm\n";
  if (!lag_advice.empty()) text << "  warning: " << lag_advice << "\n";
  if (!options.reference_results.empty()) {
    const Eigen::Matrix4d ref = ultrasound::readPlusImageToProbe(options.reference_results);
    const double w = static_cast<double>(calibration.geometry.size[0] - 1);
    const double h = static_cast<double>(calibration.geometry.size[1] - 1);
    Json corners = Json::array();
    double worst = 0.0;
    for (const auto& [x, y] : std::array<std::pair<double, double>, 4>{{{0, 0}, {w, 0}, {0, h}, {w, h}}}) {
      const Eigen::Vector4d p(x, y, 0.0, 1.0);
      const double d = (r.probe_T_image * p - ref * p).head<3>().norm();
      corners.push_back(d);
      worst = std::max(worst, d);
    }
    // The reference matrix judged by the same evaluator on the same segmented
    // frames with the same pose pairing (lag), so the two calibrations are
    // compared like for like.
    const auto ref_validation = ultrasound::evaluateSpatialCalibration(
        ref, run.validation_paired, ultrasound::nwireGeometry(*config.phantom), ultrasound::phantomToReference(config),
        ultrasound::wireNames(*config.phantom));
    j["reference"] = Json{{"results", options.reference_results},
                          {"image_to_probe", matrixJson(ref)},
                          {"corner_distances_mm", corners},
                          {"max_corner_distance_mm", worst},
                          {"validation", errorsJson(ref_validation)}};
    text << "  image corners vs the reference ImageToProbe: up to " << worst << " mm\n"
         << "  the reference ImageToProbe on the same validation frames: 3D reprojection "
         << ref_validation.reprojection_3d_mean_mm << " +/- " << ref_validation.reprojection_3d_std_mm << " mm\n";
  }
  if (!options.output_config.empty()) {
    ultrasound::writeCoordinateDefinition(options.config, options.output_config, "Image", "Probe", r.probe_T_image,
                                          run.validation_errors.reprojection_3d_mean_mm);
    j["output_config"] = options.output_config;
    text << "  written: " << options.output_config << " (CoordinateDefinitions/Transform ImageToProbe)\n";
  }
  report.text = text.str();
  return report;
}

}  // namespace

void registerCalibrateUsVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto opts = std::make_shared<CalibrateUsOptions>();
  auto* sub = app.add_subcommand(
      "calibrate-us",
      "N-wire spatial calibration of a tracked ultrasound probe (ImageToProbe with pixel spacing) from PLUS "
      "recordings; 3D/2D reprojection errors as PLUS's fCal reports them");
  sub->add_option("--config", opts->config, "PLUS device-set configuration (phantom, PhantomToReference, segmentation)")
      ->required();
  sub->add_option("--calibration", opts->calibration, "tracked B-mode sequence of the phantom for calibration")
      ->required();
  sub->add_option("--validation", opts->validation, "a second such sequence for validation")->required();
  sub->add_option("--output-config", opts->output_config,
                  "write the configuration with the ImageToProbe in CoordinateDefinitions (PLUS-compatible)");
  sub->add_option("--reference-results", opts->reference_results,
                  "a PLUS ProbeCalibration results file: distances of the mapped image corners to its ImageToProbe");
  sub->add_option(
         "--tracker-lag-ms", opts->tracker_lag,
         "tracker lag applied to both sequences (PLUS TrackerLagSec convention, ms; 0, the default, calibrates "
         "as PLUS's fCal does, with the streams as recorded), or 'auto' to estimate it from the calibration "
         "sequence and apply it (falls back to 0 when the sweep does not pin it down)")
      ->default_val("0");
  sub->add_option("--tracker-lag-range-ms", opts->lag_range_ms,
                  "half width of the lag search of 'auto' and of the lag check (ms)")
      ->default_val(1000.0)
      ->check(CLI::PositiveNumber);
  sub->add_option(
         "--objective", opts->objective,
         "least-squares criterion: both residual sets together (default), PLUS's middle-wire points alone, or the "
         "distance of every dot to its wire alone")
      ->check(CLI::IsMember({"middle-wire", "distance-to-wires", "both"}))
      ->capture_default_str();
  sub->add_flag("--no-lag-check", opts->no_lag_check,
                "with a given lag, skip the search that reports (tracker_lag_check) whether the sweep fits markedly "
                "better at another lag");
  addJsonFlag(*sub, options);
  verbs.emplace_back(sub, [opts] { return run(*opts); });
}

}  // namespace mrsns::cli
