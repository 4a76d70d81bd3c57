// `mrsns-cli calibrate-pivot` and `calibrate-spin`: tracked tool calibration
// from recorded poses.
#include <cmath>
#include <sstream>

#include "cli_context.h"
#include "json_vectors.h"
#include "mrsns/io/transform_io.h"
#include "mrsns/registration/pivot_calibration.h"
#include "mrsns/registration/spin_calibration.h"
#include "pose_source.h"

namespace mrsns::cli {
namespace {

constexpr double kDegPerRad = 180.0 / 3.14159265358979323846;

struct PivotVerbOptions {
  PoseSourceOptions source;
  bool robust = false;
  double inlier_threshold_mm = 1.0;
  double min_rotation_deg = 10.0;
  std::string output;
};

Report runPivot(const PivotVerbOptions& options) {
  const auto loaded = loadPoses(options.source);
  registration::PivotOptions pivot_options;
  pivot_options.robust = options.robust;
  pivot_options.inlier_threshold_mm = options.inlier_threshold_mm;
  pivot_options.min_rotation_range = options.min_rotation_deg / kDegPerRad;
  const auto result = registration::calibratePivot(loaded.poses, pivot_options);

  Report report;
  report.json["verb"] = "calibrate-pivot";
  report.json["poses"] = loaded.summary;
  report.json["tip_marker_mm"] = vectorJson(result.tip_marker);
  report.json["tip_length_mm"] = result.tip_marker.norm();
  report.json["pivot_point_mm"] = vectorJson(result.pivot_tracker);
  report.json["rms_mm"] = result.rms_mm;
  report.json["max_residual_mm"] = result.max_residual_mm;
  report.json["inliers"] = result.inlier_count;
  report.json["outliers"] = static_cast<int>(loaded.poses.size()) - result.inlier_count;
  report.json["rotation_range_deg"] = result.rotation_range * kDegPerRad;
  report.json["condition_number"] = result.condition_number;
  report.json["robust"] = options.robust;
  report.json["residuals_mm"] = result.residuals_mm;
  if (!options.output.empty()) {
    // A Slicer transform node "TipToMarker": its ToParent maps tip -> marker
    // (translation by the tip offset); io/transform_io.h's convention for the file.
    Eigen::Isometry3d marker_T_tip = Eigen::Isometry3d::Identity();
    marker_T_tip.translation() = result.tip_marker;
    io::writeChildToParent(marker_T_tip.matrix(), options.output);
    report.json["output"] = options.output;
  }
  std::ostringstream text;
  text << "Pivot calibration of " << loaded.summary.value("transform", std::string("poses")) << " ("
       << result.inlier_count << " of " << loaded.poses.size() << " poses used)\n"
       << "  tip in marker frame: " << formatVector(result.tip_marker) << " mm (length " << result.tip_marker.norm()
       << " mm)\n"
       << "  pivot point:         " << formatVector(result.pivot_tracker) << " mm\n"
       << "  RMS residual:        " << result.rms_mm << " mm (max " << result.max_residual_mm << " mm)\n"
       << "  rotation range:      " << result.rotation_range * kDegPerRad << " deg\n"
       << "  condition number:    " << result.condition_number << '\n';
  if (!options.output.empty()) text << "  written: " << options.output << '\n';
  report.text = text.str();
  return report;
}

struct SpinVerbOptions {
  PoseSourceOptions source;
  std::vector<double> tip;
  std::vector<double> line_start;
  double min_spin_deg = 30.0;
  std::string output;
};

Report runSpin(const SpinVerbOptions& options) {
  const auto loaded = loadPoses(options.source);
  registration::SpinOptions spin_options;
  spin_options.min_spin_angle = options.min_spin_deg / kDegPerRad;
  Eigen::Vector3d tip = Eigen::Vector3d::Zero();
  if (!options.tip.empty()) tip = Eigen::Vector3d(options.tip[0], options.tip[1], options.tip[2]);
  if (!options.output.empty() && options.tip.empty()) {
    throw InvalidArgumentError("calibrate-spin --output needs --tip (the tip frame's origin, from calibrate-pivot)");
  }
  Eigen::Vector3d line_start = Eigen::Vector3d::Zero();
  if (!options.line_start.empty()) {
    line_start = Eigen::Vector3d(options.line_start[0], options.line_start[1], options.line_start[2]);
  }
  // The shaft points towards the tip along the line from line_start (the marker's origin by default).
  const Eigen::Vector3d towards_tip = tip - line_start;
  if (!options.tip.empty() && !(towards_tip.norm() >= 1.0)) {
    throw InvalidArgumentError("calibrate-spin: the tip is within 1 mm of " +
                               std::string(options.line_start.empty() ? "the marker's origin" : "--line-start") +
                               ": it cannot say which way the shaft points");
  }
  const auto result =
      registration::calibrateSpin(loaded.poses, spin_options, options.tip.empty() ? nullptr : &towards_tip);
  Report report;
  report.json["verb"] = "calibrate-spin";
  report.json["poses"] = loaded.summary;
  report.json["shaft_marker"] = vectorJson(result.shaft_marker);
  report.json["spin_angle_deg"] = result.spin_angle * kDegPerRad;
  report.json["axis_rms_deg"] = result.axis_rms_angle * kDegPerRad;
  report.json["axis_distinctness"] = result.axis_distinctness;
  if (!options.output.empty()) {
    // TipToMarker with the shaft as the tip frame's z (PLUS's convention); io/transform_io.h's file convention.
    const Eigen::Isometry3d marker_T_tip = registration::tipFrame(tip, result.shaft_marker);
    io::writeChildToParent(marker_T_tip.matrix(), options.output);
    report.json["output"] = options.output;
    report.json["tip_frame"] = Json::array();
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) report.json["tip_frame"].push_back(marker_T_tip.matrix()(r, c));
    }
  }
  std::ostringstream text;
  text << "Spin calibration (" << loaded.poses.size() << " poses)\n"
       << "  shaft direction in marker frame: " << formatVector(result.shaft_marker, 5) << '\n'
       << "  spin covered: " << result.spin_angle * kDegPerRad << " deg; axis wobble RMS "
       << result.axis_rms_angle * kDegPerRad << " deg\n";
  if (!options.output.empty()) text << "  written: " << options.output << '\n';
  report.text = text.str();
  return report;
}

}  // namespace

