#pragma once
// What every verb shares: the --json switch and the way results are printed.
// A verb fills a Report; main() prints it as one JSON object (--json) or as
// human-readable text, and maps errors to exit codes (0 ok, 1 bad input or
// failed computation, 2 usage).
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <functional>
#include <string>

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

/// A verb adds its subcommand to `app` and returns the action run when that
/// subcommand was chosen.
using VerbAction = std::function<Report()>;
using VerbRegistration = std::function<VerbAction(CLI::App& app, GlobalOptions& options)>;

/// Verbs register themselves here (one call per verb file, from main).
void registerInfoVerb(CLI::App& app, GlobalOptions& options, std::vector<std::pair<CLI::App*, VerbAction>>& verbs);
void registerConvertVerb(CLI::App& app, GlobalOptions& options, std::vector<std::pair<CLI::App*, VerbAction>>& verbs);

/// Adds the --json flag to a subcommand (every verb has it).
void addJsonFlag(CLI::App& sub, GlobalOptions& options);

}  // namespace mrsns::cli
