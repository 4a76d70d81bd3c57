// Robot calibration acquired from the devices, as a lab does it with a tracked
// marker on the flange: the workstation drives the UR (servoj, streamed at the
// controller's rate, at a gentle joint speed) through stations whose flange
// rotations span three axes, waits for the arm to rest, and pairs the
// controller's flange pose with the tracker's marker pose averaged over the
// rest; AX = YB gives MarkerToFlange and RobotBaseToTracker, and stations kept
// out of the fit validate it. The tracking is recorded into the session and the
// station pairs written as a pose CSV, so `mrsns-cli robot-calibrate --poses`
// gives the same result offline. A tracker that is mrsns-sim drives only the
// UR controller of its own room (the serial number it announces).
#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <cmath>
#include <exception>
#include <filesystem>
#include <sstream>
#include <thread>

#include "controller_identity.h"
#include "live_tracking_recording.h"
#include "mrsns/core/error.h"
#include "mrsns/core/format.h"
#include "mrsns/core/frame_poses.h"
#include "mrsns/core/minimum_jerk.h"
#include "mrsns/core/rotation_average.h"
#include "mrsns/core/transform_repository.h"
#include "mrsns/core/units.h"
#include "mrsns/io/pose_csv.h"
#include "mrsns/robot/dashboard_client.h"
#include "mrsns/robot/robot_tracker_calibration.h"
#include "mrsns/robot/ur_rtde_arm.h"
#include "mrsns/tracking/igtl_source.h"
#include "step_internal.h"

namespace mrsns::workflow::detail {

namespace {

struct StationPlan {
  int stations = 10;            ///< used in the fit
  int validation_stations = 2;  ///< kept out of it
  double tilt_deg = 25.0;
  double spread_mm = 60.0;
  double speed_deg_s = 30.0;
  double settle_s = 0.4;
  double sample_s = 1.0;
  std::uint64_t seed = 1;
};

/// Frames received while the arm rested at one station.
struct StationWindow {
  std::size_t first = 0, last = 0;
  bool seen = false;
  Eigen::Isometry3d base_T_flange = Eigen::Isometry3d::Identity();
  robot::Joints q = robot::Joints::Zero();
  std::string skipped;  ///< why the station was not used ("" when it was)
};

std::uint16_t tcpPort(int value, const char* what) {
  if (value < 1 || value > 65535) {
    throw InvalidArgumentError(std::string("robot-calibration: the UR ") + what + " port " + std::to_string(value) +
                               " is not in 1..65535");
  }
  return static_cast<std::uint16_t>(value);
}

/// Stops the arm and repeats the stop every control period until it is at rest (a controller may ignore one
/// command), for at most `limit_s`.
void stopUntilAtRest(robot::RobotArm& arm, double limit_s = 3.0) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(limit_s);
  const auto period = std::chrono::duration<double>(std::max(arm.controlPeriodS(), 0.002));
  do {
    arm.stopJ(2.0);
    std::this_thread::sleep_for(period);
  } while (arm.state().qd.cwiseAbs().maxCoeff() > 1e-3 && std::chrono::steady_clock::now() < until);
}

}  // namespace

