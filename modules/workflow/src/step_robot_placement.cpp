// robot-placement: the robot places every planned screw in turn through the navigation loop, on the
// session's devices (a PlusServer's tracking and a UR controller, or the in-process simulator): for each path
// the arm approaches the stand-off on the planned axis, aligns, advances to the target under the safety
// supervisor (tracking, the controller, the live soft tissue) and retracts. The step records what the
// workstation knows (when each phase began, how deep it commanded the drill, every stop and how fast the arm
// came to rest); where the drill truly went is judged outside (mrsns-sim score, from the room's truth).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <thread>

#include "device_params.h"
#include "mrsns/workflow/navigation.h"
#include "step_internal.h"
#include "step_navigation_robot.h"
#include "step_navigation_soft_tissue.h"

namespace mrsns::workflow::detail {

namespace {

double utcNow() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

Json point(const Eigen::Vector3d& p) {
  return Json::array({p.x(), p.y(), p.z()});
}

Json finite(double v) {
  return std::isfinite(v) ? Json(v) : Json(nullptr);
}

/// The planned paths to place: every one (default or "all"), or `paths` = [indices] in that order.
std::vector<int> chosenPaths(const Json& params, std::size_t planned) {
  std::vector<int> chosen;
  if (!params.is_object() || !params.contains("paths")) {
    for (std::size_t i = 0; i < planned; ++i) chosen.push_back(static_cast<int>(i));
    return chosen;
  }
  // From the command line a list arrives as text: "0,2" or "[0, 2]"; "all" is every path.
  Json j = params["paths"];
  if (j.is_string()) {
    const std::string text = j.get<std::string>();
    if (text == "all") return chosenPaths(Json::object(), planned);
    j = Json::parse(text.empty() || text.front() == '[' ? text : "[" + text + "]", nullptr, false);
  }
  if (!j.is_array() || j.empty()) {
    throw InvalidArgumentError("robot-placement: paths must be a non-empty list of planned-screw indices, e.g. [0, 2]");
  }
  for (const auto& v : j) {
    if (!v.is_number_integer() || v.get<int>() < 0 || v.get<std::size_t>() >= planned) {
      throw InvalidArgumentError("robot-placement: paths holds " + v.dump() + ", not an index in 0.." +
                                 std::to_string(planned - 1) + " (the session's planned screws)");
    }
    chosen.push_back(v.get<int>());
  }
  return chosen;
}

struct PathRun {
  Json record;
  bool placed = false;
  bool stopped = false;
};

/// One path: the loop started, watched until the path is finished and the drill retracted, the supervisor
/// stopped the arm (then until it rests), or the time is up.
PathRun placeOne(Session& session, const Json& path_params, const std::initializer_list<const char*>& keys,
                 double timeout_s, bool record, const StepContext& context, double from, double to) {
  const Params p("robot-placement", path_params, keys);
  NavigationOptions options;
  options.devices = deviceOptions(p);
  if (options.devices.source != "simulated") options.required_transforms.clear();
  configureNavigationRobot(session, p, options);
  configureNavigationSoftTissue(session, p, options);
  if (options.robot.robot == "none") {
    throw InvalidArgumentError("robot-placement: robot=none places nothing: choose simulated or ur");
  }
  std::string tracking_file;
  if (record) {
    tracking_file = freeSessionName(session, "placement", "tracking", ".mhd");
    options.recording = session.resolve(tracking_file);
  }
  const auto& plan = options.robot.plan;
  PathRun run;
  Json& r = run.record;
  r = {{"name", plan.name},
       {"entry_ct", point(plan.entry)},
       {"target_ct", point(plan.target)},
       {"planned_depth_mm", (plan.target - plan.entry).norm()}};
  if (!tracking_file.empty()) r["tracking"] = tracking_file;

  NavigationLoop loop(options);
  const double utc0 = utcNow();
  const auto start = std::chrono::steady_clock::now();
  loop.start();
  double depth_reached = 0.0;
  std::string outcome = "timed out";
  bool finished = false;
  std::optional<std::chrono::steady_clock::time_point> finished_at;
  try {
    while (true) {
      const auto st = loop.status();
      depth_reached = std::max(depth_reached, st.depth_mm);
      const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      if (st.robot_stopped) {
        outcome = "stopped";
        break;
      }
      if (!finished) {
        const auto log = loop.robotTransitions();
        finished = std::any_of(log.begin(), log.end(),
                               [](const NavigationRobotTransition& x) { return x.detail == "path finished"; });
        if (finished) finished_at = std::chrono::steady_clock::now();
      }
      // Placed once the drill is back at the stand-off (the retraction's end), or 30 s after the path's end.
      if (finished &&
          (st.guidance_phase == "Done" || std::chrono::steady_clock::now() - *finished_at > std::chrono::seconds(30))) {
        outcome = "placed";
        break;
      }
      if (t > timeout_s) break;
      context.report(from + (to - from) * std::min(1.0, t / timeout_s),
                     "placing " + plan.name + " (" + st.guidance_phase + ", depth " +
                         std::to_string(static_cast<int>(std::lround(st.depth_mm))) + " mm)");
      checkCancel(context);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  } catch (...) {
    loop.stop();
    throw;
  }
  if (outcome == "stopped") waitForArmAtRest(loop);
  loop.stop();
  const double utc_end = utcNow();
  const auto st = loop.status();
  const auto transitions = loop.robotTransitions();
  run.placed = outcome == "placed";
  run.stopped = outcome == "stopped";
  r["outcome"] = outcome;
  r["utc_start"] = utc0;
  r["utc_end"] = utc_end;
  r["depth_reached_mm"] = depth_reached;
  // The phases on the wall clock (the loop's clock plus its start): what the scorer lines the truth up with.
  for (const auto& x : transitions) {
    if (x.detail == "aligned" && !r.contains("utc_aligned")) r["utc_aligned"] = utc0 + x.time_s;
    if (x.detail == "path finished" && !r.contains("utc_path_finished")) r["utc_path_finished"] = utc0 + x.time_s;
    if (x.to == "Stopped" && !r.contains("utc_stop")) r["utc_stop"] = utc0 + x.time_s;
  }
  if (run.stopped) {
    r["stop_reason"] = st.supervisor_stop.empty() ? st.stop_reason : st.supervisor_stop;
    r["stop_latency_ms"] = finite(st.stop_latency_ms);
    r["time_to_stop_s"] = finite(st.time_to_stop_s);
  }
  r["supervisor"] = navigationRobotFigures(options, st, transitions);
  r["device_identity"] = loop.deviceIdentity();
  r["soft_tissue"] = st.soft_tissue;
  return run;
}

}  // namespace

StepResult runRobotPlacement(Session& session, const Json& params, const StepContext& context) {
  static const std::initializer_list<const char*> kKeys = {
      MRSNS_DEVICE_KEYS, MRSNS_NAVIGATION_ROBOT_KEYS, MRSNS_NAVIGATION_SOFT_TISSUE_KEYS, "paths", "path_timeout_s",
      "record"};
  const Params p("robot-placement", params, kKeys);
  if (p.has("robot_path")) {
    throw InvalidArgumentError("robot-placement: give paths=[i, ...] (robot_path is the navigation step's)");
  }
  if (!session.transform("CTToPatient").has_value()) {
    throw InvalidArgumentError("robot-placement: the plan is not on the patient yet: run registration first");
  }
  const auto plans = session.plans();
  if (plans.empty()) {
    throw InvalidArgumentError(
        "robot-placement: the session has no planned screw: plan them first (plan-screw, "
        "import-plan)");
  }
  const double timeout_s = p.number("path_timeout_s", 120.0);
  if (!(timeout_s >= 5.0 && timeout_s <= 3600.0)) {
    throw InvalidArgumentError("robot-placement: path_timeout_s must be in [5, 3600] s");
  }
  const bool record = p.boolean("record", true);
  const auto chosen = chosenPaths(params, plans.size());

  Json paths = Json::array();
  int placed = 0;
  std::string stopped_at, stop_reason, identity;
  std::vector<double> depth_short;
  for (std::size_t k = 0; k < chosen.size(); ++k) {
    checkCancel(context);
    Json path_params = params.is_object() ? params : Json::object();
    path_params.erase("paths");
    path_params["robot_path"] = chosen[k];
    const double from = static_cast<double>(k) / static_cast<double>(chosen.size());
    const double to = static_cast<double>(k + 1) / static_cast<double>(chosen.size());
    PathRun run = placeOne(session, path_params, kKeys, timeout_s, record, context, from, to);
    run.record["index"] = chosen[k];
    identity = run.record.value("device_identity", "");
    if (run.placed) {
      ++placed;
      depth_short.push_back(run.record["planned_depth_mm"].get<double>() -
                            run.record["depth_reached_mm"].get<double>());
    }
    paths.push_back(run.record);
    if (!run.placed) {
      // After a stop (or a path not finished) the surgeon looks before the arm moves again: the rest waits.
      stopped_at = run.record["name"].get<std::string>();
      stop_reason = run.stopped ? run.record.value("stop_reason", std::string("stopped")) : std::string("timed out");
      session.log("warn", "robot-placement: " + stopped_at + " " + run.record["outcome"].get<std::string>() +
                              (run.stopped ? " (" + stop_reason + ")" : std::string()) +
                              "; the remaining paths were not started");
      break;
    }
  }
  StepResult result;
  result.ok = placed == static_cast<int>(chosen.size());
  for (const auto& r : paths) {
    if (r.contains("tracking")) {
      const std::string t = r["tracking"].get<std::string>();
      result.outputs.push_back(t);
      result.outputs.push_back(t.substr(0, t.size() - 4) + ".raw");
    }
  }
  const std::string source = deviceOptions(p).source;
  result.figures = {{"paths", paths},
                    {"planned", chosen.size()},
                    {"placed", placed},
                    {"device_identity", identity},
                    // Provenance: `mrsns-sim score` judges only a placement done in its room.
                    {"simulated", source == "simulated" || identity.rfind("mrsns-sim", 0) == 0},
                    {"definition",
                     "what the workstation commanded and saw: each path's phases, the drill depth commanded past "
                     "the entry, the supervisor's stops; where the drill truly went is measured outside (a "
                     "phantom's CT, or mrsns-sim score in the simulated room)"}};
  if (!depth_short.empty()) result.figures["commanded_depth_short_of_plan_mm"] = statsJson(depth_short);
  std::ostringstream s;
  s << placed << " of " << chosen.size() << " planned screws placed";
  if (!stopped_at.empty()) s << "; stopped at " << stopped_at << " (" << stop_reason << "), the rest not started";
  result.summary = s.str();
  return result;
}

}  // namespace mrsns::workflow::detail
