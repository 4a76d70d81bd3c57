// Session results against the truth file: one figure per result the truth
// can judge, each with the definition of its error.
#include "mrsns/simulation/score.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <tuple>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/surface_distance.h"
#include "mrsns/io/statismo_io.h"
#include "mrsns/simulation/soft_tissue.h"
#include "score_json.h"
#include "score_placement.h"

namespace mrsns::simulation {

namespace {

using namespace score_detail;

// The board's corners digitised with the stylus against where the printed pattern truly sits on its marker.
void scoreCheckerboardDigitisation(const Json& session, const Json& truth, Json& scored, Json& not_scored) {
  const Json* estimate = recordedTransform(session, "checkerboard-digitisation", "GridToBoard");
  if (estimate == nullptr) {
    not_scored.push_back("checkerboard-digitisation (not run, failed, or not acquired from mrsns-sim)");
    return;
  }
  if (!truth.contains("hmd_camera") || !truth["hmd_camera"].contains("GridToBoardMarker")) {
    not_scored.push_back("checkerboard-digitisation (the truth has no tracked board)");
    return;
  }
  Eigen::Isometry3d est = Eigen::Isometry3d::Identity(), real = Eigen::Isometry3d::Identity();
  est.matrix() = matrix(*estimate, "session GridToBoard");
  real.matrix() = matrix(truth["hmd_camera"]["GridToBoardMarker"], "truth GridToBoardMarker");
  const auto& b = truth["hmd_camera"]["board"];
  double worst = 0.0;
  for (int r = 0; r < b["rows"].get<int>(); ++r) {
    for (int c = 0; c < b["cols"].get<int>(); ++c) {
      const Eigen::Vector3d p(c * b["square_mm"].get<double>(), r * b["square_mm"].get<double>(), 0.0);
      worst = std::max(worst, (est * p - real * p).norm());
    }
  }
  scored["checkerboard_digitisation"] = {
      {"definition", "the grid fitted to the touched corners (GridToBoard, paper 000's T_p^b) against where the "
                     "printed pattern truly sits on the board's marker: rotation, translation, and the farthest corner"},
      {"rotation_error_deg", Eigen::AngleAxisd(real.linear().transpose() * est.linear()).angle() * 180.0 / M_PI},
      {"translation_error_mm", (est.translation() - real.translation()).norm()},
      {"max_corner_error_mm", worst},
      {"noise_model", {{"placement_error_mm", truth["hmd_camera"].value("board_touch_placement_error_mm", 0.0)}}}};
}

// Paper 000's hand-eye calibration against the camera's true place on the headset's marker, and what that error
// does to a point the camera sees 0.5 and 1 m ahead (where a hologram registered through the camera would go).
void scoreHmdCameraCalibration(const Json& session, const Json& truth, Json& scored, Json& not_scored) {
  const Json* estimate = recordedTransform(session, "hmd-camera-calibration", "CameraToHeadset");
  if (estimate == nullptr) {
    not_scored.push_back("hmd-camera-calibration (not run, failed, or not acquired from mrsns-sim)");
    return;
  }
  if (!truth.contains("hmd_camera")) {
    not_scored.push_back("hmd-camera-calibration (the truth has no headset camera)");
    return;
  }
  Eigen::Isometry3d est = Eigen::Isometry3d::Identity(), real = Eigen::Isometry3d::Identity();
  est.matrix() = matrix(*estimate, "session CameraToHeadset");
  real.matrix() = matrix(truth["hmd_camera"]["CameraToHeadsetMarker"], "truth CameraToHeadsetMarker");
  const double angle = Eigen::AngleAxisd(real.linear().transpose() * est.linear()).angle();
  Json h{{"definition",
          "the estimated camera pose in the headset marker's frame (CameraToHeadset, paper 000's T_c^h) against "
          "the truth: rotation and translation error, and the distance between where the estimate and the truth "
          "put a point 0.5 m and 1 m ahead of the camera"},
         {"rotation_error_deg", angle * 180.0 / M_PI},
         {"translation_error_mm", (est.translation() - real.translation()).norm()},
         {"error_at_500mm_mm", (est * Eigen::Vector3d(0, 0, 500) - real * Eigen::Vector3d(0, 0, 500)).norm()},
         {"error_at_1000mm_mm", (est * Eigen::Vector3d(0, 0, 1000) - real * Eigen::Vector3d(0, 0, 1000)).norm()}};
  if (truth["hmd_camera"].contains("noise_model")) h["noise_model"] = truth["hmd_camera"]["noise_model"];
  scored["hmd_camera_calibration"] = h;
}

// The HMD calibration against where the headset's world truly is, and the overlay measured where the wearer
// sees it (paper 001 Eq. 23): the patient's fiducials as the headset displayed them against where they were.
void scoreHmdCalibration(const Json& session, const Json& truth, Json& scored, Json& not_scored) {
  const Json* est = recordedTransform(session, "hmd-calibration", "HologramToTracker");
  if (est == nullptr) {
    not_scored.push_back(
        "hmd-calibration (not run, failed, without HologramToTracker, or not acquired from mrsns-sim)");
    return;
  }
  if (!truth.contains("HeadsetWorldToTracker")) {
    not_scored.push_back("hmd-calibration (the scenario's headset is not tracked: no truth of its world frame)");
    return;
  }
  const Json& st = truth.at("static");
  const Eigen::Isometry3d e(matrix(*est, "session HologramToTracker"));
  const Eigen::Isometry3d t(matrix(truth["HeadsetWorldToTracker"], "truth HeadsetWorldToTracker"));
  Json h = {{"definition",
             "HologramToTracker against the headset's true world frame: translation and rotation error, the "
             "error of the map where the cube's hologram was shown, and at the patient's true fiducials (where "
             "the headset shows a hologram meant for each). overlay_at_headset: paper 001 Eq. 23, the RMS over "
             "the patient's fiducials of the distance between where the headset displayed them (the workstation's verification overlay, "
             "through the whole chain: tracking, registration, HMD calibration, headset jitter) and where they "
             "were, per displayed frame"},
            {"translation_error_mm", (e.translation() - t.translation()).norm()},
            {"rotation_error_deg", rotationAngleBetween(e.linear(), t.linear()) * 180.0 / M_PI}};
  if (st.contains("hmd_cube_operator")) h["noise_model"] = st["hmd_cube_operator"];
  const Json& figures = session["steps"]["hmd-calibration"]["figures"];
  const Json position = figures.value("acquisition", Json::object()).value("hologram_position_mm", Json());
  if (position.is_array() && position.size() == 3) {
    // Where the operator matched the cube: the map's error there is what the matching itself left.
    const Eigen::Vector3d c(position[0].get<double>(), position[1].get<double>(), position[2].get<double>());
    h["error_at_cube_hologram_mm"] = (e * c - t * c).norm();
  }
  std::vector<Eigen::Vector3d> fiducials_ct;
  for (const auto& f : st.value("fiducials_ct", Json::array())) {
    fiducials_ct.emplace_back(f["ct_mm"][0].get<double>(), f["ct_mm"][1].get<double>(), f["ct_mm"][2].get<double>());
  }
  const Json verification = figures.value("acquisition", Json::object()).value("verification_model", Json());
  const std::string model = verification.is_string() ? verification.get<std::string>() : std::string();
  std::vector<double> calibration_errors, overlay_rms;
  for (const auto& d : truth.value("hmd_displayed", Json::array())) {
    if (!d.contains("tracker_T_ct")) continue;
    const Eigen::Isometry3d tracker_T_ct = compactPose(d["tracker_T_ct"]);
    if (calibration_errors.empty()) {
      for (const auto& p : fiducials_ct) {
        const Eigen::Vector3d x = tracker_T_ct * p;
        // The workstation puts a hologram meant for x at e^-1 x in the headset's world; the headset shows it at
        // t e^-1 x.
        calibration_errors.push_back((t * (e.inverse() * x) - x).norm());
      }
    }
    if (model.empty() || !d.contains("tracker_T_model")) continue;
    for (std::size_t i = 0; i < d["models"].size(); ++i) {
      if (d["models"][i] != model || !d["visible"][i].get<bool>()) continue;
      const Eigen::Isometry3d shown = compactPose(d["tracker_T_model"][i]);
      double sum = 0.0;
      for (const auto& p : fiducials_ct) sum += (shown * p - tracker_T_ct * p).squaredNorm();
      if (!fiducials_ct.empty()) overlay_rms.push_back(std::sqrt(sum / static_cast<double>(fiducials_ct.size())));
    }
  }
  if (!calibration_errors.empty()) h["error_at_patient_fiducials"] = stats(calibration_errors);
  if (!overlay_rms.empty()) {
    h["overlay_at_headset"] = stats(overlay_rms);
    h["overlay_at_headset"]["frames"] = overlay_rms.size();
  } else {
    h["overlay_at_headset"] = model.empty() ? "not measured: the step showed no verification overlay (no registration)"
                                            : "not measured: the headset never displayed " + model;
  }
  scored["hmd_calibration"] = h;
}

}  // namespace

// The model's shape at standardised coefficients c (mean + U diag(sqrt(lambda)) c), placed in the CT.
TriangleMesh shapeInCt(const ShapeModel& model, const Eigen::VectorXd& c, const Eigen::Isometry3d& ct_T_model) {
  Eigen::VectorXd full = Eigen::VectorXd::Zero(model.modeCount());
  full.head(std::min(full.size(), c.size())) = c.head(std::min(full.size(), c.size()));
  const Eigen::VectorXd shape = model.mean + model.basis * (model.variances.cwiseMax(0.0).cwiseSqrt().asDiagonal() * full);
  TriangleMesh mesh = model.reference;
  mesh.frame.clear();
  mesh.normals.resize(0, 3);
  for (Eigen::Index i = 0; i < mesh.vertices.rows(); ++i) {
    mesh.vertices.row(i) = (ct_T_model * Eigen::Vector3d(shape.segment<3>(3 * i))).transpose();
  }
  return mesh;
}

// The soft tissue navigation followed on the room's ultrasound (the navigation step's soft-tissue file: the
// posterior after every update) against the room's deforming vessel at each frame's instant (paper 001 Eq. 21,
// 22), beside the prior (the model's mean) at the same instants.
void scoreSoftTissue(const std::filesystem::path& session_dir, const Json& session, const Json& truth, Json& scored,
                     Json& not_scored) {
  const Json& st = truth.at("static");
  const Json* step = session.contains("steps") && session["steps"].contains("navigation")
                         ? &session["steps"]["navigation"]
                         : nullptr;
  if (!step || step->value("status", "") != "ok" || !fromSimulatedRoom(*step) ||
      !(*step)["figures"].contains("soft_tissue") || !(*step)["figures"]["soft_tissue"].contains("file")) {
    not_scored.push_back("navigation soft tissue (not run, off, refused, or not acquired from mrsns-sim)");
    return;
  }
  if (!st.contains("soft_tissue")) {
    not_scored.push_back("navigation soft tissue (the room's scenario has no deforming soft tissue)");
    return;
  }
  const Json record = readJson(session_dir / (*step)["figures"]["soft_tissue"]["file"].get<std::string>(),
                               "navigation soft-tissue file");
  if (record.value("format", "") != "mrsns-soft-tissue/1") {
    throw FormatError("the navigation's soft-tissue file is not mrsns-soft-tissue/1");
  }
  const ShapeModel estimate_model = io::readStatismoModel(session_dir / record.at("shape_model").get<std::string>());
  const Eigen::Isometry3d estimate_ct_T_model(matrix(record.at("ct_T_model"), "soft-tissue file ct_T_model"));

  // The room's vessel, rebuilt from the truth file's parameters (the same seed draws the same trajectory).
  const Json& t = st["soft_tissue"];
  SoftTissueSpec spec;
  spec.shape_model = t.at("shape_model").get<std::string>();
  spec.ct_T_model = Eigen::Isometry3d(matrix(t.at("ModelToCT"), "truth soft tissue ModelToCT"));
  spec.modes = static_cast<int>(t.at("frequency_factor").size());
  spec.amplitude_sd = t.at("amplitude_sd").get<double>();
  spec.period_s = t.at("period_s").get<double>();
  spec.push_sd = t.value("push_sd", std::vector<double>{});
  spec.push_start_s = t.value("push_start_s", 0.0);
  spec.push_ramp_s = t.value("push_ramp_s", 1.0);
  const DeformingSoftTissue room(io::readStatismoModel(spec.shape_model), spec, st.at("seed").get<std::uint64_t>());
  ShapeModel truth_model = io::readStatismoModel(spec.shape_model);
  const double utc0 = truth.at("utc_start").get<double>();

  const Json& updates = record.at("updates");
  if (updates.empty()) {
    not_scored.push_back("navigation soft tissue (no posterior update in the soft-tissue file)");
    return;
  }
  // At most 200 updates, evenly spread: a surface distance per update is milliseconds, a run has thousands.
  const std::size_t stride = std::max<std::size_t>(1, updates.size() / 200);
  const bool corresponding = estimate_model.mean.size() == truth_model.mean.size();
  const TriangleMesh prior = shapeInCt(estimate_model, Eigen::VectorXd::Zero(0), estimate_ct_T_model);
  std::vector<double> sd, sd_max, fp, prior_sd, prior_fp;
  for (std::size_t i = 0; i < updates.size(); i += stride) {
    const Json& u = updates[i];
    const auto coefficients = u.at("coefficients").get<std::vector<double>>();
    const Eigen::VectorXd c = Eigen::Map<const Eigen::VectorXd>(coefficients.data(),
                                                                static_cast<Eigen::Index>(coefficients.size()));
    const double at_s = u.at("timestamp").get<double>() - utc0;
    const TriangleMesh true_mesh = shapeInCt(truth_model, room.coefficients(at_s), spec.ct_T_model);
    const TriangleMesh posterior = shapeInCt(estimate_model, c, estimate_ct_T_model);
    const auto d = surfaceDistance(posterior, true_mesh);
    sd.push_back(d.mean);
    sd_max.push_back(d.hausdorff);
    prior_sd.push_back(surfaceDistance(prior, true_mesh).mean);
    if (corresponding) {
      fp.push_back((posterior.vertices - true_mesh.vertices).rowwise().norm().mean());
      prior_fp.push_back((prior.vertices - true_mesh.vertices).rowwise().norm().mean());
    }
  }
  auto mean = [](const std::vector<double>& v) {
    double s = 0.0;
    for (double x : v) s += x;
    return v.empty() ? 0.0 : s / static_cast<double>(v.size());
  };
  Json out = {
      {"definition",
       "the posterior after each update (every k-th of the navigation's soft-tissue file, at most 200) against the "
       "room's vessel at that frame's instant, both in the CT: E^SD the symmetric mean surface distance (Eq. 22), "
       "E^FP the mean distance of corresponding vertices (Eq. 21 at every vertex; the paper's at 7 fiducial "
       "points), when the session's model and the room's have the same points; the prior (the model's mean) at "
       "the same instants beside them"},
      {"updates_in_file", updates.size()},
      {"updates_scored", sd.size()},
      {"posterior_sd_mean_mm", mean(sd)},
      {"posterior_sd_max_mm", *std::max_element(sd_max.begin(), sd_max.end())},
      {"prior_sd_mean_mm", mean(prior_sd)}};
  if (corresponding) {
    out["posterior_fp_mm"] = mean(fp);
    out["prior_fp_mm"] = mean(prior_fp);
  }
  scored["navigation_soft_tissue"] = out;
}

std::string scoreSession(const std::filesystem::path& session_dir, const std::filesystem::path& truth_file) {
  const Json session = readJson(session_dir / "session.json", "session");
  const Json truth = readJson(truth_file, "truth file");
  if (truth.value("format", "") != "mrsns-truth/1") {
    throw FormatError(truth_file.string() + " is not an mrsns-sim truth file (format mrsns-truth/1)");
  }
  const Json& st = truth.at("static");
  Json out;
  out["scenario"] = st.value("scenario", "");
  out["seed"] = st.value("seed", 0);
  Json scored = Json::object();
  Json not_scored = Json::array();

  if (const Json* est = recordedTransform(session, "us-spatial-calibration", "ImageToProbe")) {
    if (st.contains("ImageToProbe")) {
      // The session's ImageToProbe maps pixels to probe mm (PLUS convention, spacing included); the truth maps
      // image mm to probe mm. Error: distance between where each maps the image's corners and centre.
      const Eigen::Matrix4d probe_T_pixel = matrix(*est, "session ImageToProbe");
      Eigen::Matrix4d truth_probe_T_pixel = matrix(st["ImageToProbe"], "truth ImageToProbe");
      const double sx = st["image_spacing_mm"][0].get<double>(), sy = st["image_spacing_mm"][1].get<double>();
      truth_probe_T_pixel.block<3, 1>(0, 0) *= sx;
      truth_probe_T_pixel.block<3, 1>(0, 1) *= sy;
      const double w = st["image_size_px"][0].get<double>() - 1.0, h = st["image_size_px"][1].get<double>() - 1.0;
      std::vector<double> errors;
      for (const auto& [u, v] : {std::pair{0.0, 0.0}, {w, 0.0}, {0.0, h}, {w, h}, {w / 2, h / 2}}) {
        const Eigen::Vector4d p(u, v, 0.0, 1.0);
        errors.push_back(((probe_T_pixel - truth_probe_T_pixel) * p).head<3>().norm());
      }
      scored["us_spatial_calibration"] = {{"definition",
                                           "distance between estimated and true ImageToProbe at the "
                                           "image's four corners and centre"},
                                          {"error", stats(errors)}};
    }
  } else {
    not_scored.push_back(
        "us-spatial-calibration (not run, failed, without ImageToProbe, or not acquired from mrsns-sim)");
  }

  if (const Json* est = recordedTransform(session, "us-phantom-registration", "PhantomToReference")) {
    if (!st.contains("PhantomToReference") || !st.contains("phantom_wires_mm") || st["phantom_wires_mm"].empty()) {
      not_scored.push_back("us-phantom-registration (the truth has no phantom or no wire ends to judge it at)");
    } else {
      // Judged where it matters to the calibration: at the phantom's wires (the corners of their box).
      const Eigen::Matrix4d e = matrix(*est, "session PhantomToReference");
      const Eigen::Matrix4d t = matrix(st["PhantomToReference"], "truth PhantomToReference");
      std::vector<double> errors;
      for (const auto& end : st["phantom_wires_mm"]) {
        const Eigen::Vector4d p(end[0].get<double>(), end[1].get<double>(), end[2].get<double>(), 1.0);
        errors.push_back(((e - t) * p).head<3>().norm());
      }
      const Eigen::Matrix3d dr = e.block<3, 3>(0, 0).transpose() * t.block<3, 3>(0, 0);
      const double angle_deg = std::acos(std::clamp((dr.trace() - 1.0) / 2.0, -1.0, 1.0)) * 180.0 / M_PI;
      scored["us_phantom_registration"] = {
          {"definition", "distance between where the estimated and the true PhantomToReference put the ends of the "
                         "phantom's wires; rotation error"},
          {"error_at_wires", stats(errors)},
          {"rotation_error_deg", angle_deg}};
    }
  } else {
    not_scored.push_back(
        "us-phantom-registration (not run, failed, without PhantomToReference, or not acquired from mrsns-sim)");
  }

  const Json& steps = session.contains("steps") ? session["steps"] : Json::object();
  // The tools' tips: the stylus (pivot-calibration) and the drill on the flange (drill-calibration).
  for (const auto& [step, key, default_tool] : {std::tuple{"pivot-calibration", "pivot_calibration", "Stylus"},
                                                std::tuple{"drill-calibration", "drill_calibration", "Flange"}}) {
    if (!(steps.contains(step) && steps[step].value("status", "") == "ok" && fromSimulatedRoom(steps[step]))) {
      not_scored.push_back(std::string(step) + " (not run, failed, or not acquired from mrsns-sim)");
      continue;
    }
    const Json& f = steps[step]["figures"];
    const std::string tool = f.value("tool", default_tool);
    const Json tips = st.value("tool_tips_mm", Json::object());
    const std::string tip_name = tool + "TipTo" + tool;
    if (tips.contains(tool + "ToTracker") && f.contains("transforms") && f["transforms"].contains(tip_name)) {
      const Eigen::Matrix4d marker_T_tip = matrix(f["transforms"][tip_name], "session " + tip_name);
      const Json& t = tips[tool + "ToTracker"];
      const Eigen::Vector3d truth_tip(t[0].get<double>(), t[1].get<double>(), t[2].get<double>());
      scored[key] = {{"definition", "distance between the estimated and the true tool tip, in the tool's marker frame"},
                     {"tool", tool},
                     {"tip_error_mm", (marker_T_tip.block<3, 1>(0, 3) - truth_tip).norm()}};
    } else {
      not_scored.push_back(std::string(step) + " (the truth has no tip for " + tool + ")");
    }
  }

  // The tools' shafts: the stylus (spin-calibration) and the drill's axis (drill-spin-calibration).
  for (const auto& [step, key, default_tool] :
       {std::tuple{"spin-calibration", "spin_calibration", "Stylus"},
        std::tuple{"drill-spin-calibration", "drill_spin_calibration", "Flange"}}) {
    if (!(steps.contains(step) && steps[step].value("status", "") == "ok" && fromSimulatedRoom(steps[step]))) {
      not_scored.push_back(std::string(step) + " (not run, failed, or not acquired from mrsns-sim)");
      continue;
    }
    const Json& f = steps[step]["figures"];
    const std::string tool = f.value("tool", default_tool);
    const Json shafts = st.value("tool_shafts", Json::object());
    if (!shafts.contains(tool + "ToTracker") || !f.contains("shaft_marker")) {
      not_scored.push_back(std::string(step) + " (the truth has no shaft for " + tool + ")");
      continue;
    }
    const Json& t = shafts[tool + "ToTracker"];
    const Json& e = f["shaft_marker"];
    const Eigen::Vector3d true_shaft(t[0].get<double>(), t[1].get<double>(), t[2].get<double>());
    const Eigen::Vector3d estimate(e[0].get<double>(), e[1].get<double>(), e[2].get<double>());
    const double angle = std::acos(std::clamp(true_shaft.normalized().dot(estimate.normalized()), -1.0, 1.0));
    constexpr double kScrewLengthMm = 40.0;
    scored[key] = {{"definition", "angle between the estimated and the true shaft direction in the tool's marker "
                                  "frame; the lateral error it makes 40 mm along the shaft (a pedicle screw's length)"},
                   {"tool", tool},
                   {"shaft_error_deg", angle * 180.0 / M_PI},
                   {"lateral_error_at_40mm_mm", kScrewLengthMm * std::sin(angle)}};
  }

  scoreCheckerboardDigitisation(session, st, scored, not_scored);
  scoreHmdCameraCalibration(session, st, scored, not_scored);

  if (steps.contains("us-temporal-calibration") && steps["us-temporal-calibration"].value("status", "") == "ok" &&
      fromSimulatedRoom(steps["us-temporal-calibration"]) && st.contains("video_lag_s")) {
    const double estimated_ms = steps["us-temporal-calibration"]["figures"].value("tracker_lag_ms", 0.0);
    // A video that lags the tracking by L pairs each frame with the pose L earlier: a tracker lag of -L.
    const double expected_ms = -st["video_lag_s"].get<double>() * 1e3;
    scored["us_temporal_calibration"] = {{"definition",
                                          "estimated tracker lag minus the true one (the video's lag, "
                                          "negated)"},
                                         {"estimated_ms", estimated_ms},
                                         {"true_ms", expected_ms},
                                         {"error_ms", estimated_ms - expected_ms}};
  } else {
    not_scored.push_back("us-temporal-calibration (not run, failed, or not acquired from mrsns-sim)");
  }

  if (const Json* est = recordedTransform(session, "registration", "CTToPatient")) {
    if (st.contains("CTToReference")) {
      const Eigen::Matrix4d e = matrix(*est, "session CTToPatient"), t = matrix(st["CTToReference"], "truth");
      const auto errorAt = [&](const Json& p) {
        const Eigen::Vector4d q(p[0].get<double>(), p[1].get<double>(), p[2].get<double>(), 1.0);
        return ((e - t) * q).head<3>().norm();
      };
      std::vector<double> errors, screw_errors;
      for (const auto& f : st.value("fiducials_ct", Json::array())) errors.push_back(errorAt(f["ct_mm"]));
      for (const auto& path : st.value("screw_paths_ct", Json::array())) {
        screw_errors.push_back(errorAt(path["entry_ct_mm"]));
        screw_errors.push_back(errorAt(path["target_ct_mm"]));
      }
      if (errors.empty()) errors.push_back(((e - t) * Eigen::Vector4d(0, 0, 0, 1)).head<3>().norm());
      scored["registration"] = {{"definition",
                                 "target registration error at the true fiducial positions (CT "
                                 "origin when the patient has none), and at the planned screws' entries "
                                 "and targets"},
                                {"error", stats(errors)}};
      if (!screw_errors.empty()) scored["registration"]["error_at_planned_screws"] = stats(screw_errors);
    }
  } else {
    not_scored.push_back("registration (not run, failed, without CTToPatient, or not acquired from mrsns-sim)");
  }

  if (const Json* est = recordedTransform(session, "robot-calibration", "RobotBaseToTracker")) {
    if (st.contains("RobotBaseToTracker")) {
      const Eigen::Isometry3d e(matrix(*est, "session RobotBaseToTracker"));
      const Eigen::Isometry3d t(matrix(st["RobotBaseToTracker"], "truth RobotBaseToTracker"));
      scored["robot_calibration"] = {
          {"definition",
           "RobotBaseToTracker: translation and rotation error, and the error of a point 500 mm "
           "in front of the base"},
          {"translation_error_mm", (e.translation() - t.translation()).norm()},
          {"rotation_error_deg", rotationAngleBetween(e.linear(), t.linear()) * 180.0 / M_PI},
          {"error_500mm_mm", ((e * Eigen::Vector3d(0, 0, 500) - t * Eigen::Vector3d(0, 0, 500))).norm()}};
      if (const Json* m = recordedTransform(session, "robot-calibration", "MarkerToFlange");
          m != nullptr && st.contains("MarkerToFlange")) {
        const Eigen::Isometry3d em(matrix(*m, "session MarkerToFlange"));
        const Eigen::Isometry3d tm(matrix(st["MarkerToFlange"], "truth MarkerToFlange"));
        scored["robot_calibration"]["marker_to_flange_translation_error_mm"] =
            (em.translation() - tm.translation()).norm();
        scored["robot_calibration"]["marker_to_flange_rotation_error_deg"] =
            rotationAngleBetween(em.linear(), tm.linear()) * 180.0 / M_PI;
      }
    }
  } else {
    not_scored.push_back(
        "robot-calibration (not run, failed, without RobotBaseToTracker, or not acquired from mrsns-sim)");
  }

  scoreHmdCalibration(session, truth, scored, not_scored);
  scoreSoftTissue(session_dir, session, truth, scored, not_scored);
  scoreRobotPlacement(session, truth, scored, not_scored);

  out["scored"] = scored;
  out["not_scored"] = not_scored;
  Json events = truth.value("events", Json::array());
  out["faults_in_truth"] = events.size();
  return out.dump();
}

}  // namespace mrsns::simulation