void registerCalibrateToolVerbs(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto pivot = std::make_shared<PivotVerbOptions>();
  auto* pivot_cmd = app.add_subcommand(
      "calibrate-pivot",
      "Pivot calibration of a tracked pointer: the tip offset in the marker frame from poses recorded while the "
      "tip rests in a divot and the tool pivots (refuses too little or one-axis motion)");
  addPoseSourceOptions(*pivot_cmd, pivot->source, "StylusToReference");
  pivot_cmd->add_flag("--robust", pivot->robust, "RANSAC + refit on inliers (for slips out of the divot)");
  pivot_cmd->add_option("--inlier-threshold", pivot->inlier_threshold_mm, "robust inlier threshold, mm")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  pivot_cmd->add_option("--min-rotation-deg", pivot->min_rotation_deg, "smallest rotation range accepted, degrees")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  pivot_cmd->add_option(
      "--output", pivot->output,
      "write the tip offset as the transform TipToMarker (tip -> marker): .tfm/.h5/.mat as 3D Slicer reads "
      "them (the inverse, LPS), .txt the plain 4x4 marker_T_tip");
  addJsonFlag(*pivot_cmd, options);
  verbs.emplace_back(pivot_cmd, [pivot] { return runPivot(*pivot); });

  auto spin = std::make_shared<SpinVerbOptions>();
  auto* spin_cmd = app.add_subcommand(
      "calibrate-spin",
      "Spin calibration: the shaft direction in the marker frame from poses recorded while the tool turns about "
      "its shaft");
  addPoseSourceOptions(*spin_cmd, spin->source, "StylusToReference");
  spin_cmd->add_option("--tip", spin->tip, "tip offset X Y Z (mm) from calibrate-pivot, to orient the shaft")
      ->expected(3);
  spin_cmd->add_option("--line-start", spin->line_start,
                       "X Y Z (mm, marker frame): the shaft points towards --tip from here (default the marker's "
                       "origin; a drill's flange origin when its marker sits beside the axis)")
      ->expected(3);
  spin_cmd->add_option("--min-spin-deg", spin->min_spin_deg, "smallest spin accepted, degrees")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  spin_cmd->add_option(
      "--output", spin->output,
      "write the tip's frame TipToMarker (origin at --tip, z along the shaft): .tfm/.h5/.mat as 3D Slicer "
      "reads them (the inverse, LPS), .txt the plain 4x4 marker_T_tip");
  addJsonFlag(*spin_cmd, options);
  verbs.emplace_back(spin_cmd, [spin] { return runSpin(*spin); });
}

}  // namespace mrsns::cli
