#pragma once
// The whole phantom trial, headless (`mrsns-cli trial`, the GUI's "Run
// trial"): every workflow step on a fresh session with the simulated tracker
// and robot, the real PLUS recording for the ultrasound calibrations, the
// generated cervical phantom for registration and placement, the posterior
// shape model for deformation; then a report folder (report.json, index.html
// with the figures beside paper 001's, snapshots when a renderer is given).
#include <cstdint>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "mrsns/workflow/steps.h"

namespace mrsns::workflow {

struct TrialOptions {
  std::filesystem::path out;  ///< report folder (created; must be empty or absent)
  std::uint64_t seed = 1;
  /// Navigation run time (s) and deformation cases: the trial's cost.
  double navigation_s = 2.0;
  int deformation_cases = 3;
  /// Tracker loss during navigation (the supervisor must stop the robot).
  bool simulate_tracker_loss = true;
  /// The simulated operating room (mrsns-sim, a child process) the live
  /// steps acquire from (the stylus pivot calibration, the patient
  /// registration); `mrsns-sim score` judges them against its truth, kept in
  /// <out>/room/ outside the session. Without it (or without mrsns-sim) those
  /// steps fall back to the in-process simulated patient and the report says so.
  bool simulated_room = true;
  /// The room's scenario; empty: resources/scenarios/default.json.
  std::filesystem::path scenario;
  StepContext context;
  /// The module trials run inside the steps (their cost): paper 001 Fig. 7
  /// cube trials per method, paper 000 checkerboard poses, robot placement
  /// trials (each places two screws). 0 leaves one out.
  int hmd_cube_trials = 3;
  int checkerboard_poses = 5;
  int placement_trials = 2;
  /// Writes PNG snapshots into the folder and returns their file names;
  /// writeTrialSnapshots when unset. An exception skips the snapshots (the
  /// report says why) without failing the trial.
  bool write_snapshots = true;
  std::function<std::vector<std::string>(const std::filesystem::path& folder, const Session& session)> snapshots;
};

struct TrialResult {
  bool ok = false;        ///< every step that could run succeeded
  nlohmann::json report;  ///< what report.json holds
  std::filesystem::path folder;
  std::filesystem::path index_html;
};

/// Runs the trial. Throws FileError when `out` cannot be created or is not
/// empty; step failures are recorded in the report, not thrown.
TrialResult runPhantomTrial(const TrialOptions& options);

/// The trial's snapshots (rendering module, offscreen): the registered
/// phantom with its planned screw paths, the posterior soft-tissue shape
/// coloured by its uncertainty, achieved vs planned screw paths. Returns the
/// PNG file names written into `folder`. Throws UnsupportedError without an X
/// display (run under xvfb-run -a).
std::vector<std::string> writeTrialSnapshots(const std::filesystem::path& folder, const Session& session);

/// Paper 001's published figures the report compares with.
nlohmann::json paperReferenceFigures();

/// index.html of a report (tables of figures beside the paper's, the images).
std::string renderTrialHtml(const nlohmann::json& report);

}  // namespace mrsns::workflow
