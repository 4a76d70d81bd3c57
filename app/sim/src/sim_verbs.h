#pragma once
// The verbs of mrsns-sim. Each registers its subcommand and returns the action
// main() runs when it was chosen; an action prints its report (one JSON object
// with --json) and returns the exit code, or throws mrsns::Error (exit 1).
#include <CLI/CLI.hpp>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>

namespace mrsns::sim {

using Json = nlohmann::ordered_json;
using VerbAction = std::function<int()>;

struct SimOptions {
  bool json = false;
};

VerbAction registerRunVerb(CLI::App& app, SimOptions& options, CLI::App*& sub);
VerbAction registerScoreVerb(CLI::App& app, SimOptions& options, CLI::App*& sub);
VerbAction registerCheckVerb(CLI::App& app, SimOptions& options, CLI::App*& sub);

/// Prints `json` (with --json) or `text`.
void printReport(const SimOptions& options, const Json& json, const std::string& text);

}  // namespace mrsns::sim
