#pragma once
// What every verb shares: the --json switch and the way results are printed.
// A verb fills a Report; main() prints it as one JSON object (--json) or as
// human-readable text, and maps errors to exit codes (0 ok, 1 bad input or
// failed computation, 2 usage).
#include <CLI/CLI.hpp>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

namespace mrsns::cli {

using Json = nlohmann::ordered_json;

/// The result of one verb: the JSON object printed with --json, and the text
/// printed otherwise.
struct Report {
  Json json = Json::object();
  std::string text;
};

/// Shared options of the command line.
struct GlobalOptions {
  bool json = false;
  std::string log_level = "warn";
};

/// The action run when a verb's subcommand was chosen.
using VerbAction = std::function<Report()>;
/// Every registered verb: its subcommand and its action.
using VerbList = std::vector<std::pair<CLI::App*, VerbAction>>;

// Each verb file adds its subcommand(s) to `app` and its action to `verbs`.
void registerInfoVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerConvertVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerCalibrateToolVerbs(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerRegisterPointsVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerServeVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerRegisterSurfaceVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerFindFiducialsVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerPlanCheckVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerSegmentVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerMakePhantomVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerSsmVerbs(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerDeformTrialVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerDeformTrackVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerUltrasoundVerbs(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerHmdTrialVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerHmdCalibrateCubeVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerLatencyVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerSessionVerbs(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerTrialVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerHmdCheckerboardVerbs(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerRobotSimVerbs(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerRobotTrialVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerRobotCalibrateVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerSnapshotVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs);

/// Adds the --json flag to a subcommand (every verb has it).
void addJsonFlag(CLI::App& sub, GlobalOptions& options);

}  // namespace mrsns::cli
