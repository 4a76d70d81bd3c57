// index.html of a trial report: one self-contained page, no scripts.
#include <algorithm>
#include <iomanip>
#include <sstream>

#include "mrsns/workflow/trial.h"

namespace mrsns::workflow {

namespace {

using Json = nlohmann::json;

// Per-sample series (loop latency, error per frame: up to thousands of
// numbers) stay in report.json; the page shows their length and range.
Json withLongSeriesShortened(const Json& j) {
  constexpr std::size_t kMaxShown = 12;
  if (j.is_object()) {
    Json out = Json::object();
    for (const auto& [key, value] : j.items()) out[key] = withLongSeriesShortened(value);
    return out;
  }
  if (j.is_array() && j.size() > kMaxShown &&
      std::all_of(j.begin(), j.end(), [](const Json& v) { return v.is_number(); })) {
    const auto [lo, hi] = std::minmax_element(
        j.begin(), j.end(), [](const Json& a, const Json& b) { return a.get<double>() < b.get<double>(); });
    std::ostringstream text;
    text << j.size() << " values from " << lo->get<double>() << " to " << hi->get<double>() << " (in report.json)";
    return text.str();
  }
  if (j.is_array()) {
    Json out = Json::array();
    for (const auto& v : j) out.push_back(withLongSeriesShortened(v));
    return out;
  }
  return j;
}

std::string escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '&': out += "&amp;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

// The value at a '/'-separated path, or null.
nlohmann::json at(const nlohmann::json& j, const std::string& path) {
  const nlohmann::json* cur = &j;
  std::stringstream ss(path);
  std::string part;
  while (std::getline(ss, part, '/')) {
    if (!cur->is_object() || !cur->contains(part)) return nullptr;
    cur = &(*cur)[part];
  }
  return *cur;
}

std::string number(const nlohmann::json& v) {
  if (!v.is_number()) return "&ndash;";
  std::ostringstream s;
  s << std::fixed << std::setprecision(2) << v.get<double>();
  return s.str();
}

std::string meanSd(const nlohmann::json& v) {
  if (v.is_number()) return number(v);
  if (!v.is_object()) return "&ndash;";
  return number(at(v, "mean")) + " &plusmn; " + number(at(v, "sd"));
}

// "mean &plusmn; sd" from two keys of an object.
std::string meanSdOf(const nlohmann::json& v, const char* mean, const char* sd) {
  if (!v.is_object()) return "&ndash;";
  return number(at(v, mean)) + " &plusmn; " + number(at(v, sd));
}

// A noise model as one line of "name value" pairs, so it sits beside its figure.
std::string compact(const nlohmann::json& v) {
  if (v.is_number_float()) {
    std::ostringstream s;
    s << v.get<double>();
    return s.str();
  }
  if (v.is_string()) return escape(v.get<std::string>());
  if (v.is_array()) {
    std::string out;
    for (const auto& x : v) out += (out.empty() ? "" : "&ndash;") + compact(x);
    return out;
  }
  if (!v.is_object()) return escape(v.dump());
  std::string out;
  for (const auto& [k, x] : v.items()) out += (out.empty() ? "" : ", ") + escape(k) + " " + compact(x);
  return out;
}

std::string noiseNote(const char* what, const nlohmann::json& model) {
  if (model.is_null()) return what;
  return std::string(what) + "<br><small>noise model: " + compact(model) + "</small>";
}

}  // namespace

std::string renderTrialHtml(const nlohmann::json& report) {
  // at(): a report missing a part renders with dashes (operator[] on a
  // const json with a missing key is undefined).
  const auto steps = at(report, "steps");
  const auto paper = at(report, "paper");
  struct Row {
    const char* what;
    std::string ours;
    std::string reference;
    std::string note;
  };
  const std::string fig = "/figures/";
  // The real recording's calibrations: in their own session when the trial ran a room (whose session holds the
  // room's calibration), else in the trial's.
  const auto plus_steps = at(report, "plus_comparison/steps");
  const auto us_steps = plus_steps.is_object() && !plus_steps.empty() ? plus_steps : steps;
  const bool live_us = at(steps, "us-spatial-calibration/figures/recorded/device_identity").is_string();
  // Fig. 7 and the checkerboard protocol: module trials beside a live HMD calibration, else in the step.
  const auto module_trials = at(report, "module_trials");
  const auto cube = at(module_trials, "cube_trial").is_null() ? at(steps, "hmd-calibration/figures/cube_trial")
                                                               : at(module_trials, "cube_trial");
  const auto board = at(module_trials, "checkerboard_trial").is_null()
                         ? at(steps, "hmd-calibration/figures/checkerboard_trial")
                         : at(module_trials, "checkerboard_trial");
  const bool live_hmd = at(steps, "hmd-calibration/figures/source").is_string() &&
                        at(steps, "hmd-calibration/figures/source").get<std::string>() == "hmd";
  const auto hmd_score = at(report, "simulated_room/score/scored/hmd_calibration");
  const auto robot = at(module_trials, "placement_trial");
  const auto placement_score = at(report, "simulated_room/score/scored/robot_placement");
  const bool live_placement = placement_score.is_object();
  const std::string cube_note = noiseNote("hmd::runCubeTrial", at(cube, "noise_model"));
  const bool live_robot = at(steps, "robot-calibration/figures/source").is_string() &&
                          at(steps, "robot-calibration/figures/source").get<std::string>() == "ur";
  const bool live_registration = at(steps, "registration/figures/source").is_string() &&
                                 at(steps, "registration/figures/source").get<std::string>() != "simulated";
  const std::vector<Row> rows = {
      {"US calibration, validation 3D reprojection (mm)",
       number(at(us_steps, "us-spatial-calibration" + fig + "validation/reprojection_3d_mean_mm")),
       meanSd(at(paper, "plus_us_calibration_validation_mm")),
       "PLUS ProbeCalibration on the same recording; both as recorded, without a tracker lag"},
      {"US temporal calibration, tracker lag (ms)",
       number(at(us_steps, "us-temporal-calibration" + fig + "tracker_lag_ms")), "&ndash;", "PLUS's result assumes 0 ms"},
      {"US calibration with that lag applied, validation 3D reprojection (mm)",
       number(at(us_steps, "us-temporal-calibration" + fig + "validation_reprojection_3d_mean_mm_at_lag")), "&ndash;",
       "the lag estimated from the calibration sweep, applied to both recordings"},
      {"US calibration in the simulated room, ImageToProbe error at the image's corners (mm, mean)",
       live_us ? number(at(report, "simulated_room/score/scored/us_spatial_calibration/error/mean_mm")) : "&ndash;",
       "&ndash;",
       live_us ? "phantom registered by touching its landmarks, probe swept over the wires in the room; scored from "
                 "outside (validation reprojection " +
                     number(at(steps, "us-spatial-calibration" + fig + "validation/reprojection_3d_mean_mm")) +
                     " mm)"
               : "not acquired in a room"},
      {"US temporal calibration in the simulated room, lag error (ms)",
       live_us ? number(at(report, "simulated_room/score/scored/us_temporal_calibration/error_ms")) : "&ndash;",
       "&ndash;",
       live_us ? "probe moved up and down over the bath's flat bottom; estimated " +
                     number(at(report, "simulated_room/score/scored/us_temporal_calibration/estimated_ms")) +
                     " ms against the room's true " +
                     number(at(report, "simulated_room/score/scored/us_temporal_calibration/true_ms")) + " ms"
               : "not acquired in a room"},
      {"Tool tips in the simulated room, pivot calibration error: stylus / drill (mm)",
       number(at(report, "simulated_room/score/scored/pivot_calibration/tip_error_mm")) + " / " +
           number(at(report, "simulated_room/score/scored/drill_calibration/tip_error_mm")),
       "&ndash;", "each pivoted about its tip in a divot (the drill by hand, the arm in freedrive); scored from outside"},
      {"Tool shafts in the simulated room, spin calibration error: stylus / drill (deg)",
       number(at(report, "simulated_room/score/scored/spin_calibration/shaft_error_deg")) + " / " +
           number(at(report, "simulated_room/score/scored/drill_spin_calibration/shaft_error_deg")),
       "&ndash;",
       "each turned about its shaft with the tip in the divot; the drill's axis is the direction navigation drills "
       "along; scored from outside"},
      {"Registration, landmark FRE (mm)", number(at(steps, "registration" + fig + "landmarks/fre_rms_mm")), "&ndash;",
       live_registration ? "fiducial screws touched with the tracked stylus in the simulated room (noise model below)"
                         : "8 fiducial screws, 0.5 mm FLE (in-process simulated patient)"},
      {live_registration ? "Registration, TRE at the planned screws' entries and targets (mm, mean)"
                         : "Registration, TRE at the planned screws (mm, RMS)",
       live_registration ? number(at(report, "simulated_room/score/scored/registration/error_at_planned_screws/mean_mm"))
                         : number(at(steps, "registration" + fig + "surface/tre/rms")),
       "&ndash;",
       live_registration ? "landmarks + ICP on the swept bone; scored from outside by mrsns-sim score against the "
                           "room's truth"
                         : "landmarks + ICP on the posterior bone"},
      {live_robot ? "Robot calibration, RobotBaseToTracker error 500 mm in front of the base (mm)"
                  : "Robot calibration, error at the patient (mm)",
       live_robot ? number(at(report, "simulated_room/score/scored/robot_calibration/error_500mm_mm"))
                  : number(at(steps, "robot-calibration" + fig + "tre_at_patient_mm")),
       "&ndash;",
       live_robot ? "stations driven on the room's UR controller, marker seen by its tracker; scored from outside"
                  : "simulated UR5 + tracker (in-process)"},
      live_hmd
          ? Row{"MR (HMD) calibration in the simulated room, the fiducials' overlay at the headset, Eq. 23 RMS (mm, "
                "mean)",
                number(at(hmd_score, "overlay_at_headset/mean_mm")), meanSd(at(paper, "mr_calibration_rms_mm")),
                noiseNote(("the cube lined up with its hologram in 4 views, tremor-compensated and averaged; "
                           "HologramToTracker error " +
                           number(at(hmd_score, "translation_error_mm")) + " mm, " +
                           number(at(hmd_score, "rotation_error_deg")) +
                           " deg; scored from outside at the emulated headset. The paper's figure is a physical "
                           "HoloLens experiment, context only")
                              .c_str(),
                          at(hmd_score, "noise_model"))}
          : Row{"MR (HMD) calibration of this session, cube fit RMS (mm)",
                number(at(steps, "hmd-calibration" + fig + "rigid_rms_mm")), "&ndash;",
                noiseNote("calibration cube, Eq. 2-3", at(steps, "hmd-calibration" + fig + "noise_model"))},
      {"MR calibration, Fig. 7 compensated (tremor + 4 views), Eq. 23 RMS (mm)",
       meanSdOf(cube, "compensated/mean_rms_mm", "compensated/std_rms_mm"), meanSd(at(paper, "mr_calibration_rms_mm")),
       cube_note},
      {"MR calibration, Fig. 7 uncompensated, Eq. 23 RMS (mm)",
       meanSdOf(cube, "uncompensated/mean_rms_mm", "uncompensated/std_rms_mm"), "&ndash;", "same trials"},
      {"MR calibration, Fig. 7 pointer method, Eq. 23 RMS (mm)",
       meanSdOf(cube, "pointer/mean_rms_mm", "pointer/std_rms_mm"), "&ndash;", "same trials"},
      {"MR calibration, improvement vs uncompensated (%)", number(at(cube, "improvement_vs_uncompensated_percent")),
       number(at(paper, "mr_calibration_improvement_vs_uncompensated_percent")), "paper 001 Fig. 7"},
      {"MR calibration, improvement vs pointer (%)", number(at(cube, "improvement_vs_pointer_percent")),
       number(at(paper, "mr_calibration_improvement_vs_pointer_percent")), "paper 001 Fig. 7"},
      {"HMD camera hand-eye from the headset's photos in the simulated room, CameraToHeadset error (deg / mm; mm "
       "1 m ahead)",
       number(at(report, "simulated_room/score/scored/hmd_camera_calibration/rotation_error_deg")) + " / " +
           number(at(report, "simulated_room/score/scored/hmd_camera_calibration/translation_error_mm")) + "; " +
           number(at(report, "simulated_room/score/scored/hmd_camera_calibration/error_at_1000mm_mm")),
       meanSd(at(paper, "checkerboard_rpee_mm")) + " RPEE (paper 000)",
       noiseNote(("paper 000's method on the headset's own photos of the tracked board (RPEE " +
                  number(at(steps, "hmd-camera-calibration" + fig + "rpee/mean_mm")) +
                  " mm, which does not see an error of the intrinsics); scored from outside. The paper's figure is "
                  "a physical HoloLens 2 experiment, context only")
                     .c_str(),
                 at(report, "simulated_room/score/scored/hmd_camera_calibration/noise_model"))},
      {"HMD camera checkerboard hand-eye, retro-projection error (mm)", meanSdOf(board, "rpee_mean_mm", "rpee_std_mm"),
       meanSd(at(paper, "checkerboard_rpee_mm")) + " (paper 000)",
       noiseNote("hmd::runCheckerboardTrial", at(board, "noise_model"))},
      {"HMD camera hand-eye, error vs truth (deg / mm)",
       number(at(board, "hand_eye_rotation_error_deg")) + " / " + number(at(board, "hand_eye_translation_error_mm")),
       "&ndash;", "simulation truth"},
      {"Deformation, mean surface distance E^SD (mm)",
       number(at(steps, "navigation" + fig + "deformation/posterior_sd_mean_mm")),
       meanSd(at(paper, "deformation_mean_surface_distance_mm")), "posterior shape model, Table I"},
      {"Deformation, fiducial point error E^FP (mm)",
       number(at(steps, "navigation" + fig + "deformation/posterior_fp_mm")),
       meanSd(at(paper, "deformation_fiducial_point_error_mm")), "Table I"},
      {"Placement, robot trial distance deviation (mm)", meanSd(at(robot, "distance_deviation_mm")),
       meanSd(at(paper, "placement_distance_deviation_mm")),
       noiseNote("robot::runPlacementTrial, C5/C6 pedicle screws", at(robot, "noise_model"))},
      {"Placement, robot trial angle deviation (deg)", meanSd(at(robot, "angle_deviation_deg")),
       meanSd(at(paper, "placement_angle_deviation_deg")), "same trials"},
      {"Placement, robot trial tip deviation (mm)", meanSd(at(robot, "tip_deviation_mm")), "&ndash;", "same trials"},
      {"Placement in the simulated room, entry / target error (mm, mean)",
       live_placement ? number(at(placement_score, "entry_error/mean_mm")) + " / " +
                            number(at(placement_score, "target_error/mean_mm"))
                      : "&ndash;",
       meanSd(at(paper, "placement_distance_deviation_mm")),
       live_placement
           ? "the room's UR navigated along each planned screw on this session's registration, robot, drill and "
             "spin calibrations; where the drill truly went, scored from outside (" +
                 std::to_string(at(placement_score, "placed").is_number_integer()
                                    ? at(placement_score, "placed").get<int>()
                                    : 0) +
                 " screws; noise model below). The paper's figure is a physical experiment, context only"
           : "not placed in a room (" + escape(at(steps, "robot-placement/summary").is_string()
                                            ? at(steps, "robot-placement/summary").get<std::string>()
                                            : std::string("not run")) +
                 ")"},
      {"Placement in the simulated room, angle error (deg, mean)",
       live_placement ? number(at(placement_score, "angle_error_deg/mean")) : "&ndash;",
       meanSd(at(paper, "placement_angle_deviation_deg")), live_placement ? "same screws" : "&ndash;"},
      {"Navigation loop latency (ms)", number(at(steps, "navigation" + fig + "mean_loop_latency_ms")),
       meanSd(at(paper, "navigation_delay_ms")), "ours: tracking to hologram stream, no Wi-Fi/HMD"},
  };
  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>MR-SNS phantom trial</title>\n"
    << "<style>body{font-family:sans-serif;margin:2em;max-width:70em}table{border-collapse:collapse;margin:1em 0}"
    << "td,th{border:1px solid #bbb;padding:.3em .6em;text-align:left}th{background:#eee}"
    << ".ok{color:#070}.failed,.cancelled{color:#b00}.skipped{color:#a60}pre{background:#f6f6f6;padding:.5em;"
    << "overflow:auto;max-height:25em}img{max-width:45%;margin:.5em;border:1px solid #ccc}</style></head><body>\n"
    << "<h1>MR-SNS phantom trial</h1>\n<p>Version " << escape(report.value("version", "")) << ", "
    << escape(report.value("created", "")) << ", seed " << report.value("seed", 0) << ", "
    << number(at(report, "seconds")) << " s. Overall: <b class=\""
    << (report.value("ok", false) ? "ok\">ok" : "failed\">FAILED")
    << "</b>.</p>\n<h2>Figures beside the papers</h2>\n<table><tr><th>Figure</th><th>This trial</th>"
    << "<th>Paper 001 / PLUS</th><th>Note</th></tr>\n";
  for (const auto& r : rows) {
    h << "<tr><td>" << r.what << "</td><td>" << r.ours << "</td><td>" << r.reference << "</td><td>" << r.note
      << "</td></tr>\n";
  }
  h << "</table>\n";
  const auto room = at(report, "simulated_room");
  h << "<h2>Simulated operating room (mrsns-sim), scored from outside</h2>\n";
  if (room.is_object() && room.value("used", false)) {
    h << "<p>Scenario " << escape(room.value("scenario", "")) << ". Noise model: "
      << escape(room.value("noise_model", "")) << "</p>\n<p>The live steps acquired from it over its protocols; "
      << "<code>mrsns-sim score</code> judged their results against the truth it kept to itself. Simulated "
         "figures: they are not a physical experiment.</p>\n<table><tr><th>Result</th><th>Error</th>"
         "<th>Definition</th></tr>\n";
    const auto scored = at(room, "score/scored");
    for (const auto& [name, item] : scored.items()) {
      nlohmann::json figures = item;
      figures.erase("definition");
      h << "<tr><td>" << escape(name) << "</td><td>" << compact(figures) << "</td><td>"
        << escape(item.value("definition", "")) << "</td></tr>\n";
    }
    h << "</table>\n";
    if (room.contains("score_error")) h << "<p class=\"failed\">" << escape(room.value("score_error", "")) << "</p>\n";
    const auto not_scored = at(room, "score/not_scored");
    if (not_scored.is_array() && !not_scored.empty()) {
      h << "<p>Not scored: ";
      bool first = true;
      for (const auto& n : not_scored) {
        h << (first ? "" : "; ") << escape(n.is_string() ? n.get<std::string>() : n.dump());
        first = false;
      }
      h << ".</p>\n";
    }
  } else {
    h << "<p class=\"skipped\">Not used"
      << (room.is_object() && room.contains("why_not") ? ": " + escape(room.value("why_not", "")) : std::string())
      << ". The registration was simulated in-process.</p>\n";
  }
  h << "<h2>Steps</h2>\n<table><tr><th>Step</th><th>Status</th><th>Summary</th></tr>\n";
  for (const auto& [name, s] : steps.items()) {
    const std::string status = s.value("status", "?");
    h << "<tr><td>" << escape(name) << "</td><td class=\"" << escape(status) << "\">" << escape(status) << "</td><td>"
      << escape(s.value("summary", "")) << "</td></tr>\n";
  }
  h << "</table>\n";
  if (!report.value("snapshots_skipped", "").empty()) {
    h << "<h2>Snapshots</h2>\n<p class=\"skipped\">Skipped: " << escape(report.value("snapshots_skipped", ""))
      << "</p>\n";
  }
  if (report.contains("images") && !report["images"].empty()) {
    h << "<h2>Snapshots</h2>\n";
    for (const auto& img : report["images"]) {
      h << "<img src=\"" << escape(img.get<std::string>()) << "\" alt=\"" << escape(img.get<std::string>()) << "\">\n";
    }
  }
  h << "<h2>Session log</h2>\n<pre>";
  for (const auto& line : at(report, "log")) {
    if (!line.is_object()) continue;
    h << escape(line.value("time", "")) << ' ' << escape(line.value("level", "")) << ' '
      << escape(line.value("message", "")) << '\n';
  }
  h << "</pre>\n<h2>All figures</h2>\n";
  for (const auto& [name, s] : steps.items()) {
    h << "<h3>" << escape(name) << "</h3><pre>"
      << escape(s.contains("figures") ? withLongSeriesShortened(s["figures"]).dump(2) : "{}") << "</pre>\n";
  }
  h << "</body></html>\n";
  return h.str();
}

}  // namespace mrsns::workflow
