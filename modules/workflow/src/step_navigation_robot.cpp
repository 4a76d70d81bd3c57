#include "step_navigation_robot.h"

#include <chrono>
#include <cmath>
#include <limits>
#include <thread>

#include "controller_identity.h"
#include "live_tracking_recording.h"
#include "mrsns/registration/spin_calibration.h"

namespace mrsns::workflow::detail {

namespace {

Eigen::Vector3d vector3(const Json& j, const std::string& what) {
  if (!j.is_array() || j.size() != 3) {
    throw InvalidArgumentError("navigation: " + what + " in the session is not [x, y, z]: re-run registration");
  }
  return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
}

Json number(double v) {
  return std::isfinite(v) ? Json(v) : Json(nullptr);
}

// A simulated tracker never drives a real controller: mrsns-sim's PlusServer only the controller of its own
// room (the serial number it announces), the in-process simulated tracker or a playback only a controller on
// this machine (a simulator), and a robot calibration simulated in-process is no calibration of a real arm.
void refuseSimulationDrivingARealController(const NavigationOptions& options, const Json& calibration) {
  const auto& ro = options.robot;
  const bool local = isLoopbackHost(ro.ur_host);
  if ((options.devices.source == "simulated" || options.devices.source == "playback") && !local) {
    const std::string tracker = options.devices.source == "simulated" ? "simulated" : "a recording played back";
    throw InvalidArgumentError("navigation: the tracker is " + tracker +
                               " and the UR controller at " + ro.ur_host +
                               " is not on this machine: a simulated tracker never drives a real controller; connect "
                               "the session to the tracker (connect-devices source=plus)");
  }
  if (!local && calibration["figures"].contains("simulation_truth")) {
    throw InvalidArgumentError("navigation: the session's robot calibration was simulated in-process, not measured "
                               "on the UR controller at " + ro.ur_host +
                               ": run robot-calibration with source=ur on this robot first");
  }
  if (options.devices.source != "plus") return;
  const std::string identity = trackerIdentity(options.devices.host, options.devices.port, 2.0);
  if (!fromSimulatedRoom(identity)) return;
  const std::string serial = controllerSerial(ro.ur_host, ro.ur_dashboard_port, "navigation");
  if (announcedSerial(identity) != serial) {
    throw InvalidArgumentError("navigation: the tracker is mrsns-sim's simulated one ('" + identity +
                               "') and the UR controller at " + ro.ur_host + " (serial " + serial +
                               ") is not its room's: a simulated tracker never drives another controller");
  }
}

// A UR driven with a PlusServer's tracking: the drill as this session calibrated it (no geometry is assumed).
void configureDrill(const Session& session, const Json& calibration, NavigationRobotOptions& ro) {
  const auto& transforms = calibration["figures"]["transforms"];
  if (!transforms.contains("MarkerToFlange")) {
    throw InvalidArgumentError("navigation: robot=ur needs where the drill's marker sits on the flange "
                               "(MarkerToFlange): the session's robot calibration has none; run robot-calibration "
                               "with source=ur on this robot");
  }
  const auto drill = session.step("drill-calibration");
  if (!drill.is_object() || drill.value("status", "") != "ok" || !drill.contains("figures") ||
      !drill["figures"].contains("transforms") || !drill["figures"]["transforms"].contains("FlangeTipToFlange")) {
    throw InvalidArgumentError("navigation: robot=ur needs the drill's tip (FlangeTipToFlange): run "
                               "drill-calibration on this session first (the drill pivoted about its tip)");
  }
  const Eigen::Isometry3d flange_T_marker(
      matrixFromJson(transforms["MarkerToFlange"], "session.json steps.robot-calibration MarkerToFlange"));
  const Eigen::Isometry3d marker_T_tip(matrixFromJson(drill["figures"]["transforms"]["FlangeTipToFlange"],
                                                      "session.json steps.drill-calibration FlangeTipToFlange"));
  // The drilling direction (the tip frame's z): the drill's own axis, from turning it about its axis.
  const auto spin = session.step("drill-spin-calibration");
  if (!spin.is_object() || spin.value("status", "") != "ok" || !spin.contains("figures") ||
      !spin["figures"].contains("shaft_marker")) {
    throw InvalidArgumentError("navigation: robot=ur needs the drill's axis: run drill-spin-calibration on this "
                               "session first (the drill turned about its axis, its tip in the divot)");
  }
  const Eigen::Vector3d shaft_marker = vector3(spin["figures"]["shaft_marker"], "the drill's axis (shaft_marker)");
  // The axis belongs to this tip and this marker: a drill re-clamped and pivoted again needs its spin again.
  const auto spun_tip = spin["figures"].contains("tip_marker_mm")
                            ? vector3(spin["figures"]["tip_marker_mm"], "the drill spin's tip (tip_marker_mm)")
                            : Eigen::Vector3d(Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()));
  if (!((spun_tip - marker_T_tip.translation()).norm() <= 0.5) ||
      spin["figures"].value("tool", "") != drill["figures"].value("tool", "Flange")) {
    throw InvalidArgumentError("navigation: the drill's axis was calibrated for another tip or marker than "
                               "drill-calibration's: run drill-spin-calibration again after drill-calibration");
  }
  const Eigen::Isometry3d flange_T_tip =
      flange_T_marker * registration::tipFrame(marker_T_tip.translation(), shaft_marker);
  ro.flange_T_marker = flange_T_marker;
  ro.flange_T_tip = flange_T_tip;
  // The tracker reports the marker the robot calibration calibrated.
  const auto params = calibration.value("params", Json::object());
  ro.tool_transform = params.is_object() && params.contains("marker") && params["marker"].is_string()
                          ? params["marker"].get<std::string>()
                          : std::string("FlangeToTracker");
}

// The UR controller's address and where its base stands (the robot calibration: a real arm is not wheeled to
// the patient by the software).
void configureUr(const Session& session, const Params& params, NavigationOptions& options) {
  auto& ro = options.robot;
  ro.ur_host = params.text("ur_host", ro.ur_host);
  ro.ur_rtde_port = params.integer("ur_rtde_port", ro.ur_rtde_port);
  ro.ur_script_port = params.integer("ur_script_port", ro.ur_script_port);
  ro.ur_dashboard_port = params.integer("ur_dashboard_port", ro.ur_dashboard_port);
  ro.ur_silence_s = params.number("ur_silence_s", ro.ur_silence_s);
  const auto calibration = session.step("robot-calibration");
  const bool calibrated = calibration.is_object() && calibration.value("status", "") == "ok" &&
                          calibration.contains("figures") && calibration["figures"].contains("transforms") &&
                          calibration["figures"]["transforms"].contains("RobotBaseToTracker");
  if (!calibrated) {
    throw InvalidArgumentError(
        "navigation: robot=ur needs the session's robot calibration (RobotBaseToTracker): the arm stands where it "
        "is, so run the robot-calibration step on this session first");
  }
  // What the session lacks is said before anything is asked over the network.
  if (options.devices.source == "plus") configureDrill(session, calibration, ro);
  refuseSimulationDrivingARealController(options, calibration);
  ro.tracker_T_robot_base = Eigen::Isometry3d(matrixFromJson(calibration["figures"]["transforms"]["RobotBaseToTracker"],
                                                             "session.json steps.robot-calibration.transforms."
                                                             "RobotBaseToTracker"));
  // Only the simulated tracker needs the loop to draw the drill marker on the arm; a real one sees it.
  ro.simulate_drill_marker = options.devices.source == "simulated";
}

}  // namespace

