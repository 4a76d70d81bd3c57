// mrsns-sim score SESSION TRUTH: a session's results against the truth.
#include "mrsns/simulation/score.h"
#include "sim_verbs.h"

namespace mrsns::sim {

VerbAction registerScoreVerb(CLI::App& app, SimOptions& options, CLI::App*& sub) {
  auto session = std::make_shared<std::string>();
  auto truth = std::make_shared<std::string>();
  sub = app.add_subcommand("score", "compare a session's results with a simulated operating room's truth");
  sub->add_option("session", *session, "session folder (holds session.json)")
      ->required()
      ->check(CLI::ExistingDirectory);
  sub->add_option("truth", *truth, "truth file written by 'mrsns-sim run --truth'")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_flag("--json", options.json, "print one JSON object");
  return [session, truth, &options] {
    const Json j = Json::parse(simulation::scoreSession(*session, *truth));
    std::string text = "scored against '" + j.value("scenario", std::string()) + "':";
    for (const auto& [name, figure] : j["scored"].items()) text += "\n  " + name + ": " + figure.dump();
    for (const auto& n : j["not_scored"]) text += "\n  not scored: " + n.get<std::string>();
    printReport(options, j, text);
    return 0;
  };
}

}  // namespace mrsns::sim
