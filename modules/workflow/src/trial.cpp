// The phantom trial: every step on a fresh session, then the report.
#include "mrsns/workflow/trial.h"

#include <algorithm>
#include <chrono>
#include <fstream>
#include <memory>
#include <optional>

#include "mrsns/core/data_dir.h"
#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "module_trials.h"
#include "simulated_room_process.h"
#include "time_text.h"

namespace mrsns::workflow {

namespace fs = std::filesystem;

nlohmann::json paperReferenceFigures() {
  // Paper 001 (Results), paper 000 (checkerboard) and PLUS's reference calibration of the fCal recording.
  return {{"deformation_fiducial_point_error_mm", {{"mean", 2.19}, {"sd", 0.21}}},
          {"deformation_mean_surface_distance_mm", {{"mean", 1.52}, {"sd", 0.43}}},
          {"mr_calibration_rms_mm", {{"mean", 1.64}, {"sd", 0.48}}},
          {"placement_distance_deviation_mm", {{"mean", 1.04}, {"sd", 0.27}}},
          {"placement_angle_deviation_deg", {{"mean", 1.53}, {"sd", 0.41}}},
          {"navigation_delay_ms", {{"mean", 247.0}, {"sd", 43.0}}},
          {"mr_calibration_improvement_vs_uncompensated_percent", 12.3},
          {"mr_calibration_improvement_vs_pointer_percent", 32.5},
          {"checkerboard_rpee_mm", {{"mean", 3.2}, {"sd", 1.6}}},  // paper 000
          {"tracker_accuracy_mm", 0.35},
          {"plus_us_calibration_validation_mm", {{"mean", 1.24684}, {"sd", 0.493905}}}};
}

namespace {

struct PlannedStep {
  std::string name;
  nlohmann::json params;
  bool needs_plus_data = false;
  bool last_in_room = false;  ///< the room stops after this step (its live acquisitions are done)
  /// Run in the PLUS-comparison session, not the trial's: the real recording's calibration is compared with
  /// PLUS's, while the trial's session keeps the room's own (what the scorer judges and navigation uses).
  bool plus_comparison = false;
};

}  // namespace

TrialResult runPhantomTrial(const TrialOptions& options) {
  if (options.out.empty()) throw InvalidArgumentError("trial: the report folder (--out) is empty");
  std::error_code ec;
  if (fs::exists(options.out, ec) && !fs::is_empty(options.out, ec)) {
    throw FileError("trial report folder '" + options.out.string() +
                    "' exists and is not empty: choose a new folder (nothing was overwritten)");
  }
  fs::create_directories(options.out, ec);
  if (ec) throw FileError("cannot create trial report folder '" + options.out.string() + "': " + ec.message());
  const auto start = std::chrono::steady_clock::now();
  Session session = Session::create(options.out / "session");
  const int seed = static_cast<int>(options.seed % 1000000);
  nlohmann::json navigation = {
      {"duration_s", options.navigation_s}, {"seed", seed}, {"deformation_cases", options.deformation_cases}};
  if (options.simulate_tracker_loss) {
    navigation["dropout_tool"] = "PatientToTracker";
    navigation["dropout_start_s"] = options.navigation_s * 0.5;
    navigation["dropout_duration_s"] = std::min(0.5, options.navigation_s * 0.25);
  }
  // The patient's data first, as a lab brings them to the case: the phantom's CT, its segmentation and the
  // planned screws, imported and prepared (models, fiducials found in the CT) before the room's timeline starts.
  nlohmann::json preparation = nlohmann::json::object();
  bool prepared = false;
  {
    const fs::path scenario =
        options.scenario.empty() ? resourceDirectory() / "scenarios" / "default.json" : options.scenario;
    double spacing_mm = 0.8;
    bool generated = true;
    try {
      std::ifstream in(scenario);
      const auto j = nlohmann::json::parse(in);
      const auto patient = j.value("patient", nlohmann::json::object());
      generated = !options.simulated_room || patient.contains("generated_phantom");
      if (generated) spacing_mm = patient["generated_phantom"].value("spacing_mm", spacing_mm);
    } catch (const nlohmann::json::exception&) {
      // mrsns-sim reports a broken scenario when the room starts.
    }
    if (generated) {
      StepContext context;
      context.cancel = options.context.cancel;
      context.progress = [&](double f, const std::string& message) {
        options.context.report(0.02 * f, "import-phantom: " + message);
      };
      try {
        const auto r = runStep(session, "import-phantom", {{"spacing_mm", spacing_mm}, {"seed", seed}}, context);
        prepared = r.ok;
      } catch (const Error& e) {
        session.log("error", std::string("import-phantom: ") + e.what());
      }
      preparation["import-phantom"] = session.step("import-phantom");
    } else {
      preparation["import-phantom"] = {{"status", "skipped"},
                                       {"summary", "the scenario's patient is not the generated phantom: import its "
                                                   "CT into the session before the registration"}};
    }
  }
  // The room: started first, since its timeline (pivot, then the fiducials, then the bone surface) runs from
  // its start; stopped once the live steps are done.
  std::unique_ptr<detail::SimulatedRoomProcess> room;
  nlohmann::json room_report = {{"used", false}};
  const fs::path room_dir = options.out / "room";
  if (options.simulated_room) {
    const fs::path program = detail::findSimProgram();
    const fs::path scenario =
        options.scenario.empty() ? resourceDirectory() / "scenarios" / "default.json" : options.scenario;
    room_report["scenario"] = scenario.string();
    if (program.empty()) {
      room_report["why_not"] = "mrsns-sim was not found beside mrsns-cli (or in MRSNS_SIM)";
    } else {
      fs::create_directories(room_dir);
      options.context.report(0.0, "starting the simulated operating room (" + program.string() + ")");
      try {
        // The trial's seed is the room's: its noise, its operator's hands, its headset.
        room = std::make_unique<detail::SimulatedRoomProcess>(program, scenario, room_dir / "truth.json",
                                                              room_dir / "sim.log", 120.0, options.seed);
        std::string noise_model;
        try {
          std::ifstream in(scenario);
          noise_model = nlohmann::json::parse(in).value("description", "");
        } catch (const nlohmann::json::exception&) {
          // mrsns-sim read it already; a description is only for the report.
        }
        room_report = {{"used", true},
                       {"noise_model", noise_model},
                       {"program", program.string()},
                       {"scenario", scenario.string()},
                       {"endpoints", room->endpoints()}};
      } catch (const Error& e) {
        room_report["why_not"] = e.what();
      }
    }
    if (!room) session.log("warn", "simulated operating room not used: " + room_report.value("why_not", ""));
  }
  std::vector<PlannedStep> plan = {{"connect-devices", {{"duration_s", 0.5}, {"seed", seed}}}};
  if (room) {
    const nlohmann::json at_room = {{"source", "plus"}, {"host", room->host()}, {"port", room->plusPort()}};
    nlohmann::json pivot = at_room;
    pivot["duration_s"] = 60.0;
    nlohmann::json registration = at_room;
    registration["duration_s"] = 120.0;
    plan.push_back({"pivot-calibration", pivot});
    // Then the operator turns the stylus about its shaft, the tip still in the divot.
    nlohmann::json spin = at_room;
    spin["duration_s"] = 30.0;
    plan.push_back({"spin-calibration", spin});
    plan.push_back({"registration", registration});
    // The N-wire phantom: its landmarks touched, then the probe swept over its wires (fCal's workflow).
    nlohmann::json phantom = at_room;
    phantom["duration_s"] = 90.0;
    plan.push_back({"us-phantom-registration", phantom});
    // PLUS's order: the tracker's lag behind the video first (the probe moved up and down over the bath's flat
    // bottom), so the sweep over the wires is calibrated with it.
    nlohmann::json temporal = at_room;
    temporal["duration_s"] = 15.0;
    plan.push_back({"us-temporal-calibration", temporal});
    nlohmann::json sweep = at_room;
    sweep["duration_s"] = 90.0;
    plan.push_back({"us-spatial-calibration", sweep});
    // The room's UR: its stations are driven by the workstation, at any time of the room's timeline.
    nlohmann::json robot = at_room;
    robot["source"] = "ur";
    const auto ports = room->endpoints().value("robot", nlohmann::json::object());
    robot["ur_rtde_port"] = ports.value("rtde", 30004);
    robot["ur_script_port"] = ports.value("realtime", 30003);
    robot["ur_dashboard_port"] = ports.value("dashboard", 29999);
    robot["seed"] = seed;
    plan.push_back({"robot-calibration", robot});
    // Then the drill's tip: the scenario's operator pivots the drill by hand (freedrive) from 205 s, then spins it.
    nlohmann::json drill = at_room;
    drill["duration_s"] = 90.0;
    // The headset's calibration needs its wearer: a room whose headset nobody operates keeps the in-process one.
    const bool headset =
        room->endpoints().contains("hmd_port") && room->endpoints().value("hmd_cube_operator", false);
    plan.push_back({"drill-calibration", drill});
    // And turns the drill about its axis (the drilling direction navigation uses).
    nlohmann::json drill_spin = at_room;
    drill_spin["duration_s"] = 30.0;
    plan.push_back({"drill-spin-calibration", drill_spin});
    if (headset) {
      // The headset's wearer lines the tracked cube up with its hologram, view after view, when asked; then the
      // patient's fiducials are shown through the new calibration (the overlay the scorer measures at the
      // headset, Eq. 23).
      nlohmann::json hmd = at_room;
      hmd["source"] = "hmd";
      hmd["hmd_port"] = room->endpoints()["hmd_port"];
      hmd["duration_s"] = 120.0;
      // Then paper 000's hand-eye calibration of the headset's camera, when the room's headset sends photos.
      const bool camera = room->endpoints().value("hmd_camera_operator", false);
      plan.push_back({"hmd-calibration", hmd});
      if (camera) {
        // Paper 000's order: the board's corners digitised with the stylus first (the operator reads the prompts
        // on the headset), then the photos.
        if (room->endpoints().value("hmd_board_touch", false)) {
          nlohmann::json touch = at_room;
          touch["hmd_port"] = room->endpoints()["hmd_port"];
          touch["duration_s"] = 120.0;
          plan.push_back({"checkerboard-digitisation", touch});
        }
        nlohmann::json photos = at_room;
        photos["source"] = "hmd";
        photos["hmd_port"] = room->endpoints()["hmd_port"];
        photos["duration_s"] = 120.0;
        plan.push_back({"hmd-camera-calibration", photos});
      }
    }
    // Then, the arm long released by the hand that spun its drill, it places every planned screw, navigated
    // on the room's tracking under the safety supervisor with the drill's tip and axis calibrated above;
    // mrsns-sim score measures where the drill truly went.
    nlohmann::json placement = robot;
    placement.erase("seed");
    placement["robot"] = "ur";
    placement["source"] = "plus";
    plan.push_back({"robot-placement", placement, false, true});
  }
  // The real recording (PLUS's fCal data), compared with PLUS's own result.
  plan.push_back({"us-spatial-calibration", nlohmann::json::object(), true, false, room != nullptr});
  plan.push_back({"us-temporal-calibration", nlohmann::json::object(), true, false, room != nullptr});
  if (!room) {
    plan.push_back({"robot-calibration", {{"source", "simulated"}, {"seed", seed}}});
    plan.push_back({"registration", {{"source", "simulated"}, {"seed", seed}}});
  }
  const bool live_hmd = std::any_of(plan.begin(), plan.end(), [](const PlannedStep& p) {
    return p.name == "hmd-calibration";
  });
  if (!live_hmd) {
    plan.push_back({"hmd-calibration",
                    {{"seed", seed},
                     {"cube_trials", options.hmd_cube_trials},
                     {"checkerboard_poses", options.checkerboard_poses}}});
  }
  plan.push_back({"navigation", navigation});
  // Without the room, the in-process simulated tracker and arm place the screws (no truth judges them).
  if (!room) plan.push_back({"robot-placement", {{"seed", seed}}});
  const bool have_plus = findDataFile("plus/fCal_Test_Calibration_3NWires.igs.mha").has_value();
  TrialResult result;
  result.ok = true;
  result.folder = options.out;
  nlohmann::json steps = preparation;
  if (!prepared) result.ok = false;
  nlohmann::json plus_steps = nlohmann::json::object();
  std::optional<Session> plus_session;
  for (std::size_t i = 0; i < plan.size(); ++i) {
    const auto& step = plan[i];
    if (step.plus_comparison && !plus_session) plus_session = Session::create(options.out / "plus_comparison");
    Session& in = step.plus_comparison ? *plus_session : session;
    nlohmann::json& recorded = step.plus_comparison ? plus_steps : steps;
    StepContext context;
    context.cancel = options.context.cancel;
    const double lo = static_cast<double>(i) / static_cast<double>(plan.size());
    const double hi = static_cast<double>(i + 1) / static_cast<double>(plan.size());
    context.progress = [&](double f, const std::string& message) {
      options.context.report(lo + (hi - lo) * f, step.name + ": " + message);
    };
    if (step.needs_plus_data && !have_plus) {
      recorded[step.name] = {{"status", "skipped"},
                          {"summary", "the PLUS recording is not in the data directory '" + dataDirectory().string() +
                                          "' (set MRSNS_DATA_DIR)"}};
      in.log("warn", step.name + " skipped: no PLUS recording");
      continue;
    }
    try {
      const auto r = runStep(in, step.name, step.params, context);
      recorded[step.name] = in.step(step.name);
      if (r.cancelled) {
        result.ok = false;
        break;
      }
      result.ok = result.ok && r.ok;
    } catch (const Error& e) {
      recorded[step.name] = {{"status", "failed"}, {"summary", e.what()}};
      in.log("error", step.name + ": " + e.what());
      result.ok = false;
    }
    if (step.last_in_room && room) room_report["exit_code"] = room->stop();
  }
  if (room) {
    // Scored from outside: the scorer reads the truth; this process only keeps what it prints.
    if (!room_report.contains("exit_code")) room_report["exit_code"] = room->stop();
    options.context.report(1.0, "scoring the session against the room's truth (mrsns-sim score)");
    try {
      room_report["score"] = detail::scoreWithSim(detail::findSimProgram(), session.folder(), room_dir / "truth.json",
                                                  room_dir / "sim.log");
      std::ofstream(room_dir / "score.json") << room_report["score"].dump(2) << '\n';
    } catch (const Error& e) {
      room_report["score_error"] = e.what();
      result.ok = false;
    }
  }
  // Paper 001 Fig. 7 and paper 000's protocol are module trials (simulated matches, their own noise model):
  // beside a live HMD calibration they run here, not in the session's step.
  nlohmann::json module_trials = nlohmann::json::object();
  if (live_hmd) {
    options.context.report(1.0, "module trials: paper 001 Fig. 7 and paper 000's checkerboard");
    if (options.hmd_cube_trials > 0) {
      module_trials["cube_trial"] = detail::cubeTrialFigures(options.hmd_cube_trials, seed);
    }
    if (options.checkerboard_poses > 0) {
      module_trials["checkerboard_trial"] = detail::checkerboardTrialFigures(options.checkerboard_poses, seed);
    }
  }
  // The robot module's placement trial (its UR5 simulator, control loop and supervisor, its own noise model):
  // paper 001's distance and angle deviations, beside the placement in the room.
  if (options.placement_trials > 0) {
    options.context.report(1.0, "module trial: robot placement (UR5 simulator, control loop, supervisor)");
    module_trials["placement_trial"] = detail::placementTrialFigures(options.placement_trials, seed);
    if (module_trials["placement_trial"]["completed"].get<int>() == 0) result.ok = false;
  }
  std::vector<std::string> images;
  std::string snapshots_skipped;
  if (options.write_snapshots) {
    options.context.report(1.0, "snapshots");
    try {
      images = options.snapshots ? options.snapshots(options.out, session) : writeTrialSnapshots(options.out, session);
    } catch (const std::exception& e) {
      // Snapshots illustrate the figures; without a display the figures still stand.
      snapshots_skipped = e.what();
      logger()->warn("trial snapshots skipped: {}", e.what());
      session.log("warn", std::string("snapshots skipped: ") + e.what());
    }
  } else {
    snapshots_skipped = "snapshots not requested";
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  auto& report = result.report;
  report = {{"trial", "phantom"},
            {"version", versionString()},
            {"created", isoTimeNow()},
            {"seed", options.seed},
            {"ok", result.ok},
            {"seconds", seconds},
            {"session", "session"},
            {"steps", steps},
            {"plus_comparison", {{"session", plus_session ? "plus_comparison" : ""}, {"steps", plus_steps}}},
            {"paper", paperReferenceFigures()},
            {"simulated_room", room_report},
            {"module_trials", module_trials},
            {"images", images},
            {"snapshots_skipped", snapshots_skipped},
            {"log", session.state()["log"]}};
  std::ofstream(options.out / "report.json") << report.dump(2) << '\n';
  result.index_html = options.out / "index.html";
  std::ofstream(result.index_html) << renderTrialHtml(report);
  return result;
}

}  // namespace mrsns::workflow
