// `mrsns-cli serve`: the hologram stream for HMD clients. An OpenIGTLink
// server that sends each model as POLYDATA on connect, then each model's
// hologram_T_model (Eq. 1 of paper 001) as TRANSFORM at the tracker rate, and
// STATUS when tracking is lost; fed by playback, the simulator or PlusServer.
// With --webxr-port it also serves the WebXR hologram client (HTTPS page and
// WebSocket, admitted by a pairing code printed at start).
#include <atomic>
#include <cmath>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <iostream>
#include <set>
#include <thread>

#include "cli_context.h"
#include "mrsns/core/error.h"
#include "mrsns/io/mesh_io.h"
#include "mrsns/tracking/hologram_client_preset.h"
#include "mrsns/tracking/hologram_streamer.h"
#include "mrsns/tracking/igtl_source.h"
#include "mrsns/tracking/playback_source.h"
#include "mrsns/tracking/simulated_source.h"
#include "mrsns/webxr/tls_certificate.h"
#include "mrsns/webxr/webxr_hologram_service.h"
#include "mrsns/workflow/steps.h"

namespace mrsns::cli {
namespace {

struct ServeOptions {
  int port = 18944;
  std::string bind = "127.0.0.1";
  std::string source = "simulator";
  std::string sequence;
  std::string plus_host = "127.0.0.1";
  int plus_port = 18944;
  std::vector<std::string> models;
  std::string model_frame = "Reference";
  std::string hologram_frame = "Tracker";
  bool forward_tools = false;
  std::string client = "slicer";
  bool unity = false;
  int igtl_version = 0;  // 0: the client's
  double rate_hz = 60.0;
  double duration_s = 0.0;
  bool loop = false;
  double speed = 1.0;
  bool wait_for_client = false;
  std::uint64_t seed = 1;
  int webxr_port = -1;  // -1: no WebXR client
  std::string webxr_bind;  // empty: --bind
  std::string webxr_code;  // empty: a random one
  std::string webxr_tls_dir;  // empty: webxr::defaultCertificateDirectory()
};

std::atomic<bool> g_stop{false};
extern "C" void onSignal(int) {
  g_stop.store(true);
}

// Restores the previous handlers when serving ends (tests run verbs in-process too).
class SignalGuard {
 public:
  SignalGuard() {
    g_stop.store(false);
    struct sigaction action {};
    action.sa_handler = onSignal;
    sigemptyset(&action.sa_mask);
    sigaction(SIGINT, &action, &old_int_);
    sigaction(SIGTERM, &action, &old_term_);
  }
  ~SignalGuard() {
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }
  SignalGuard(const SignalGuard&) = delete;
  SignalGuard& operator=(const SignalGuard&) = delete;