void configureNavigationRobot(const Session& session, const Params& params, NavigationOptions& options) {
  // The session's plan, placed on the patient by its registration.
  const auto plans = session.plans();
  const bool has_plan = !plans.empty() && session.transform("CTToPatient").has_value();
  options.silence_timeout_s = params.number("silence_timeout_s", options.silence_timeout_s);
  if (!(options.silence_timeout_s > 0.0 && options.silence_timeout_s <= 10.0)) {
    throw InvalidArgumentError("navigation: silence_timeout_s must be in (0, 10] s");
  }
  std::string mode = params.text("robot", "auto");
  if (mode == "auto") mode = has_plan ? "simulated" : "none";
  if (mode != "none" && mode != "simulated" && mode != "ur") {
    throw InvalidArgumentError("navigation: robot '" + mode + "' is not one of auto, none, simulated, ur");
  }
  options.robot.robot = mode;
  if (mode == "none") return;
  if (mode == "ur") configureUr(session, params, options);
  options.robot.advance_speed_mm_s = params.number("advance_speed_mm_s", options.robot.advance_speed_mm_s);
  const int missed = params.integer("max_missed_cycles", static_cast<int>(options.robot.max_missed_cycles));
  if (missed < 0) throw InvalidArgumentError("navigation: max_missed_cycles must be >= 0");
  options.robot.max_missed_cycles = static_cast<std::uint64_t>(missed);
  options.robot.max_cycle_time_s = params.number("max_cycle_time_s", options.robot.max_cycle_time_s);
  if (!(options.robot.max_cycle_time_s > 0.0 && options.robot.max_cycle_time_s <= 1.0)) {
    throw InvalidArgumentError("navigation: max_cycle_time_s must be in (0, 1] s");
  }
  if (!has_plan) return;  // the default path in front of the patient reference
  const int index = params.integer("robot_path", 0);
  if (index < 0 || index >= static_cast<int>(plans.size())) {
    throw InvalidArgumentError("navigation: robot_path " + std::to_string(index) + " is not in 0.." +
                               std::to_string(plans.size() - 1) + " (the session's planned screws)");
  }
  const auto& path = plans[static_cast<std::size_t>(index)];
  options.robot.plan.name = path.name;
  options.robot.plan.entry = path.entry;
  options.robot.plan.target = path.target;
  Eigen::Matrix4d patient_T_ct;
  if (findRecordedTransform(session, "CTToPatient", patient_T_ct)) options.robot.patient_T_plan.matrix() = patient_T_ct;
}

