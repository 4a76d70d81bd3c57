// `mrsns-cli robot-sim`: the in-project UR controller simulator (RTDE 30004, dashboard 29999, secondary 30002,
// real-time 30003) on 127.0.0.1 until --duration elapses or Ctrl-C; prints what it served.
// `mrsns-cli robot-status --host H`: reads a UR controller's (or the simulator's) dashboard and RTDE state.
#include <atomic>
#include <chrono>
#include <csignal>
#include <thread>

#include "cli_context.h"
#include "mrsns/core/error.h"
#include "mrsns/core/format.h"
#include "mrsns/robot/dashboard_client.h"
#include "mrsns/robot/ur_rtde_arm.h"
#include "mrsns/robot/ur_simulator.h"
#include "mrsns/robot/urscript.h"

namespace mrsns::cli {
namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

struct Ports {
  std::uint16_t rtde, dashboard, secondary, realtime;
};

Ports portsWithOffset(int offset) {
  return {static_cast<std::uint16_t>(30004 + offset), static_cast<std::uint16_t>(29999 + offset),
          static_cast<std::uint16_t>(30002 + offset), static_cast<std::uint16_t>(30003 + offset)};
}

std::atomic<bool> g_robot_sim_stop{false};
extern "C" void onRobotSimSignal(int) {
  g_robot_sim_stop.store(true);
}

// Restores the previous handlers when the simulator ends.
class SignalScope {
 public:
  SignalScope() {
    g_robot_sim_stop.store(false);
    struct sigaction action {};
    action.sa_handler = onRobotSimSignal;
    sigemptyset(&action.sa_mask);
    sigaction(SIGINT, &action, &old_int_);
    sigaction(SIGTERM, &action, &old_term_);
  }
  ~SignalScope() {
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }
  SignalScope(const SignalScope&) = delete;
  SignalScope& operator=(const SignalScope&) = delete;

