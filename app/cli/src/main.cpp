// mrsns-cli entry point: parses the verb, runs it, prints its report, and
// turns every error into a one-line message and an exit code.
#include <iostream>
#include <utility>
#include <vector>

#include "cli_context.h"
#include "mrsns/core/data_dir.h"
#include "mrsns/core/error.h"
#include "mrsns/core/log.h"

namespace {

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;
constexpr int kExitUsage = 2;

std::string firstLine(const std::string& message) {
  const auto end = message.find('\n');
  return end == std::string::npos ? message : message.substr(0, end);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace mrsns::cli;
  CLI::App app{
      "mrsns-cli: the MR-SNS surgical navigation engine, headless.\n"
      "Every workflow step is a verb; every verb takes --json and then prints one JSON object.",
      "mrsns-cli"};
  app.set_version_flag("--version", std::string("mrsns-cli ") + mrsns::versionString());
  app.require_subcommand(1);
  GlobalOptions options;
  app.add_option("--log-level", options.log_level, "trace, debug, info, warn, error, critical or off")
      ->capture_default_str();

  VerbList verbs;
  registerInfoVerb(app, options, verbs);
  registerConvertVerb(app, options, verbs);
  registerCalibrateToolVerbs(app, options, verbs);
  registerRegisterPointsVerb(app, options, verbs);
  registerServeVerb(app, options, verbs);
  registerRegisterSurfaceVerb(app, options, verbs);
  registerFindFiducialsVerb(app, options, verbs);
  registerPlanCheckVerb(app, options, verbs);
  registerSegmentVerb(app, options, verbs);
  registerMakePhantomVerb(app, options, verbs);
  registerSsmVerbs(app, options, verbs);
  registerDeformTrialVerb(app, options, verbs);
  registerDeformTrackVerb(app, options, verbs);
  registerUltrasoundVerbs(app, options, verbs);
  registerHmdTrialVerb(app, options, verbs);
  registerHmdCalibrateCubeVerb(app, options, verbs);
  registerLatencyVerb(app, options, verbs);
  registerSessionVerbs(app, options, verbs);
  registerTrialVerb(app, options, verbs);
  registerHmdCheckerboardVerbs(app, options, verbs);
  registerRobotSimVerbs(app, options, verbs);
  registerRobotTrialVerb(app, options, verbs);
  registerRobotCalibrateVerb(app, options, verbs);
  registerSnapshotVerb(app, options, verbs);

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << "mrsns-cli: " << firstLine(e.what()) << " (see 'mrsns-cli --help')\n";
    return kExitUsage;
  }

  try {
    mrsns::setLogLevel(options.log_level);
    for (auto& [sub, action] : verbs) {
      if (!sub->parsed()) continue;
      Report report = action();
      if (options.json) {
        std::cout << report.json.dump(2) << '\n';
      } else {
        std::cout << report.text;
        if (!report.text.empty() && report.text.back() != '\n') std::cout << '\n';
      }
      return kExitOk;
    }
    std::cerr << "mrsns-cli: no verb given (see 'mrsns-cli --help')\n";
    return kExitUsage;
  } catch (const mrsns::InvalidArgumentError& e) {
    std::cerr << "mrsns-cli: error: " << firstLine(e.what()) << '\n';
    return kExitFailure;
  } catch (const mrsns::Error& e) {
    std::cerr << "mrsns-cli: error: " << firstLine(e.what()) << '\n';
    return kExitFailure;
  } catch (const std::bad_alloc&) {
    std::cerr << "mrsns-cli: error: out of memory (is the input file much larger than it claims?)\n";
    return kExitFailure;
  } catch (const std::exception& e) {
    std::cerr << "mrsns-cli: internal error: " << firstLine(e.what()) << " (please report this)\n";
    return kExitFailure;
  }
}