void waitForArmAtRest(const NavigationLoop& loop) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(1);
  while (std::chrono::steady_clock::now() < end) {
    const auto s = loop.status();
    if (!s.robot_stopped || !std::isnan(s.time_to_stop_s)) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

Json navigationRobotFigures(const NavigationOptions& options, const NavigationStatus& s,
                            const std::vector<NavigationRobotTransition>& transitions) {
  Json log = Json::array();
  for (const auto& t : transitions) {
    log.push_back({{"cycle", t.cycle},
                   {"time_s", t.time_s},
                   {"from", t.from},
                   {"to", t.to},
                   {"reason", t.reason},
                   {"command", t.command},
                   {"detail", t.detail},
                   {"tracking", t.tracking}});
  }
  return {{"mode", s.robot},
          {"plan", options.robot.plan.name},
          {"docked", s.robot_docked},
          {"supervisor_state", s.supervisor_state},
          {"supervisor_stop", s.supervisor_stop},
          {"guidance_phase", s.guidance_phase},
          {"stops", s.robot_stops},
          {"stop_latency_cycles", s.stop_latency_cycles},
          {"stop_latency_ms", number(s.stop_latency_ms)},
          {"time_to_stop_s", number(s.time_to_stop_s)},
          {"stop_time_limit_s", s.stop_time_limit_s},
          {"arm_speed_end_rad_s", s.arm_speed_rad_s},
          {"depth_mm", s.depth_mm},
          {"control_cycles", s.robot_cycles},
          {"missed_cycles", s.robot_missed_cycles},
          {"motion_commands", s.motion_commands},
          {"motion_commands_after_stop", s.motion_commands_after_stop},
          {"transitions", log}};
}

}  // namespace mrsns::workflow::detail
