// mrsns-sim check SCENARIO: reads a scenario and builds its world without
// serving anything, so a typo or a missing file shows before a trial starts.
#include "mrsns/simulation/operating_room.h"
#include "mrsns/simulation/scenario.h"
#include "sim_verbs.h"

namespace mrsns::sim {

VerbAction registerCheckVerb(CLI::App& app, SimOptions& options, CLI::App*& sub) {
  auto file = std::make_shared<std::string>();
  sub = app.add_subcommand("check", "read a scenario and build its world (patient, phantom, robot reach)");
  sub->add_option("scenario", *file, "scenario file")->required()->check(CLI::ExistingFile);
  sub->add_flag("--json", options.json, "print one JSON object");
  return [file, &options] {
    const auto s = simulation::readScenario(*file);
    const simulation::OperatingRoom room(s);  // builds the world: the checks that need it run here
    Json tools = Json::array();
    for (const auto& t : s.tools) tools.push_back(t.name);
    Json j{{"scenario", s.name},
           {"ok", true},
           {"duration_s", s.duration_s},
           {"tools", tools},
           {"ultrasound", s.ultrasound.enabled},
           {"robot", s.robot.enabled},
           {"patient", s.patient ? (s.patient->generated ? "generated phantom" : s.patient->labels.string()) : ""},
           {"nwire_phantom", s.nwire_phantom.has_value()},
           {"faults", s.faults.size()},
           {"replay", s.replay ? s.replay->sequence.string() : ""}};
    printReport(options, j,
                "scenario '" + s.name + "' is valid: " + std::to_string(s.tools.size()) + " tools, " +
                    std::to_string(s.faults.size()) + " faults");
    return 0;
  };
}

}  // namespace mrsns::sim