 private:
  struct sigaction old_int_ {};
  struct sigaction old_term_ {};
};

Json jointsJson(const robot::Joints& q, double scale) {
  Json a = Json::array();
  for (int i = 0; i < 6; ++i) a.push_back(q[i] * scale);
  return a;
}

struct SimOptions {
  std::string host = "127.0.0.1";
  int port_offset = 0;
  double duration_s = 0;
  bool power_off = false;
  double unlock_delay_s = 5.0;
};

Report runSim(const SimOptions& o) {
  if (!(o.duration_s >= 0)) throw InvalidArgumentError("--duration must be >= 0 s (0 = until Ctrl-C)");
  if (!(o.unlock_delay_s >= 0)) throw InvalidArgumentError("--unlock-delay must be >= 0 s");
  robot::UrSimulatorOptions options;
  const auto ports = portsWithOffset(o.port_offset);
  options.host = o.host;
  options.rtde_port = ports.rtde;
  options.dashboard_port = ports.dashboard;
  options.secondary_port = ports.secondary;
  options.realtime_port = ports.realtime;
  options.start_ready = !o.power_off;
  options.unlock_delay_s = o.unlock_delay_s;
  SignalScope signals;
  robot::UrSimulator sim(options);
  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  while (!g_robot_sim_stop.load() && (o.duration_s == 0 || elapsed() < o.duration_s)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  const auto stats = sim.stats();
  const auto state = sim.armState();
  const double ran_s = elapsed();
  sim.stop();

  Report r;
  r.json["host"] = o.host;
  r.json["ports"] = {{"rtde", sim.rtdePort()},
                     {"dashboard", sim.dashboardPort()},
                     {"secondary", sim.secondaryPort()},
                     {"realtime", sim.realtimePort()}};
  r.json["ran_s"] = ran_s;
  r.json["control_period_s"] = sim.arm().controlPeriodS();
  r.json["cycles"] = stats.cycles;
  r.json["mean_cycle_rate_hz"] = ran_s > 0 ? static_cast<double>(stats.cycles) / ran_s : 0.0;
  r.json["clients_connected"] = stats.clients_connected;
  r.json["rtde_packages_sent"] = stats.rtde_packages_sent;
  r.json["rtde_inputs_received"] = stats.rtde_inputs_received;
  r.json["script_commands"] = stats.script_commands;
  r.json["script_rejected"] = stats.script_rejected;
  r.json["dashboard_commands"] = stats.dashboard_commands;
  r.json["protocol_errors"] = stats.protocol_errors;
  r.json["final_joints_rad"] = jointsJson(state.q, 1.0);
  r.json["final_safety_mode"] = robot::toString(robot::toUrSafetyMode(state.safety));
  r.text = "UR simulator on " + o.host + " (RTDE " + std::to_string(sim.rtdePort()) + ", dashboard " +
           std::to_string(sim.dashboardPort()) + ", secondary " + std::to_string(sim.secondaryPort()) + ", real-time " +
           std::to_string(sim.realtimePort()) + ") ran " + formatFixed(ran_s, 1) + " s, " +
           std::to_string(stats.cycles) + " cycles, " + std::to_string(stats.clients_connected) + " clients, " +
           std::to_string(stats.script_commands) + " script commands";
  return r;
}

struct StatusOptions {
  std::string host = "127.0.0.1";
  int port_offset = 0;
  double frequency_hz = 125;
  double timeout_s = 2.0;
};

Report runStatus(const StatusOptions& o) {
  if (!(o.timeout_s > 0)) throw InvalidArgumentError("--timeout must be > 0 s");
  const auto ports = portsWithOffset(o.port_offset);
  robot::DashboardClient dashboard({o.host, ports.dashboard, o.timeout_s});
  const auto robot_mode = dashboard.robotMode();
  const auto safety = dashboard.safetyStatus();
  const bool running = dashboard.programRunning();
  const auto polyscope = dashboard.polyscopeVersion();

  robot::UrRtdeArmOptions arm_options;
  arm_options.host = o.host;
  arm_options.rtde_port = ports.rtde;
  arm_options.dashboard_port = ports.dashboard;
  arm_options.script_port = ports.realtime;
  arm_options.frequency_hz = o.frequency_hz;
  arm_options.connect_timeout_s = o.timeout_s;
  robot::UrRtdeArm arm(arm_options);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(o.timeout_s);
  while (!arm.state().connected && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  const auto state = arm.state();
  if (!state.connected) {
    throw NetworkError("UR controller at " + o.host + ": RTDE connected but no state arrived within " +
                       formatFixed(o.timeout_s, 1) + " s");
  }
  const auto pose = robot::urscript::toUrPose(state.base_T_flange);

  Report r;
  r.json["host"] = o.host;
  r.json["polyscope_version"] = polyscope;
  r.json["controller_version"] = arm.controllerVersion();
  r.json["robot_mode"] = robot::toString(robot_mode);
  r.json["safety_mode"] = robot::toString(safety);
  r.json["program_running"] = running;
  r.json["controller_time_s"] = state.time_s;
  r.json["joints_rad"] = jointsJson(state.q, 1.0);
  r.json["joints_deg"] = jointsJson(state.q, kRadToDeg);
  r.json["joint_speeds_rad_s"] = jointsJson(state.qd, 1.0);
  r.json["tcp_position_mm"] = {state.base_T_flange.translation().x(), state.base_T_flange.translation().y(),
                               state.base_T_flange.translation().z()};
  r.json["tcp_rotation_vector_rad"] = {pose[3], pose[4], pose[5]};
  r.json["tcp_speed_mm_s"] = state.flange_twist.head<3>().norm();
  r.json["rtde_frequency_hz"] = o.frequency_hz;
  r.json["rtde_packages"] = arm.stats().packages;
  r.text = "UR controller " + o.host + " (" + polyscope + "): " + robot::toString(robot_mode) + ", safety " +
           robot::toString(safety) + (running ? ", program running" : ", no program running") + "\n  joints (deg):";
  for (int i = 0; i < 6; ++i) r.text += " " + formatFixed(state.q[i] * kRadToDeg, 2);
  r.text += "\n  TCP (mm): " + formatFixed(state.base_T_flange.translation().x(), 1) + " " +
            formatFixed(state.base_T_flange.translation().y(), 1) + " " +
            formatFixed(state.base_T_flange.translation().z(), 1);
  return r;
}

}  // namespace

void registerRobotSimVerbs(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto sim_options = std::make_shared<SimOptions>();
  auto* sim = app.add_subcommand("robot-sim",
                                 "Run the UR controller simulator (RTDE, dashboard, secondary and real-time script "
                                 "interfaces) on 127.0.0.1 until --duration or Ctrl-C");
  sim->add_option("--host", sim_options->host, "address to bind (keep 127.0.0.1 unless on an isolated network)")
      ->capture_default_str();
  sim->add_option("--port-offset", sim_options->port_offset,
                  "added to every UR port (30004, 29999, 30002, 30003), e.g. for tests or several simulators")
      ->check(CLI::Range(0, 35000))
      ->capture_default_str();
  sim->add_option("--duration", sim_options->duration_s, "seconds to run; 0 = until Ctrl-C")->capture_default_str();
  sim->add_flag("--power-off", sim_options->power_off,
                "start powered off like a booted controller (power on and brake release via the dashboard)");
  sim->add_option("--unlock-delay", sim_options->unlock_delay_s,
                  "seconds after a protective stop before the dashboard accepts the unlock (UR: 5)")
      ->capture_default_str();
  addJsonFlag(*sim, options);
  verbs.emplace_back(sim, [sim_options] { return runSim(*sim_options); });

  auto status_options = std::make_shared<StatusOptions>();
  auto* status = app.add_subcommand("robot-status",
                                    "Read a UR controller's dashboard (robot and safety mode) and RTDE state "
                                    "(joints, TCP pose)");
  status->add_option("--host", status_options->host, "controller IP address")->capture_default_str();
  status->add_option("--port-offset", status_options->port_offset, "as for robot-sim (0 for a real controller)")
      ->check(CLI::Range(0, 35000))
      ->capture_default_str();
  status->add_option("--frequency", status_options->frequency_hz, "RTDE output rate in Hz (125 CB3, up to 500)")
      ->check(CLI::Range(1.0, 500.0))
      ->capture_default_str();
  status->add_option("--timeout", status_options->timeout_s, "seconds to wait for each reply")->capture_default_str();
  addJsonFlag(*status, options);
  verbs.emplace_back(status, [status_options] { return runStatus(*status_options); });
}

}  // namespace mrsns::cli
