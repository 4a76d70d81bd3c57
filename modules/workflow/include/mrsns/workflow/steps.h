#pragma once
// The steps of the surgical workflow (paper 001 §III.C), each runnable from
// the CLI and the GUI: a step reads its inputs from the session (or from
// `params`), writes its outputs into the session folder, and records its
// figures in session.json. Long steps report progress and stop when asked.
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "mrsns/workflow/session.h"

namespace mrsns::workflow {

struct StepInfo {
  std::string name;   ///< "registration"
  std::string title;  ///< "Patient registration"
  std::string area;   ///< "preparation" | "function" (paper 001 Fig. 4)
  std::string description;
  /// Where the GUI lists it: "data" (the patient's images and models),
  /// "planning" (fiducials and screws), "devices", "registration",
  /// "calibration", "navigation".
  std::string group;
};

struct StepContext {
  /// Called from the step's thread with a fraction in [0, 1]; may be empty.
  std::function<void(double fraction, const std::string& message)> progress;
  /// When set and true, the step stops at its next check and returns ok=false.
  const std::atomic<bool>* cancel = nullptr;
  /// The operator's confirmations from the keyboard or a foot pedal (the GUI's Confirm button, Space): each
  /// increment is one confirmation. A step waiting for the operator (the HMD calibration's holds) counts them.
  const std::atomic<std::uint64_t>* confirmations = nullptr;

  void report(double fraction, const std::string& message) const {
    if (progress) progress(fraction, message);
  }
  [[nodiscard]] bool cancelled() const { return cancel != nullptr && cancel->load(); }
};

struct StepResult {
  bool ok = false;
  bool cancelled = false;
  std::string summary;                                ///< one line for a status bar
  nlohmann::json figures = nlohmann::json::object();  ///< quality figures (mm, deg at the boundary, s)
  std::vector<std::string> outputs;                   ///< files written, relative to the session folder
};

/// Every step in workflow order: the patient's data (import-ct,
/// import-label-map, make-models, import-model, shape-model), planning
/// (find-fiducials, place-fiducial, plan-screw, import-plan, export-plan),
/// then the devices, calibrations and registrations, navigation and the
/// robot-assisted placement.
std::vector<StepInfo> listSteps();

/// Runs `step` on `session` with `params` (a JSON object; the steps on the
/// user's data need the file they import, path=, and the rest of their
/// parameters, like every parameter of the other steps, have defaults that
/// work on the bundled data), records the result in the
/// session and returns it. Throws InvalidArgumentError for an unknown step or
/// parameter, other mrsns::Error subclasses for bad input; returns ok=false,
/// cancelled=true when context.cancel was raised.
StepResult runStep(Session& session, const std::string& step, const nlohmann::json& params,
                   const StepContext& context = {});

/// The bundled sample session: MRSNS_SAMPLE_SESSION from the environment,
/// else resources/sample_session in the source tree, else
/// <prefix>/share/mrsns/sample_session beside the running program. Throws
/// FileError when none exists.
std::filesystem::path sampleSessionPath();

/// A new session at `folder` (absent or empty) copied from the sample
/// session: the installed one is read-only. Throws FileError as
/// Session::create does, or when the sample is missing.
Session createSessionFromSample(const std::filesystem::path& folder);

/// The share directory holding resources (build tree: the source resources/
/// folder; installed: <prefix>/share/mrsns).
std::filesystem::path resourceDirectory();

}  // namespace mrsns::workflow