StepResult runLiveRobotCalibration(Session& session, const Json& params, const StepContext& context) {
  const Params p("robot-calibration",
                 params, {"source", "host", "port", "ur_host", "ur_rtde_port", "ur_script_port", "ur_dashboard_port",
                          "marker", "stations", "validation_stations", "tilt_deg", "spread_mm", "speed_deg_s",
                          "settle_s", "sample_s", "seed", "connect_timeout_s", "unlock_timeout_s"});
  StationPlan plan;
  plan.stations = p.integer("stations", plan.stations);
  plan.validation_stations = p.integer("validation_stations", plan.validation_stations);
  plan.tilt_deg = p.number("tilt_deg", plan.tilt_deg);
  plan.spread_mm = p.number("spread_mm", plan.spread_mm);
  plan.speed_deg_s = p.number("speed_deg_s", plan.speed_deg_s);
  plan.settle_s = p.number("settle_s", plan.settle_s);
  plan.sample_s = p.number("sample_s", plan.sample_s);
  plan.seed = static_cast<std::uint64_t>(p.integer("seed", 1));
  if (plan.stations < 6 || plan.validation_stations < 0 || !(plan.tilt_deg > 0.0 && plan.tilt_deg <= 45.0) ||
      !(plan.spread_mm >= 0.0 && plan.spread_mm <= 200.0) || !(plan.speed_deg_s > 0.0 && plan.speed_deg_s <= 60.0) ||
      !(plan.settle_s >= 0.0) || !(plan.sample_s >= 0.3)) {
    throw InvalidArgumentError(
        "robot-calibration: stations must be >= 6 (AX = YB has 12 unknowns), validation_stations >= 0, tilt_deg in "
        "(0, 45], spread_mm in [0, 200], speed_deg_s in (0, 60] (a calibration moves gently), settle_s >= 0, "
        "sample_s >= 0.3");
  }
  const double unlock_timeout_s = p.number("unlock_timeout_s", 300.0);
  if (!(unlock_timeout_s > 0.0 && unlock_timeout_s <= 1800.0)) {
    throw InvalidArgumentError("robot-calibration: unlock_timeout_s must be in (0, 1800] s");
  }
  const std::string marker = p.text("marker", "FlangeToTracker");
  LiveTrackingOptions live;
  sessionPlusServer(session, p, live.host, live.port);
  live.connect_timeout_s = p.number("connect_timeout_s", live.connect_timeout_s);
  robot::UrRtdeArmOptions ur;
  ur.host = p.text("ur_host", live.host);
  ur.rtde_port = tcpPort(p.integer("ur_rtde_port", 30004), "RTDE");
  ur.script_port = tcpPort(p.integer("ur_script_port", 30003), "real-time script");
  ur.dashboard_port = tcpPort(p.integer("ur_dashboard_port", 29999), "dashboard");
  ur.frequency_hz = 125.0;
  ur.connect_timeout_s = 5.0;
  ur.stale_after_periods = 25.0;  // 0.2 s without a package: the arm is treated as gone

  // Who is who, before anything moves: a simulated tracker never drives a controller outside its room.
  context.report(0.02, "asking the tracker at " + live.host + ":" + std::to_string(live.port) + " who it is");
  const std::string identity = trackerIdentity(live.host, live.port, std::min(5.0, live.connect_timeout_s));
  const bool simulated = fromSimulatedRoom(identity);
  const std::string serial = controllerSerial(ur.host, ur.dashboard_port, "robot-calibration");
  if (simulated && announcedSerial(identity) != serial) {
    throw InvalidArgumentError("robot-calibration: the tracker is mrsns-sim's simulated one ('" + identity +
                               "') and the UR controller at " + ur.host + " (serial " + serial +
                               ") is not its room's: a simulated tracker never drives another controller");
  }
  checkCancel(context);

  auto arm = std::make_shared<robot::UrRtdeArm>(ur);
  const robot::Ur5Kinematics kinematics;
  auto start = arm->state();
  for (int i = 0; i < 60 && !start.connected; ++i) {  // the first RTDE package may take a moment
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    start = arm->state();
  }
  if (!start.connected) {
    throw NetworkError("robot-calibration: the UR controller at " + ur.host + ":" + std::to_string(ur.rtde_port) +
                       " sends no state over RTDE within 3 s");
  }
  robot::CalibrationPoseOptions pose_options;
  pose_options.count = plan.stations + plan.validation_stations;
  pose_options.tilt_rad = plan.tilt_deg * kDeg;
  pose_options.position_spread_mm = plan.spread_mm;
  pose_options.seed = plan.seed;
  const auto stations = robot::generateCalibrationPoses(kinematics, start.q, pose_options);

  context.report(0.05, "the robot moves through " + std::to_string(stations.q.size()) +
                          " stations around where it stands (flange tilts of " + formatFixed(plan.tilt_deg, 0) +
                          " deg, " + formatFixed(plan.spread_mm, 0) + " mm): keep its workspace clear");
  const std::string recording = freeSessionName(session, "robot-calibration", "RobotCalibration", ".mhd");
  live.recording = session.resolve(recording);
  // The stations take well under 10 minutes; a protective stop adds the operator's time to unlock it.
  live.max_duration_s = 600.0 + 2.0 * unlock_timeout_s;
  std::vector<StationWindow> windows(stations.q.size() + 1);  // the last: back at the start pose
  std::atomic<int> holding{-1};
  std::atomic<bool> done{false};
  std::atomic<int> reached{0};
  std::exception_ptr robot_error;
  std::atomic<bool> abort{false};
  const double period = arm->controlPeriodS();
  // A protective stop on the way to a station (the controller's joint limits, a collision): the station is
  // skipped and the step waits for the operator to inspect the arm and unlock it (pendant or dashboard; the
  // workstation never unlocks a protective stop itself), then goes on from where the arm stands.
  std::atomic<int> stopped_at{-1};
  // The arm's own thread: move, settle, hold still while the tracker samples, next station; then home.
  std::thread mover([&] {
    try {
      robot::Joints from = start.q;
      for (std::size_t k = 0; k <= stations.q.size() && !abort; ++k) {
        const bool home = k == stations.q.size();
        const robot::Joints to = home ? start.q : stations.q[k];
        const double travel = std::max(1.0, (to - from).cwiseAbs().maxCoeff() / (plan.speed_deg_s * kDeg) * 1.875);
        const auto t0 = std::chrono::steady_clock::now();
        auto next = t0;
        const double total = travel + plan.settle_s + (home ? 0.0 : plan.sample_s);
        bool protective_stop = false;
        while (!abort) {
          const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
          if (t > total) break;
          if (!arm->servoJ(from + (to - from) * minimumJerk(t / travel))) {
            if (!arm->state().connected) throw NetworkError("the connection to the UR controller was lost");
            const auto safety = arm->state().safety;
            if (safety != robot::SafetyMode::ProtectiveStop) {
              throw ComputationError(std::string("the UR controller refused the motion (safety mode ") +
                                     robot::toString(safety) + ")");
            }
            protective_stop = true;
            break;
          }
          if (!home) holding = t >= travel + plan.settle_s ? static_cast<int>(k) : -1;
          next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(period));
          std::this_thread::sleep_until(next);
        }
        holding = -1;
        if (protective_stop) {
          if (!home) windows[k].skipped = "protective stop on the way to it (a joint limit of the controller's "
                                          "safety configuration, or a collision)";
          stopped_at = static_cast<int>(k);
          if (!home) reached = static_cast<int>(k) + 1;
          const auto waited_from = std::chrono::steady_clock::now();
          while (!abort) {
            const auto state = arm->state();
            if (!state.connected) throw NetworkError("the connection to the UR controller was lost");
            if (state.safety == robot::SafetyMode::Normal || state.safety == robot::SafetyMode::Reduced) break;
            if (std::chrono::steady_clock::now() - waited_from > std::chrono::duration<double>(unlock_timeout_s)) {
              throw ComputationError("protective stop on the way to " +
                                     (home ? std::string("the start pose") : "station " + std::to_string(k + 1)) +
                                     " not unlocked within " + formatFixed(unlock_timeout_s, 0) + " s");
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(50));
          }
          stopped_at = -1;
          from = arm->state().q;
          if (home) --k;  // home is where the arm must end: try again from where it stands
          continue;
        }
        if (!home) {
          windows[k].base_T_flange = arm->state().base_T_flange;
          windows[k].q = arm->state().q;
          if ((windows[k].q - to).cwiseAbs().maxCoeff() > 0.5 * kDeg) windows[k].skipped = "the arm did not reach it";
        }
        reached = static_cast<int>(k) + 1;
        // The next move starts where the arm is, not where it was sent: after a station it could not reach, a
        // path from the unreached target would open with a jump.
        from = arm->state().q;
      }
      stopUntilAtRest(*arm);
    } catch (...) {
      robot_error = std::current_exception();
      stopUntilAtRest(*arm);
    }
    done = true;
  });
  const auto monitor = [&](const std::vector<TrackedFrame>& so_far, std::string& message) {
    const int k = holding.load();
    if (k >= 0) {
      auto& w = windows[static_cast<std::size_t>(k)];
      if (!w.seen) w.first = so_far.size();
      w.seen = true;
      w.last = so_far.size();
    }
    const auto n = static_cast<int>(stations.q.size());
    if (const int stop = stopped_at.load(); stop >= 0) {
      message = stop < n ? "protective stop on the way to station " + std::to_string(stop + 1) +
                               ": inspect the arm's workspace, then unlock the protective stop on the teach pendant; "
                               "the calibration goes on without that station"
                         : std::string("protective stop on the way back to the start pose: inspect the arm's "
                                       "workspace, then unlock the protective stop on the teach pendant");
      return false;
    }
    message = reached.load() > n ? std::string("returning the robot to where it started")
                                 : "moving the robot through its calibration stations: " +
                                       std::to_string(reached.load()) + " of " + std::to_string(n) + " done";
    return done.load();
  };
  LiveTrackingRecording r;
  try {
    r = recordLiveTracking(live, monitor, context);
  } catch (...) {
    abort = true;
    mover.join();
    throw;
  }
  const bool ran_out = !done;
  if (ran_out) abort = true;
  mover.join();
  if (robot_error) std::rethrow_exception(robot_error);
  if (ran_out) {
    // The recording's time ran out (a long wait for an unlock): the stations not reached say so.
    for (std::size_t k = static_cast<std::size_t>(std::max(0, reached.load())); k < stations.q.size(); ++k) {
      if (windows[k].skipped.empty()) windows[k].skipped = "not reached: the acquisition's time ran out";
    }
    stopUntilAtRest(*arm);
  }

  // The pairs: the controller's flange pose and the marker's mean pose over the rest.
  std::vector<Eigen::Isometry3d> fit_flange, fit_marker, val_flange, val_marker, csv_fit;
  Json per_station = Json::array();
  for (std::size_t k = 0; k < stations.q.size(); ++k) {
    auto& w = windows[k];
    std::vector<Eigen::Isometry3d> seen;
    if (w.skipped.empty() && w.seen && w.last > w.first) {
      const std::vector<TrackedFrame> slice(r.frames.begin() + static_cast<std::ptrdiff_t>(w.first),
                                            r.frames.begin() + static_cast<std::ptrdiff_t>(w.last));
      try {
        for (const auto& pose : extractFramePoses(slice, marker).poses) seen.push_back(pose.to_T_from);
      } catch (const FrameError&) {
      }
    }
    if (w.skipped.empty() && seen.size() < 5) w.skipped = "the marker was not seen while the arm rested";
    Json entry = {{"station", k + 1}, {"validation", static_cast<int>(k) >= plan.stations}};
    if (!w.skipped.empty()) {
      entry["skipped"] = w.skipped;
      per_station.push_back(entry);
      continue;
    }
    const auto mean = averagePoses(seen);
    entry["samples"] = seen.size();
    entry["marker_scatter_mm"] = mean.translation_rms;
    per_station.push_back(entry);
    if (static_cast<int>(k) < plan.stations) {
      fit_flange.push_back(w.base_T_flange);
      fit_marker.push_back(mean.mean);
    } else {
      val_flange.push_back(w.base_T_flange);
      val_marker.push_back(mean.mean);
    }
  }
  StepResult result;
  const std::string csv = "robot-calibration/" + std::filesystem::path(recording).stem().string() + "_stations.csv";
  for (std::size_t i = 0; i < fit_flange.size(); ++i) {
    csv_fit.push_back(fit_flange[i]);
    csv_fit.push_back(fit_marker[i]);
  }
  io::writePoseCsv(session.resolve(csv), csv_fit);
  result.outputs = {recording, csv};
  result.figures["simulated"] = simulated;
  result.figures["source"] = "ur";
  result.figures["recorded"] = {{"file", recording},
                                {"frames", r.frames.size()},
                                {"seconds", r.seconds},
                                {"device_identity", r.device_identity},
                                {"controller_serial", serial},
                                {"controller_version", arm->controllerVersion()},
                                {"stations_file", csv}};
  result.figures["stations"] = per_station;
  result.figures["offline_command"] = "mrsns-cli robot-calibrate --poses " + session.resolve(csv).string();
  const std::string kept = " (the recording is kept: " + recording + ")";
  if (static_cast<int>(fit_flange.size()) < 6) {
    result.ok = false;
    result.summary = "robot-calibration: " + std::to_string(fit_flange.size()) +
                     " usable stations, 6 needed: see figures.stations for why the others were skipped" + kept;
    return result;
  }
  robot::RobotTrackerCalibrationResult c;
  try {
    c = robot::calibrateRobotTracker(fit_flange, fit_marker);
  } catch (const Error& e) {
    result.ok = false;
    result.summary = std::string(e.what()) + kept;
    return result;
  }
  // Stations not in the fit: where the calibration puts the marker against where the tracker saw it.
  std::vector<double> validation;
  for (std::size_t i = 0; i < val_flange.size(); ++i) {
    const Eigen::Isometry3d predicted = c.base_T_tracker.inverse() * val_flange[i] * c.flange_T_marker;
    validation.push_back((predicted.translation() - val_marker[i].translation()).norm());
  }
  const Eigen::Isometry3d tracker_T_base = c.base_T_tracker.inverse();
  result.ok = true;
  result.figures["poses"] = c.poses;
  result.figures["residual_rms_mm"] = c.translation_rms_mm;
  result.figures["residual_rms_deg"] = c.rotation_rms_rad / kDeg;
  result.figures["axis_spread_deg"] = c.axis_spread_rad / kDeg;
  result.figures["validation_error_mm"] = statsJson(validation);
  result.figures["transforms"] = {{"RobotBaseToTracker", matrixJson(tracker_T_base.matrix())},
                                  {"MarkerToFlange", matrixJson(c.flange_T_marker.matrix())}};
  std::ostringstream s;
  s << "RobotBaseToTracker and MarkerToFlange from " << c.poses << " stations driven on the UR (serial " << serial
    << "): residual " << formatFixed(c.translation_rms_mm, 2) << " mm / " << formatFixed(c.rotation_rms_rad / kDeg, 2)
    << " deg";
  if (!validation.empty()) {
    s << ", " << validation.size() << " validation stations " << formatFixed(result.figures["validation_error_mm"]["mean"].get<double>(), 2)
      << " mm";
  }
  int skipped = 0;
  for (const auto& e : per_station) skipped += e.contains("skipped") ? 1 : 0;
  if (skipped > 0) s << "; " << skipped << " stations skipped (figures.stations says why)";
  result.summary = s.str();
  return result;
}

}  // namespace mrsns::workflow::detail
