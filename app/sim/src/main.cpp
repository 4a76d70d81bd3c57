// mrsns-sim entry point: the simulated operating room (run), its scorer
// (score) and the scenario checker (check). Errors become one line on stderr
// and exit 1; usage errors exit 2.
#include <iostream>
#include <utility>
#include <vector>

#include "mrsns/core/data_dir.h"
#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "sim_verbs.h"

namespace {

std::string firstLine(const std::string& message) {
  const auto end = message.find('\n');
  return end == std::string::npos ? message : message.substr(0, end);
}

}  // namespace

namespace mrsns::sim {

void printReport(const SimOptions& options, const Json& json, const std::string& text) {
  if (options.json) {
    std::cout << json.dump() << std::endl;
  } else {
    std::cout << text << std::endl;
  }
}

}  // namespace mrsns::sim

int main(int argc, char** argv) {
  using namespace mrsns::sim;
  CLI::App app{
      "mrsns-sim: the simulated operating room of MR-SNS, a process of its own behind the real device protocols\n"
      "(a PlusServer for tracking and B-mode video, a UR controller). It keeps the truth to itself: only\n"
      "'mrsns-sim score' reads the truth file. Every verb takes --json and then prints one JSON object.",
      "mrsns-sim"};
  app.set_version_flag("--version", std::string("mrsns-sim ") + mrsns::versionString());
  app.require_subcommand(1);
  std::string log_level = "warn";
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error, critical or off")->capture_default_str();
  SimOptions options;
  std::vector<std::pair<CLI::App*, VerbAction>> verbs(3);
  verbs[0].second = registerRunVerb(app, options, verbs[0].first);
  verbs[1].second = registerScoreVerb(app, options, verbs[1].first);
  verbs[2].second = registerCheckVerb(app, options, verbs[2].first);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << "mrsns-sim: " << firstLine(e.what()) << " (see 'mrsns-sim --help')\n";
    return 2;
  }
  try {
    mrsns::setLogLevel(log_level);
    for (auto& [sub, action] : verbs) {
      if (sub->parsed()) return action();
    }
  } catch (const mrsns::Error& e) {
    std::cerr << "mrsns-sim: " << firstLine(e.what()) << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "mrsns-sim: " << firstLine(e.what()) << "\n";
    return 1;
  }
  return 2;
}
