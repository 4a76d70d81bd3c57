// mrsns-sim run: serves the scenario's operating room until its duration runs
// out or SIGINT/SIGTERM, then writes the truth file and prints a summary.
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <thread>

#include "mrsns/core/error.h"
#include "mrsns/simulation/operating_room.h"
#include "mrsns/simulation/scenario.h"
#include "sim_verbs.h"

namespace mrsns::sim {

namespace {

std::atomic<bool> g_stop{false};

extern "C" void onSignal(int /*signal*/) {
  g_stop = true;
}

struct RunOptions {
  std::string scenario;
  std::string truth;
  std::string ready_file;
  double duration_s = -1.0;
  bool any_ports = false;
  int hmd_port = 0;
  long long seed = -1;
};

// Written atomically once every device listens: a test or `mrsns-cli trial` waits for it.
void writeReadyFile(const std::filesystem::path& path, const Json& ready) {
  const auto tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    if (!out) throw FileError("cannot write the ready file " + path.string());
    out << ready.dump() << "\n";
  }
  std::filesystem::rename(tmp, path);
}

Json endpointsJson(const simulation::OperatingRoomEndpoints& e, const simulation::Scenario& scenario) {
  Json j{{"host", e.host}, {"plus_port", e.plus_port}, {"pid", static_cast<long>(::getpid())}};
  // The headset is a client: where it looks for the workstation's hologram stream.
  if (scenario.hmd.enabled) j["hmd_port"] = scenario.hmd.port;
  // Someone in the room who lines the cube up with its hologram when the workstation asks.
  if (scenario.hmd.enabled && scenario.hmd.cube.enabled && !scenario.hmd.marker_tool.empty()) {
    j["hmd_cube_operator"] = true;
  }
  // Someone who looks at the tracked checkerboard when asked, and a headset that sends its camera's photos.
  if (scenario.hmd.enabled && scenario.hmd.camera.enabled && !scenario.hmd.marker_tool.empty()) {
    j["hmd_camera_operator"] = true;
  }
  // Someone who touches the board's corners with the stylus when the headset asks.
  if (scenario.hmd.enabled && scenario.hmd.board_touch.enabled) j["hmd_board_touch"] = true;
  if (e.robot) {
    j["robot"] = {{"rtde", e.rtde_port},
                  {"dashboard", e.dashboard_port},
                  {"secondary", e.secondary_port},
                  {"realtime", e.realtime_port}};
  }
  return j;
}

int run(const RunOptions& o, const SimOptions& options) {
  auto scenario = simulation::readScenario(o.scenario);
  if (o.duration_s >= 0.0) scenario.duration_s = o.duration_s;
  if (o.seed >= 0) scenario.seed = static_cast<std::uint64_t>(o.seed);
  if (o.hmd_port > 0) {
    if (!scenario.hmd.enabled) {
      throw InvalidArgumentError("--hmd-port: the scenario '" + o.scenario + "' has no headset (hmd)");
    }
    scenario.hmd.port = static_cast<std::uint16_t>(o.hmd_port);
  }
  if (o.any_ports) {
    scenario.tracker.port = 0;
    scenario.robot.rtde_port = scenario.robot.dashboard_port = 0;
    scenario.robot.secondary_port = scenario.robot.realtime_port = 0;
  }
  const std::filesystem::path truth_path = o.truth;
  if (truth_path.has_parent_path() && !std::filesystem::is_directory(truth_path.parent_path())) {
    throw FileError("the folder of the truth file " + truth_path.string() + " does not exist");
  }
  simulation::OperatingRoom room(scenario);
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  room.start();
  const auto endpoints = room.endpoints();
  if (!o.ready_file.empty()) writeReadyFile(o.ready_file, endpointsJson(endpoints, scenario));
  if (!options.json) {
    std::printf("mrsns-sim: scenario '%s' serving PlusServer on %s:%u%s (Ctrl-C to stop)\n", scenario.name.c_str(),
                endpoints.host.c_str(), endpoints.plus_port, endpoints.robot ? ", UR controller" : "");
    std::fflush(stdout);
  }
  while (!g_stop.load() && !room.finished()) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  room.stop();
  room.writeTruth(truth_path);
  const auto s = room.stats();
  Json j{{"scenario", scenario.name},
         {"elapsed_s", s.elapsed_s},
         {"stopped_by", g_stop.load() ? "signal" : "duration"},
         {"endpoints", endpointsJson(endpoints, scenario)},
         {"tracker_samples", s.tracker_samples},
         {"invalid_tool_samples", s.invalid_tool_samples},
         {"tracker_overruns", s.tracker_overruns},
         {"video_frames", s.video_frames},
         {"frozen_frames", s.frozen_frames},
         {"mean_frame_render_ms", s.mean_frame_render_ms},
         {"max_frame_render_ms", s.max_frame_render_ms},
         {"replayed_frames", s.replayed_frames},
         {"faults_fired", s.faults_fired},
         {"messages", {{"TRANSFORM", s.transform_messages}, {"TDATA", s.tdata_messages}, {"IMAGE", s.image_messages}}},
         {"clients_connected", s.clients_connected},
         {"hmd",
          {{"enabled", scenario.hmd.enabled},
           {"connected", s.hmd_connected},
           {"meshes", s.hmd_meshes},
           {"transforms_displayed", s.hmd_transforms}}},
         {"truth", truth_path.string()}};
  char text[512];
  std::snprintf(
      text, sizeof text, "ran %.1f s: %llu tracker samples, %llu video frames (%.1f ms each), %llu faults; truth in %s",
      s.elapsed_s, static_cast<unsigned long long>(s.tracker_samples), static_cast<unsigned long long>(s.video_frames),
      s.mean_frame_render_ms, static_cast<unsigned long long>(s.faults_fired), truth_path.string().c_str());
  printReport(options, j, text);
  return 0;
}

}  // namespace

VerbAction registerRunVerb(CLI::App& app, SimOptions& options, CLI::App*& sub) {
  auto o = std::make_shared<RunOptions>();
  sub = app.add_subcommand("run", "serve the simulated operating room of a scenario (PlusServer, UR controller)");
  sub->add_option("--scenario", o->scenario, "scenario file (JSON, format mrsns-scenario/1; see the docs)")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("--truth", o->truth, "where to write the truth (read only by 'mrsns-sim score')")->required();
  sub->add_option("--duration", o->duration_s, "seconds to run (overrides the scenario's; 0 = until Ctrl-C)")
      ->check(CLI::Range(0.0, 86400.0));
  sub->add_option("--ready-file", o->ready_file,
                  "write {host, plus_port, robot ports, pid} here once every device listens");
  sub->add_flag("--any-ports", o->any_ports,
                "listen on ports the system picks instead of the scenario's (see --ready-file); for tests and "
                "several rooms on one machine");
  sub->add_option("--seed", o->seed, "the room's random seed (overrides the scenario's: noise, hands, operator)")
      ->check(CLI::Range(0LL, 4294967295LL));
  sub->add_option("--hmd-port", o->hmd_port,
                  "the port of the workstation's hologram stream the scenario's headset connects to (overrides "
                  "the scenario's hmd.port)")
      ->check(CLI::Range(1, 65535));
  sub->add_flag("--json", options.json, "print one JSON object at the end");
  return [o, &options] { return run(*o, options); };
}

}  // namespace mrsns::sim
