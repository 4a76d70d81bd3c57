// `mrsns-cli session create|run|info|steps`: the workstation's session and
// workflow steps, headless (the same calls the GUI makes).
#include <array>
#include <atomic>
#include <csignal>
#include <thread>
#include <iostream>
#include <optional>
#include <sstream>

#include "cli_context.h"
#include "mrsns/core/error.h"
#include "mrsns/workflow/steps.h"

namespace mrsns::cli {

namespace {

std::atomic<bool> g_cancel_run{false};

extern "C" void onStopSignal(int /*signal*/) {
  g_cancel_run = true;
}

}  // namespace
namespace {

// "k=v": v as JSON when it parses (numbers, true/false, quoted strings), else as text.
nlohmann::json parseParams(const std::vector<std::string>& pairs) {
  nlohmann::json params = nlohmann::json::object();
  for (const auto& pair : pairs) {
    const auto eq = pair.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw InvalidArgumentError("--param '" + pair + "' is not NAME=VALUE (e.g. --param duration_s=2)");
    }
    const std::string key = pair.substr(0, eq);
    const std::string value = pair.substr(eq + 1);
    nlohmann::json parsed = nlohmann::json::parse(value, nullptr, false);
    params[key] = (parsed.is_discarded() || parsed.is_object() || parsed.is_array()) ? nlohmann::json(value) : parsed;
  }
  return params;
}

// "TOOL:START_S:DURATION_S" (a PLUS transform name, start >= 0, duration > 0).
struct Dropout {
  std::string tool;
  double start_s = 0.0, duration_s = 0.0;
};
std::optional<Dropout> parseDropout(const std::string& text) {
  const auto a = text.find(':');
  const auto b = a == std::string::npos ? a : text.find(':', a + 1);
  if (a == 0 || b == std::string::npos) return std::nullopt;
  Dropout d;
  d.tool = text.substr(0, a);
  try {
    std::size_t used_start = 0, used_duration = 0;
    const std::string start = text.substr(a + 1, b - a - 1), duration = text.substr(b + 1);
    d.start_s = std::stod(start, &used_start);
    d.duration_s = std::stod(duration, &used_duration);
    if (used_start != start.size() || used_duration != duration.size()) return std::nullopt;
  } catch (const std::exception&) {
    return std::nullopt;
  }
  if (!(d.start_s >= 0.0 && d.duration_s > 0.0)) return std::nullopt;
  return d;
}

// "RTDE,SCRIPT,DASHBOARD": three TCP ports (UR: 30004,30003,29999).
std::optional<std::array<int, 3>> parsePorts(const std::string& text) {
  std::array<int, 3> ports{};
  std::istringstream in(text);
  std::string item;
  std::size_t n = 0;
  while (std::getline(in, item, ',')) {
    if (n == 3 || item.empty() || item.find_first_not_of("0123456789") != std::string::npos || item.size() > 5) {
      return std::nullopt;
    }
    ports[n++] = std::stoi(item);
    if (ports[n - 1] < 1 || ports[n - 1] > 65535) return std::nullopt;
  }
  if (n != 3 || text.back() == ',') return std::nullopt;
  return ports;
}

void addNavigationFlags(const std::string& step, const std::string& robot, const std::string& dropout,
                        nlohmann::json& params) {
  if (!robot.empty()) {
    if (step != "navigation") throw InvalidArgumentError("--robot applies to the navigation step, not '" + step + "'");
    params["robot"] = robot;
  }
  if (!dropout.empty()) {
    if (step != "navigation" && step != "connect-devices") {
      throw InvalidArgumentError("--tracker-dropout applies to the navigation and connect-devices steps, not '" + step +
                                 "'");
    }
    const auto d = parseDropout(dropout);  // validated by the option's check
    params["dropout_tool"] = d->tool;
    params["dropout_start_s"] = d->start_s;
    params["dropout_duration_s"] = d->duration_s;
  }
}

// The figures a script checks after a navigation run, at the top of the JSON.
void addNavigationReport(const workflow::Session& session, const workflow::StepResult& result, Report& report) {
  const Json f = report.json["figures"];  // a copy: adding keys below moves the ordered map's storage
  const bool robot = f.contains("robot");
  report.json["robot"] = robot ? f["robot"]["mode"] : Json("none");
  report.json["robot_stopped"] = f.value("robot_stopped", false);
  report.json["stop_reason"] = f.value("stop_reason", "");
  report.json["supervisor_state"] = robot ? f["robot"]["supervisor_state"] : Json(nullptr);
  report.json["stop_latency_cycles"] = robot ? f["robot"]["stop_latency_cycles"] : Json(nullptr);
  report.json["stop_latency_ms"] = robot ? f["robot"]["stop_latency_ms"] : Json(nullptr);
  report.json["time_to_stop_s"] = robot ? f["robot"]["time_to_stop_s"] : Json(nullptr);
  report.json["arm_speed_end_rad_s"] = robot ? f["robot"]["arm_speed_end_rad_s"] : Json(nullptr);
  report.json["frames_recorded"] = f.value("frames_recorded", 0);
  report.json["recording"] = result.outputs.empty() ? Json(nullptr) : Json(session.resolve(result.outputs[0]).string());
}

Json stepsJson(const workflow::Session& session) {
  Json out = Json::array();
  for (const auto& info : workflow::listSteps()) {
    const auto s = session.step(info.name);
    out.push_back(Json{{"name", info.name},
                       {"area", info.area},
                       {"group", info.group},
                       {"status", s.is_null() ? "not run" : s.value("status", "?")},
                       {"summary", s.is_null() ? "" : s.value("summary", "")}});
  }
  return out;
}

// The document's types convert to nlohmann::json; the CLI prints ordered JSON.
template <typename T>
Json typed(const T& value) {
  return Json::parse(nlohmann::json(value).dump());
}

Json transformsJson(const std::vector<workflow::TransformEntry>& list) {
  Json out = Json::object();
  for (const auto& t : list) out[t.name] = typed(t);
  return out;
}

std::string fixed1(double v) {
  std::ostringstream s;
  s.precision(1);
  s << std::fixed << v;
  return s.str();
}

Report infoReport(const workflow::Session& session, const std::string& verb) {
  Report report;
  report.json["verb"] = verb;
  report.json["folder"] = session.folder().string();
  report.json["version"] = session.state()["version"];
  report.json["created"] = session.state().value("created", "");
  if (session.openedVersion() != workflow::kSessionVersion) report.json["migrated_from_version"] = session.openedVersion();
  const auto ct = session.ct();
  report.json["ct"] = ct ? typed(*ct) : Json(nullptr);
  report.json["label_maps"] = typed(session.labelMaps());
  report.json["models"] = typed(session.models());
  const auto shape = session.shapeModel();
  report.json["shape_model"] = shape ? typed(*shape) : Json(nullptr);
  const auto fiducials = session.fiducials();
  report.json["fiducials"] = fiducials ? typed(*fiducials) : Json(nullptr);
  report.json["plans"] = typed(session.plans());
  report.json["calibrations"] = transformsJson(session.calibrations());
  report.json["registrations"] = transformsJson(session.registrations());
  report.json["recordings"] = typed(session.recordings());
  report.json["steps"] = stepsJson(session);
  report.json["log_lines"] = session.state()["log"].size();
  std::ostringstream text;
  text << "session " << session.folder().string() << " (version " << workflow::kSessionVersion << ")\n";
  if (ct) {
    text << "  CT: " << ct->name << ", " << ct->size_px[0] << "x" << ct->size_px[1] << "x" << ct->size_px[2]
         << " voxels of " << ct->spacing_mm.x() << " x " << ct->spacing_mm.y() << " x " << ct->spacing_mm.z()
         << " mm (" << ct->file << ")\n";
  } else {
    text << "  CT: none (import-ct)\n";
  }
  for (const auto& m : session.models()) {
    text << "  model " << m.id << ": " << workflow::modelRoleName(m.role) << ", " << m.triangles << " triangles, "
         << fixed1(m.volume_ml) << " ml";
    if (m.voxel_volume_ml > 0.0) text << " (voxels " << fixed1(m.voxel_volume_ml) << " ml)";
    text << "\n";
  }
  if (fiducials) text << "  fiducials: " << fiducials->points.size() << "\n";
  for (const auto& p : session.plans()) {
    text << "  screw " << p.name << " (" << (p.vertebra.empty() ? "?" : p.vertebra) << ")";
    const Json& f = p.figures;
    if (f.contains("breach") && f["breach"].is_object()) {
      text << ": breach " << fixed1(f["breach"].value("max_breach_mm", 0.0)) << " mm ("
           << f["breach"].value("grade", "?") << ")";
    }
    if (f.contains("clearance") && f["clearance"].is_object()) {
      for (const char* kind : {"vessel", "neural", "soft_tissue"}) {
        if (f["clearance"].contains(kind) && f["clearance"][kind].is_object()) {
          text << ", " << fixed1(f["clearance"][kind].value("min_clearance_mm", 0.0)) << " mm from "
               << f["clearance"][kind].value("name", kind);
        }
      }
    }
    text << "\n";
  }
  for (const auto& list : {session.calibrations(), session.registrations()}) {
    for (const auto& t : list) {
      text << "  " << t.kind << " " << t.name << " (" << t.provenance.step << ", " << t.provenance.time
           << (t.provenance.simulated ? ", simulated" : "") << ")\n";
    }
  }
  for (const auto& s : report.json["steps"]) {
    text << "  " << s["name"].get<std::string>() << ": " << s["status"].get<std::string>();
    if (!s["summary"].get<std::string>().empty()) text << " - " << s["summary"].get<std::string>();
    text << "\n";
  }
  report.text = text.str();
  return report;
}

}  // namespace