 private:
  struct sigaction old_int_ {};
  struct sigaction old_term_ {};
};

// The simulator's default scene: a reference frame held still with tremor, a
// pivoting stylus and a probe sweeping a circle.
tracking::SimulatorOptions simulatorScene(const ServeOptions& o) {
  tracking::SimulatorOptions sim;
  sim.rate_hz = o.rate_hz;
  sim.seed = o.seed;
  tracking::ToolScript reference;
  reference.name = o.model_frame + "ToTracker";
  Eigen::Isometry3d reference_pose = Eigen::Isometry3d::Identity();
  reference_pose.translation() = Eigen::Vector3d(0.0, 0.0, -1000.0);
  reference.motion = tracking::StaticMotion{reference_pose};
  reference.tremor = tracking::Tremor{};
  tracking::ToolScript stylus;
  stylus.name = "StylusToTracker";
  stylus.motion = tracking::PivotMotion{};
  tracking::ToolScript probe;
  probe.name = "ProbeToTracker";
  probe.motion = tracking::CircularSweep{};
  sim.tools = {reference};
  if (reference.name != stylus.name) sim.tools.push_back(stylus);
  if (reference.name != probe.name) sim.tools.push_back(probe);
  return sim;
}

std::string modelName(const std::filesystem::path& path, std::set<std::string>& used) {
  std::string name = path.filename().string();
  name = name.substr(0, name.find('.'));  // "C5.stl" -> "C5", "skin.vtk.gz" -> "skin"
  if (name.empty()) name = "Model";
  name = name.substr(0, igtlink::kDeviceNameSize);
  std::string unique = name;
  for (int i = 2; !used.insert(unique).second; ++i) {
    const std::string suffix = "_" + std::to_string(i);
    unique = name.substr(0, igtlink::kDeviceNameSize - suffix.size()) + suffix;
  }
  return unique;
}

void validate(const ServeOptions& o) {
  if (o.source != "playback" && o.source != "simulator" && o.source != "plus") {
    throw InvalidArgumentError("unknown --source '" + o.source + "': use playback, simulator or plus");
  }
  if (o.port < 0 || o.port > 65535) throw InvalidArgumentError("--port must be 0..65535");
  if (o.plus_port < 1 || o.plus_port > 65535) throw InvalidArgumentError("--plus-port must be 1..65535");
  if (o.igtl_version != 0 && o.igtl_version != 1 && o.igtl_version != 2) {
    throw InvalidArgumentError("--igtl-version must be 1 or 2");
  }
  if (o.source == "playback") {
    if (o.sequence.empty()) throw InvalidArgumentError("--source playback needs --sequence FILE (a PLUS .mha/.nrrd)");
    if (!std::filesystem::is_regular_file(o.sequence)) {
      throw FileError("sequence file '" + o.sequence + "' does not exist; check the path given to --sequence");
    }
  }
  if (o.source == "plus" && o.plus_port == o.port &&
      (o.plus_host == "127.0.0.1" || o.plus_host == "localhost" || o.plus_host == o.bind)) {
    throw InvalidArgumentError("--plus-port " + std::to_string(o.plus_port) +
                               " on this machine is serve's own --port: give one of them another port");
  }
  if (!(o.rate_hz > 0.0 && o.rate_hz <= 10000.0)) throw InvalidArgumentError("--rate must be in (0, 10000] Hz");
  if (!(o.duration_s >= 0.0)) throw InvalidArgumentError("--duration must be >= 0 s (0 = until Ctrl-C)");
  if (!(o.speed >= 0.0)) throw InvalidArgumentError("--speed must be >= 0 (0 = as fast as possible)");
  if (o.webxr_port < -1 || o.webxr_port > 65535) throw InvalidArgumentError("--webxr-port must be 0..65535");
  if (o.webxr_port >= 0 && o.webxr_port == o.port && o.port != 0) {
    throw InvalidArgumentError("--webxr-port and --port are the same port: give the WebXR client another one");
  }
  if (!o.webxr_code.empty() && !webxr::isValidPairingCode(o.webxr_code)) {
    throw InvalidArgumentError("--webxr-code must be 6 to 12 digits");
  }
  for (const auto& m : o.models) {
    if (!std::filesystem::is_regular_file(m)) {
      throw FileError("model file '" + m + "' does not exist; check the paths given to --models");
    }
  }
}

std::unique_ptr<webxr::WebXrHologramService> makeWebXr(const ServeOptions& o,
                                                      std::shared_ptr<TransformRepository> repository,
                                                      std::vector<tracking::HologramModel> models,
                                                      const tracking::HologramStreamOptions& stream_options) {
  if (o.webxr_port < 0) return nullptr;
  const std::filesystem::path tls_dir =
      o.webxr_tls_dir.empty() ? webxr::defaultCertificateDirectory() : std::filesystem::path(o.webxr_tls_dir);
  webxr::WebXrServiceOptions web = webxr::workstationWebXrOptions(
      workflow::resourceDirectory() / "webxr", o.webxr_bind.empty() ? o.bind : o.webxr_bind,
      static_cast<std::uint16_t>(o.webxr_port), tls_dir);
  if (web.server.certificate.generated) {
    std::cerr << "mrsns-cli serve: made a self-signed certificate for the WebXR client in " << tls_dir.string()
              << std::endl;
  }
  if (!o.webxr_code.empty()) web.server.pairing_code = o.webxr_code;
  web.stream.hologram_frame = stream_options.hologram_frame;
  web.stream.forward_transforms = o.forward_tools ? stream_options.forward_transforms : std::vector<std::string>{};
  return std::make_unique<webxr::WebXrHologramService>(std::move(repository), std::move(models), std::move(web));
}

Json webXrReport(webxr::WebXrHologramService& web) {
  const auto server = web.server().stats();
  const auto relay = web.relay().stats();
  Json j;
  j["url"] = web.url();
  j["port"] = web.server().port();
  j["pages_paired"] = server.paired;
  j["pairings_refused"] = server.pairings_refused;
  j["clients_dropped"] = server.clients_dropped;
  j["files_served"] = server.files_served;
  j["frames_sent"] = server.frames_sent;
  j["confirmations_forwarded"] = relay.confirmations_forwarded;
  j["display_reports"] = relay.display_reports;
  j["models_shown"] = relay.models_shown;
  auto number = [](double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); };
  j["display_latency_p50_ms"] = number(relay.display_latency_p50_ms);
  j["display_latency_p99_ms"] = number(relay.display_latency_p99_ms);
  return j;
}

Report run(const ServeOptions& o) {
  validate(o);
  auto repository = std::make_shared<TransformRepository>();
  // The models live in the model frame (identity T_Vir^Pre and T_Pre^Pat until
  // a registration sets them); the hologram frame is where the HMD shows them.
  std::vector<tracking::HologramModel> models;
  std::set<std::string> used;
  for (const auto& path : o.models) {
    tracking::HologramModel model;
    model.mesh = io::readMesh(path);
    model.name = modelName(path, used);
    model.frame = o.model_frame;
    models.push_back(std::move(model));
  }

  std::unique_ptr<tracking::TrackingSource> source;
  if (o.source == "playback") {
    tracking::PlaybackOptions playback;
    playback.speed = o.speed;
    playback.loop = o.loop;
    source = std::make_unique<tracking::PlaybackTrackingSource>(repository, o.sequence, playback);
  } else if (o.source == "simulator") {
    source = std::make_unique<tracking::SimulatedTrackingSource>(repository, simulatorScene(o));
  } else {
    tracking::IgtlSourceOptions plus;
    plus.client.host = o.plus_host;
    plus.client.port = static_cast<std::uint16_t>(o.plus_port);
    plus.request_tdata = true;
    source = std::make_unique<tracking::IgtlTrackingSource>(repository, plus);
  }

  igtlink::ServerOptions server_options;
  server_options.bind_address = o.bind;
  server_options.port = static_cast<std::uint16_t>(o.port);
  igtlink::Server server(server_options);
  tracking::HologramStreamOptions stream_options;
  stream_options.hologram_frame = o.hologram_frame;
  if (o.forward_tools) stream_options.forward_transforms = source->toolNames();
  const tracking::HologramClientPreset& preset = tracking::hologramClientPreset(o.unity ? "unity-metres" : o.client);
  stream_options = tracking::withClientPreset(std::move(stream_options), preset);
  if (o.igtl_version != 0) {
    stream_options.version = o.igtl_version == 1 ? igtlink::HeaderVersion::kV1 : igtlink::HeaderVersion::kV2;
  }
  tracking::HologramStreamer streamer(server, repository, models, stream_options);
  std::unique_ptr<webxr::WebXrHologramService> web = makeWebXr(o, repository, models, stream_options);
  source->setUpdateCallback([&streamer, &web](std::span<const tracking::ToolUpdate> updates) {
    streamer.update(updates.front().timestamp);
    if (web) web->update(updates.front().timestamp);
  });

  SignalGuard signals;
  server.start();  // throws NetworkError (port in use, bad address)
  std::cerr << "mrsns-cli serve: listening on " << o.bind << ':' << server.port() << " (source " << source->name()
            << ", " << models.size() << " model(s))" << std::endl;
  if (web) {
    web->start();  // throws NetworkError
    std::cerr << "mrsns-cli serve: WebXR client at " << web->url() << "  pairing code " << web->pairingCode()
              << "  (certificate SHA-256 " << web->certificateFingerprint() << ")" << std::endl;
  }
  const auto t0 = std::chrono::steady_clock::now();
  auto elapsed = [&t0] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  bool started = false;
  while (!g_stop.load() && (o.duration_s == 0.0 || elapsed() < o.duration_s)) {
    if (!started && (!o.wait_for_client || streamer.readyClients() > 0)) {
      source->start();
      started = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  source->stop();
  // Let the last queued messages leave before closing the connections.
  for (int i = 0; i < 20; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  server.stop();
  if (web) web->stop();

  const auto server_stats = server.stats();
  const auto stream_stats = streamer.stats();
  const auto source_status = source->status();
  Report report;
  report.json["verb"] = "serve";
  report.json["source"] = source->name();
  report.json["port"] = server.port();
  report.json["bind"] = o.bind;
  report.json["client"] = preset.name;
  report.json["igtl_version"] = stream_options.version == igtlink::HeaderVersion::kV1 ? 1 : 2;
  report.json["unity"] = stream_options.unity;
  report.json["models"] = Json::array();
  for (const auto& m : models) report.json["models"].push_back(m.name);
  report.json["duration_s"] = elapsed();
  report.json["stopped_by_signal"] = g_stop.load();
  report.json["source_updates"] = source_status.updates;
  report.json["source_state"] = std::string(tracking::toString(source_status.state));
  report.json["clients"] = server_stats.connections_accepted;
  report.json["clients_refused"] = server_stats.connections_refused;
  report.json["messages_sent"] = server_stats.messages_sent;
  report.json["stream_messages_dropped"] = server_stats.stream_messages_dropped;
  report.json["meshes_queued"] = stream_stats.meshes_queued;
  report.json["transforms_queued"] = stream_stats.transforms_queued;
  report.json["statuses_queued"] = stream_stats.statuses_queued;
  report.json["client_messages_ignored"] = stream_stats.client_messages_ignored;
  report.json["malformed_messages"] = server_stats.malformed_messages;
  if (web) report.json["webxr"] = webXrReport(*web);
  report.text = "served " + std::to_string(server_stats.messages_sent) + " messages to " +
                std::to_string(server_stats.connections_accepted) + " client(s) in " + std::to_string(elapsed()) +
                " s (" + std::to_string(server_stats.stream_messages_dropped) + " stream messages dropped, " +
                std::to_string(stream_stats.client_messages_ignored) + " client messages ignored)";
  return report;
}

}  // namespace

void registerServeVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto o = std::make_shared<ServeOptions>();
  auto* sub = app.add_subcommand(
      "serve",
      "OpenIGTLink server for HMD clients (the hologram stream): on connect each model is sent as POLYDATA, then "
      "each model's transform T_Vir^Hol (ModelToHologram, Eq. 1 of paper 001) as TRANSFORM at the tracker rate, and "
      "STATUS "
      "when tracking is lost. Send-only: client messages are logged and ignored. Stops after --duration or on "
      "Ctrl-C/SIGTERM.");
  sub->add_option("--port", o->port, "TCP port to listen on (0 = any free port)")->capture_default_str();
  sub->add_option("--bind", o->bind, "address to bind (127.0.0.1 = this machine only; 0.0.0.0 = every interface)")
      ->capture_default_str();
  sub->add_option("--source", o->source,
                  "tracking source: playback (a PLUS sequence file), simulator or plus "
                  "(PlusServer over OpenIGTLink)")
      ->capture_default_str();
  sub->add_option("--sequence", o->sequence, "PLUS sequence file (.mha/.mhd/.seq.nrrd) for --source playback");
  sub->add_option("--plus-host", o->plus_host, "PlusServer host for --source plus")->capture_default_str();
  sub->add_option("--plus-port", o->plus_port, "PlusServer port for --source plus")->capture_default_str();
  sub->add_option("--models", o->models,
                  "mesh files to stream (.stl/.ply/.vtk/.obj...); device name = file name without extension "
                  "(at most 20 characters)");
  sub->add_option("--model-frame", o->model_frame,
                  "repository frame the models are attached to (the tracked patient reference)")
      ->capture_default_str();
  sub->add_option("--hologram-frame", o->hologram_frame, "frame the HMD displays the models in")->capture_default_str();
  sub->add_flag("--forward-tools", o->forward_tools,
                "also stream every tool transform of the source under its own name (e.g. ProbeToTracker; playback and "
                "simulator only: PlusServer's tools are known only once they arrive)");
  std::string clients;
  for (const auto& preset : tracking::hologramClientPresets()) clients += "\n  " + preset.name + ": " + preset.description;
  auto* client = sub->add_option("--client", o->client,
                                 "the headset client, which sets the header version, units, handedness and messages "
                                 "it can read:" +
                                     clients)
                     ->capture_default_str();
  sub->add_flag("--unity", o->unity, "the same as --client unity-metres (left-handed metres on the wire)")
      ->excludes(client);
  sub->add_option("--igtl-version", o->igtl_version,
                  "OpenIGTLink header version 1 or 2 instead of the client's (a client may then read nothing)");
  sub->add_option("--rate", o->rate_hz, "simulator rate in Hz (playback and PlusServer stream at their own rate)")
      ->capture_default_str();
  sub->add_option("--duration", o->duration_s, "stop after this many seconds (0 = until Ctrl-C or SIGTERM)")
      ->capture_default_str();
  sub->add_flag("--loop", o->loop, "playback: start again after the last frame");
  sub->add_option("--speed", o->speed, "playback speed factor (1 = real time, 0 = as fast as possible)")
      ->capture_default_str();
  sub->add_flag("--wait-for-client", o->wait_for_client,
                "start the source only when the first client has connected (playback then starts at frame 0)");
  sub->add_option("--seed", o->seed, "simulator noise seed")->capture_default_str();
  sub->add_option("--webxr-port", o->webxr_port,
                  "also serve the WebXR hologram client (a page for headset browsers: HTTPS and a WebSocket) on this "
                  "port, e.g. 8443 (0 = any free port); its URL and pairing code are printed at start");
  sub->add_option("--webxr-bind", o->webxr_bind, "address of the WebXR client's server (default: --bind)");
  sub->add_option("--webxr-code", o->webxr_code,
                  "the WebXR pairing code (6 to 12 digits; default: a new random code at each start)");
  sub->add_option("--webxr-tls-dir", o->webxr_tls_dir,
                  "folder of the WebXR server's certificate, made there on first use (default: "
                  "~/.config/mrsns/webxr-tls)");
  addJsonFlag(*sub, options);
  verbs.emplace_back(sub, [o] { return run(*o); });
}

}  // namespace mrsns::cli
