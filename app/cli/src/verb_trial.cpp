// `mrsns-cli trial`: the whole phantom trial on bundled data, headless, with
// a report folder (index.html, report.json, snapshots).
#include <iostream>
#include <sstream>

#include "cli_context.h"
#include "mrsns/core/error.h"
#include "mrsns/workflow/trial.h"

namespace mrsns::cli {

void registerTrialVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  struct TrialArgs {
    std::string out = "mrsns-trial";
    std::uint64_t seed = 1;
    double navigation_s = 2.0;
    int deformation_cases = 3;
    bool progress = false;
    bool no_snapshots = false;
    int hmd_trials = 3;
    int checkerboard_poses = 5;
    int placement_trials = 2;
    bool no_room = false;
    std::string scenario;
  };
  auto args = std::make_shared<TrialArgs>();
  auto* sub = app.add_subcommand(
      "trial",
      "The whole phantom trial, headless: the simulated operating room (mrsns-sim) started as a child process; "
      "acquired live from it as from the real devices: the stylus pivot, the patient registration (fiducials "
      "touched, bone swept), the N-wire phantom's registration, the probe's temporal and spatial calibration, "
      "the robot calibration on its UR controller, the drill pivoted by hand, the headset's calibration with "
      "the cube, then every planned screw placed by its UR under the safety supervisor; `mrsns-sim score` judges "
      "them against its truth (the placement where the drill truly went); PLUS's recording calibrated beside "
      "PLUS's result; paper 001 Fig. 7, paper 000 and the robot's placement as module trials; navigation with "
      "deformation tracking and a simulated tracker loss (in-process); writes a report folder");
  sub->add_option("--out", args->out, "report folder (absent or empty)")->capture_default_str();
  sub->add_option("--seed", args->seed, "random seed of the simulated devices")->capture_default_str();
  sub->add_option("--navigation-s", args->navigation_s, "navigation run time, s")
      ->check(CLI::Range(0.2, 600.0))
      ->capture_default_str();
  sub->add_option("--deformation-cases", args->deformation_cases, "deformation trial cases (paper: 6)")
      ->check(CLI::Range(0, 20))
      ->capture_default_str();
  sub->add_option("--hmd-trials", args->hmd_trials, "paper 001 Fig. 7 cube trials per method (0 skips)")
      ->check(CLI::Range(0, 50))
      ->check([](const std::string& v) { return v == "1" ? std::string("must be 0 (skip) or >= 2") : std::string(); })
      ->capture_default_str();
  sub->add_option("--checkerboard-poses", args->checkerboard_poses, "paper 000 checkerboard poses (0 skips, else >= 3)")
      ->check(CLI::Range(0, 50))
      ->check([](const std::string& v) {
        return v == "1" || v == "2" ? std::string("must be 0 (skip) or >= 3") : std::string();
      })
      ->capture_default_str();
  sub->add_option("--placement-trials", args->placement_trials, "robot placement trials, 2 screws each (0 skips)")
      ->check(CLI::Range(0, 20))
      ->capture_default_str();
  sub->add_flag("--no-snapshots", args->no_snapshots, "write no PNG snapshots (they need an X display)");
  sub->add_flag("--progress", args->progress, "print progress lines on stderr");
  sub->add_flag("--no-room", args->no_room,
                "no simulated operating room: the pivot calibration is left out and the registration simulated "
                "in-process");
  sub->add_option("--scenario", args->scenario, "the room's scenario (default: the bundled default.json)")
      ->check(CLI::ExistingFile);
  addJsonFlag(*sub, options);
  verbs.emplace_back(sub, [args]() -> Report {
    workflow::TrialOptions trial;
    trial.out = args->out;
    trial.seed = args->seed;
    trial.navigation_s = args->navigation_s;
    trial.deformation_cases = args->deformation_cases;
    trial.hmd_cube_trials = args->hmd_trials;
    trial.checkerboard_poses = args->checkerboard_poses;
    trial.placement_trials = args->placement_trials;
    trial.write_snapshots = !args->no_snapshots;
    trial.simulated_room = !args->no_room;
    trial.scenario = args->scenario;
    if (args->progress) {
      // A live step reports ten times a second; a line per change is enough to follow it.
      trial.context.progress = [last = std::string()](double f, const std::string& message) mutable {
        if (message == last) return;
        last = message;
        std::cerr << static_cast<int>(f * 100.0) << "% " << message << "\n";
      };
    }
    const auto result = workflow::runPhantomTrial(trial);
    Report report;
    report.json = Json::parse(result.report.dump());
    report.json.erase("log");
    report.json["verb"] = "trial";
    report.json["folder"] = result.folder.string();
    report.json["index_html"] = result.index_html.string();
    std::ostringstream text;
    text << "phantom trial " << (result.ok ? "ok" : "FAILED") << " in " << result.report["seconds"].get<double>()
         << " s; report " << result.index_html.string() << "\n";
    for (const auto& [name, s] : result.report["steps"].items()) {
      text << "  " << name << ": " << s.value("status", "?") << " - " << s.value("summary", "") << "\n";
    }
    const auto& room = result.report["simulated_room"];
    if (room.value("used", false)) {
      text << "  simulated operating room: " << room.value("scenario", "") << "\n";
      if (room.contains("score")) {
        for (const auto& [name, s] : room["score"]["scored"].items()) text << "    scored " << name << ": " << s.dump() << "\n";
      }
      if (room.contains("score_error")) text << "    score failed: " << room["score_error"].get<std::string>() << "\n";
    } else if (room.contains("why_not")) {
      text << "  simulated operating room not used: " << room["why_not"].get<std::string>() << "\n";
    }
    for (const auto& image : result.report["images"]) text << "  snapshot " << image.get<std::string>() << "\n";
    if (!result.report["snapshots_skipped"].get<std::string>().empty()) {
      text << "  snapshots skipped: " << result.report["snapshots_skipped"].get<std::string>() << "\n";
    }
    report.text = text.str();
    if (!result.ok) {
      // The report is written; the exit code tells scripts the trial failed.
      throw ComputationError("the phantom trial did not pass every step: see " + result.index_html.string());
    }
    return report;
  });
}

}  // namespace mrsns::cli