void registerSessionVerbs(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto* group = app.add_subcommand("session", "Surgical sessions: create one, run workflow steps on it, show it");
  group->require_subcommand(1);

  auto folder_create = std::make_shared<std::string>();
  auto* create = group->add_subcommand("create", "Create an empty session folder (session.json)");
  create->add_option("DIR", *folder_create, "new session folder (absent or empty)")->required();
  addJsonFlag(*create, options);
  verbs.emplace_back(create, [folder_create]() -> Report {
    const auto s = workflow::Session::create(*folder_create);
    auto report = infoReport(s, "session create");
    report.text = "created session " + s.folder().string() + "\n";
    return report;
  });

  auto folder_sample = std::make_shared<std::string>();
  auto* sample = group->add_subcommand("sample", "Create a session folder from the bundled sample session");
  sample->add_option("DIR", *folder_sample, "new session folder (absent or empty)")->required();
  addJsonFlag(*sample, options);
  verbs.emplace_back(sample, [folder_sample]() -> Report {
    const auto s = workflow::createSessionFromSample(*folder_sample);
    auto report = infoReport(s, "session sample");
    report.json["sample"] = workflow::sampleSessionPath().string();
    report.text = "created session " + s.folder().string() + " from " + workflow::sampleSessionPath().string() + "\n";
    return report;
  });

  auto folder_info = std::make_shared<std::string>();
  auto* info = group->add_subcommand("info", "Show a session: every step's status and summary");
  info->add_option("DIR", *folder_info, "session folder")->required();
  addJsonFlag(*info, options);
  verbs.emplace_back(info, [folder_info]() -> Report {
    auto report = infoReport(workflow::Session::open(*folder_info), "session info");
    return report;
  });

  auto* steps = group->add_subcommand("steps", "List the workflow steps (paper 001 §III.C)");
  addJsonFlag(*steps, options);
  verbs.emplace_back(steps, []() -> Report {
    Report report;
    report.json["verb"] = "session steps";
    Json list = Json::array();
    std::ostringstream text;
    for (const auto& s : workflow::listSteps()) {
      list.push_back(Json{{"name", s.name},
                          {"title", s.title},
                          {"area", s.area},
                          {"group", s.group},
                          {"description", s.description}});
      text << s.name << " (" << s.area << "): " << s.description << "\n";
    }
    report.json["steps"] = list;
    report.text = text.str();
    return report;
  });

  struct RunArgs {
    std::string folder;
    std::string step;
    std::vector<std::string> params;
    bool progress = false;
    bool confirm_on_enter = false;
    std::string robot;
    std::string dropout;
    std::string robot_host;
    std::string robot_ports;
  };
  auto args = std::make_shared<RunArgs>();
  auto* run = group->add_subcommand("run", "Run one workflow step on a session (see 'session steps')");
  run->add_option("DIR", args->folder, "session folder")->required();
  run->add_option("STEP", args->step, "step name, e.g. registration")->required();
  run->add_option("--param", args->params, "step parameter NAME=VALUE (repeatable)");
  run->add_flag("--progress", args->progress, "print progress lines on stderr");
  run->add_flag("--confirm-on-enter", args->confirm_on_enter,
                "each line on stdin (Enter, or a foot pedal that sends it) confirms what the step asks, e.g. the "
                "HMD calibration's cube held on its hologram");
  run->add_option("--robot", args->robot,
                  "navigation: the robot the loop drives (auto: simulated when the session has a plan)")
      ->check(CLI::IsMember({"auto", "none", "simulated", "ur"}));
  run->add_option("--robot-host", args->robot_host, "navigation --robot ur: the UR controller's address (127.0.0.1)");
  run->add_option("--robot-ports", args->robot_ports,
                  "navigation --robot ur: the controller's ports RTDE,SCRIPT,DASHBOARD (30004,30003,29999)")
      ->check(CLI::Validator(
          [](std::string& text) -> std::string {
            return parsePorts(text) ? std::string() : "expected RTDE,SCRIPT,DASHBOARD ports, got '" + text + "'";
          },
          "RTDE,SCRIPT,DASHBOARD"));
  run->add_option("--tracker-dropout", args->dropout,
                  "navigation, connect-devices: simulated tracker loss TOOL:START_S:DURATION_S "
                  "(e.g. PatientToTracker:2.2:1)")
      ->check(CLI::Validator(
          [](std::string& text) -> std::string {
            return parseDropout(text) ? std::string() : "expected TOOL:START_S:DURATION_S, got '" + text + "'";
          },
          "TOOL:START_S:DURATION_S"));
  addJsonFlag(*run, options);
  verbs.emplace_back(run, [args]() -> Report {
    auto session = workflow::Session::open(args->folder);
    workflow::StepContext context;
    if (args->progress) {
      // A live step reports ten times a second; a line per change is enough to follow it.
      context.progress = [last = std::string()](double f, const std::string& message) mutable {
        if (message == last) return;
        last = message;
        std::cerr << static_cast<int>(f * 100.0) << "% " << message << "\n";
      };
    }
    auto params = parseParams(args->params);
    addNavigationFlags(args->step, args->robot, args->dropout, params);
    if (!args->robot_host.empty() || !args->robot_ports.empty()) {
      if (args->step != "navigation" || params.value("robot", "") != "ur") {
        throw InvalidArgumentError("--robot-host and --robot-ports apply to the navigation step with --robot ur");
      }
      if (!args->robot_host.empty()) params["ur_host"] = args->robot_host;
      if (const auto ports = args->robot_ports.empty() ? std::nullopt : parsePorts(args->robot_ports)) {
        params["ur_rtde_port"] = (*ports)[0];
        params["ur_script_port"] = (*ports)[1];
        params["ur_dashboard_port"] = (*ports)[2];
      }
    }
    // Ctrl-C (or SIGTERM) asks the step to stop as the GUI's Cancel does: a live acquisition stops its devices
    // (an arm is brought to rest) and keeps what it recorded, instead of the process dying mid-motion.
    g_cancel_run = false;
    context.cancel = &g_cancel_run;
    if (args->confirm_on_enter) {
      // The reader blocks on stdin until the process ends: detached, it never holds the step up.
      static std::atomic<std::uint64_t> confirmations{0};
      context.confirmations = &confirmations;
      std::thread([] {
        std::string line;
        while (std::getline(std::cin, line)) confirmations.fetch_add(1);
      }).detach();
    }
    std::signal(SIGINT, onStopSignal);
    std::signal(SIGTERM, onStopSignal);
    const auto result = workflow::runStep(session, args->step, params, context);
    std::signal(SIGINT, SIG_DFL);
    std::signal(SIGTERM, SIG_DFL);
    if (result.cancelled) {
      throw ComputationError("step '" + args->step +
                             "' cancelled (Ctrl-C or SIGTERM); what it recorded is kept in the session");
    }
    if (!result.ok) {
      throw ComputationError("step '" + args->step + "' did not succeed: " + result.summary);
    }
    Report report;
    report.json["verb"] = "session run";
    report.json["step"] = args->step;
    report.json["ok"] = result.ok;
    report.json["summary"] = result.summary;
    report.json["figures"] = Json::parse(result.figures.dump());
    report.json["outputs"] = result.outputs;
    report.text = args->step + ": " + result.summary + "\n";
    if (args->step == "navigation") addNavigationReport(session, result, report);
    return report;
  });
}

}  // namespace mrsns::cli
