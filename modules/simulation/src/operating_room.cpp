// The simulated operating room's threads: the tracker at its rate (truth ->
// measurement noise -> PlusServer), the ultrasound video at its rate (world
// at the probe plane, lagged -> B-mode -> IMAGE), the UR controller stepping
// on its own, faults on schedule; or the replay of a recording.
#include "mrsns/simulation/operating_room.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <random>
#include <thread>

#include "mrsns/core/error.h"
#include "mrsns/core/minimum_jerk.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/units.h"
#include "mrsns/core/wall_clock.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/robot/ur_simulator.h"
#include "mrsns/simulation/bmode_renderer.h"
#include "mrsns/simulation/hmd_emulator.h"
#include "mrsns/simulation/plus_server.h"
#include "mrsns/simulation/world.h"
#include "board_toucher.h"
#include "camera_operator.h"
#include "cube_operator.h"
#include "mrsns/hmd/board_renderer.h"
#include "mrsns/hmd/checkerboard_dataset.h"

namespace mrsns::simulation {

namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;
// The UR5's reach from its base axis (Universal Robots: 850 mm).
constexpr double kUr5ReachMm = 850.0;

// A pose as [x, y, z, qw, qx, qy, qz]: compact for the truth file.
std::array<double, 7> compact(const Eigen::Isometry3d& p) {
  const Eigen::Quaterniond q(p.linear());
  return {p.translation().x(), p.translation().y(), p.translation().z(), q.w(), q.x(), q.y(), q.z()};
}

struct ToolSampleTruth {
  std::array<double, 7> pose;
  int visibility;
};

struct TrackerTruth {
  double t;
  double utc;
  std::vector<ToolSampleTruth> tools;
};

struct FrameTruth {
  double utc;
  double content_t;  // world time the frame shows (t - lag)
  std::array<double, 7> tracker_T_image;
  bool frozen;
};

// What the headset displayed at an instant: per model, its pose in the headset's drifting world frame.
struct HmdTruth {
  double utc;
  std::vector<std::string> names;
  std::vector<std::array<double, 7>> world_T_model;
  std::vector<std::array<double, 7>> tracker_T_model;  // where the wearer sees it (tracked headsets only)
  std::vector<bool> visible;
  std::optional<std::array<double, 7>> tracker_T_ct;  // where the patient's CT truly is at that instant
};

struct EventTruth {
  double t;
  double utc;
  std::string what;
};

}  // namespace

struct OperatingRoom::Impl {
  Scenario scenario;
  std::unique_ptr<World> world;
  std::unique_ptr<PlusServerEmulator> plus;
  std::unique_ptr<robot::UrSimulator> ur;
  std::unique_ptr<HmdEmulator> hmd;
  std::unique_ptr<CubeOperator> cube_operator;  ///< the HMD calibration's operator (a tracked headset only)
  /// The wearer during the checkerboard hand-eye calibration (a tracked headset with a camera only).
  std::unique_ptr<CameraOperator> camera_operator;
  /// The operator digitising the board's corners with the stylus, as the headset's prompts ask.
  std::unique_ptr<BoardToucher> board_toucher;
  /// Renders and sends a photo off the tracker's thread (one at a time).
  std::thread photo_thread;
  /// The headset's world frame in the tracker's, anchored at the start (a tracked headset only).
  std::optional<Eigen::Isometry3d> tracker_T_hmd_world;
  std::optional<TrackedSequence> replay;

  std::atomic<bool> running{false};
  std::atomic<bool> finished{false};
  Clock::time_point t0;
  double utc0 = 0.0;
  std::thread tracker_thread, video_thread, replay_thread;

  mutable std::mutex truth_mutex;
  std::vector<std::string> tool_names;
  std::vector<TrackerTruth> tracker_truth;
  std::vector<FrameTruth> frame_truth;
  std::vector<HmdTruth> hmd_truth;
  std::vector<CubeOperator::MatchTruth> cube_matches;
  std::vector<CameraOperator::ViewTruth> camera_views;
  std::vector<BoardToucher::TouchTruth> board_touches;
  std::vector<EventTruth> events;
  OperatingRoomStats stats;

  [[nodiscard]] double elapsed() const { return std::chrono::duration<double>(Clock::now() - t0).count(); }

  void event(double t, const std::string& what, bool fault = true) {
    std::lock_guard lock(truth_mutex);
    events.push_back({t, utc0 + t, what});
    if (fault) ++stats.faults_fired;
  }

  // Sleeps until t0 + t_s, or returns false when stopping.
  bool sleepUntil(double t_s) {
    const auto deadline = t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(t_s));
    while (running.load()) {
      const auto now = Clock::now();
      if (now >= deadline) return true;
      std::this_thread::sleep_for(std::min<Clock::duration>(deadline - now, std::chrono::milliseconds(20)));
    }
    return false;
  }

  void trackerLoop() {
    std::mt19937_64 rng(scenario.seed * 31ULL + 5ULL);
    std::normal_distribution<double> normal(0.0, 1.0);
    const double sigma_p = scenario.tracker.noise.position_rms_mm / std::sqrt(3.0);
    const double sigma_r = scenario.tracker.noise.orientation_rms_deg * kDeg / std::sqrt(3.0);
    const double period = 1.0 / scenario.tracker.rate_hz;
    std::vector<bool> started(scenario.faults.size(), false), ended(scenario.faults.size(), false);
    for (std::uint64_t tick = 0; running.load(); ++tick) {
      const double t_tick = tick * period;
      if (!sleepUntil(t_tick)) break;
      // A tracker samples at regular instants and stamps each sample with its own clock; when this process is
      // late (a loaded machine) the sample is still taken and stamped at its instant, and only published late.
      const double t = t_tick;
      if (elapsed() > t_tick + period) {
        std::lock_guard lock(truth_mutex);
        ++stats.tracker_overruns;
      }
      if (scenario.duration_s > 0.0 && t >= scenario.duration_s) {
        finished = true;
        break;
      }
      fireFaults(t, started, ended);
      if (hmd && tick % 6 == 0) {
        operateHeadset(t);
        recordHmd(t);
      }
      std::optional<Eigen::Isometry3d> base_T_flange;
      if (ur) {
        guideArm(t);
        base_T_flange = ur->armState().base_T_flange;
      }
      const auto truth = world->tools(t, base_T_flange, heldTools(t, base_T_flange));
      std::vector<MeasuredTool> measured;
      measured.reserve(truth.size());
      TrackerTruth record{t, utc0 + t, {}};
      std::uint64_t invalid = 0;
      for (const auto& tool : truth) {
        // Datasheet noise, independent per sample: position per axis, orientation as a small rotation.
        Eigen::Isometry3d noisy = tool.tracker_T_tool;
        noisy.translation() += sigma_p * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
        noisy.linear() = noisy.linear() * so3Exp(sigma_r * Eigen::Vector3d(normal(rng), normal(rng), normal(rng)));
        const bool valid = tool.visibility == Visibility::Visible;
        if (!valid) ++invalid;
        measured.push_back({tool.name, noisy.matrix(), valid});
        record.tools.push_back({compact(tool.tracker_T_tool), static_cast<int>(tool.visibility)});
      }
      plus->publishTools(measured, utc0 + t);
      std::lock_guard lock(truth_mutex);
      if (tool_names.empty()) {
        for (const auto& tool : truth) tool_names.push_back(tool.name);
      }
      tracker_truth.push_back(std::move(record));
      ++stats.tracker_samples;
      stats.invalid_tool_samples += invalid;
    }
  }

  // The operator guiding the arm by hand (freedrive): the arm is where the hand puts it, waypoint after waypoint
  // with a minimum-jerk profile; after each waypoint the controller has the arm again until the next one.
  struct GuidedPlay {
    std::vector<std::pair<robot::Joints, double>> path;  ///< joints reached, over that long
    robot::Joints from;
    double start_s = 0.0;
  };
  std::size_t next_guided = 0;
  std::uint64_t script_commands_seen = 0;
  double last_command_s = -1e9;
  double guided_end_s = 0.0;  ///< when the previous waypoint ended (the next one without at_s starts then)
  std::optional<GuidedPlay> guiding;

  /// The arm turning the drill about its tip, held in a divot: `n` waypoints over the duration, waypoint i the
  /// rotation `turn(i, axis)` about the tip (axis: the drill's, from the flange through its tip), each joint
  /// solution nearest the one before. Throws ComputationError (`what`) when the UR5 cannot follow.
  std::vector<std::pair<robot::Joints, double>> turnAboutTip(
      const robot::Joints& from, int n, double duration_s,
      const std::function<Eigen::Matrix3d(int, const Eigen::Vector3d&)>& turn, const std::string& what) const {
    const auto& kinematics = ur->arm().kinematics();
    const Eigen::Isometry3d base_T_flange = kinematics.forward(from);
    const Eigen::Vector3d tip = base_T_flange * scenario.robot.drill_tip_flange;
    const Eigen::Vector3d axis = (tip - base_T_flange.translation()).normalized();
    std::vector<std::pair<robot::Joints, double>> path;
    robot::Joints q = from;
    for (int i = 1; i <= n; ++i) {
      Eigen::Isometry3d about_tip = Eigen::Isometry3d::Identity();
      about_tip.linear() = turn(i, axis);
      about_tip.translation() = tip - about_tip.linear() * tip;
      const auto next = kinematics.inverseNearest(about_tip * base_T_flange, q, &ur->arm().options().limits);
      if (!next) throw ComputationError(what + " from where it stands");
      q = *next;
      path.emplace_back(q, duration_s / n);
    }
    return path;
  }

  /// The joints of one waypoint, from where the arm stands: the target; the drill pivoting about its tip (its
  /// axis circling a cone, ramped in and out); or the drill turned back and forth about its own axis (a spin).
  std::vector<std::pair<robot::Joints, double>> guidedPath(const RobotSpec::GuidedWaypoint& w,
                                                           const robot::Joints& from) const {
    constexpr double kRad = M_PI / 180.0;
    if (w.spin_deg > 0.0) {
      constexpr int kPerCycle = 96;  // a few degrees of turn per waypoint
      return turnAboutTip(
          from, kPerCycle * w.spin_cycles, w.duration_s,
          [&](int i, const Eigen::Vector3d& axis) {
            const double angle = w.spin_deg * kRad * std::sin(2.0 * M_PI * i / kPerCycle);
            return Eigen::AngleAxisd(angle, axis).toRotationMatrix();
          },
          "hand-guided drill spin: the UR5 cannot turn the drill " + std::to_string(w.spin_deg) +
              " deg about its axis");
    }
    if (w.pivot_deg > 0.0) {
      constexpr int kPerCycle = 48;  // 7.5 deg of the cone per waypoint: the tip stays within ~0.1 mm between them
      const int n = kPerCycle * w.pivot_cycles;
      return turnAboutTip(
          from, n, w.duration_s,
          [&](int i, const Eigen::Vector3d& axis) {
            const Eigen::Vector3d u = axis.unitOrthogonal(), v = axis.cross(u);
            const double phase = 2.0 * M_PI * i / kPerCycle;
            const double ramp = std::min({1.0, i / (0.25 * kPerCycle), (n - i) / (0.25 * kPerCycle)});
            const Eigen::Vector3d tilt_axis = std::cos(phase) * u + std::sin(phase) * v;
            return Eigen::AngleAxisd(ramp * w.pivot_deg * kRad, tilt_axis).toRotationMatrix();
          },
          "hand-guided drill pivot: the UR5 cannot tilt the drill " + std::to_string(w.pivot_deg) +
              " deg about its tip");
    }
    robot::Joints to;
    for (int i = 0; i < 6; ++i) to[i] = w.joints[static_cast<std::size_t>(i)];
    return {{to, w.duration_s}};
  }

  void guideArm(double t) {
    const auto& waypoints = scenario.robot.hand_guided;
    if (!guiding && next_guided < waypoints.size()) {
      const auto& w = waypoints[next_guided];
      const double at = w.at_s.value_or(guided_end_s);
      // The operator does not take an arm the controller is driving: a UR refuses freedrive while its program
      // moves the arm. The hand waits until no command came for a second and the arm stands still.
      const auto commands = ur->stats().script_commands;
      if (commands != script_commands_seen) {
        script_commands_seen = commands;
        last_command_s = t;
      }
      const bool driven = t - last_command_s < 1.0 || ur->armState().qd.cwiseAbs().maxCoeff() > 1e-6;
      if (t >= at && !driven) {
        GuidedPlay play;
        if (next_guided == 0 && !w.at_s) {
          for (int i = 0; i < 6; ++i) play.from[i] = scenario.robot.start_joints[static_cast<std::size_t>(i)];
        } else {
          play.from = ur->armState().q;  // the hand takes the arm where it stands
        }
        play.start_s = t;  // when the hand took it (at_s, or later if the controller was still driving it)
        try {
          play.path = guidedPath(w, play.from);
        } catch (const Error& e) {
          event(t, std::string("hand guidance skipped: ") + e.what());
          play.path.clear();
        }
        guiding = std::move(play);
        ++next_guided;
      }
    }
    if (!guiding) return;
    robot::Joints from = guiding->from;
    double start = guiding->start_s;
    for (const auto& [to, duration] : guiding->path) {
      if (t < start + duration) {
        ur->arm().reset(from + (to - from) * minimumJerk((t - start) / duration));
        return;
      }
      from = to;
      start += duration;
    }
    ur->arm().reset(from);  // released where the waypoint ends
    guided_end_s = start;
    guiding.reset();
  }

  // The virtual operator at the headset: answers the workstation's prompts after the time the task takes, and
  // confirms on the scenario's timeline. Runs at 10 Hz from the tracker thread.
  std::uint64_t prompts_seen = 0;
  std::vector<std::pair<double, std::string>> pending_confirmations;
  std::vector<bool> timeline_confirmed;

  // The cube in the operator's hand, lined up with where the headset shows its hologram (in the tracker frame:
  // the headset's world frame placed by its truth).
  std::vector<World::HeldTool> heldTools(double t, const std::optional<Eigen::Isometry3d>& base_T_flange) {
    std::vector<World::HeldTool> held;
    if (!board_toucher && !camera_operator && !cube_operator) return held;
    // Where the scenario puts every tool now (nobody holding it), evaluated once per tick.
    const auto resting = world->tools(t, base_T_flange);
    const auto rest = [&](const std::string& name) { return restingPoseIn(resting, name); };
    if (board_toucher) {
      const auto& name = scenario.hmd.board_touch.tool;
      if (auto stylus = board_toucher->pose(t, rest(name))) held.push_back({name, *stylus});
    }
    if (camera_operator) {
      if (auto headset = camera_operator->pose(t, rest(scenario.hmd.marker_tool))) {
        held.push_back({scenario.hmd.marker_tool, *headset});
      }
    }
    if (!cube_operator) return held;
    std::optional<Eigen::Isometry3d> shown;
    for (const auto& m : hmd->displayed()) {
      if (m.name == scenario.hmd.cube.hologram && m.visible && tracker_T_hmd_world) {
        shown = *tracker_T_hmd_world * m.world_T_model;
      }
    }
    if (const auto cube = cube_operator->pose(t, rest(scenario.hmd.cube.tool), shown)) {
      held.push_back({scenario.hmd.cube.tool, *cube});
    }
    return held;
  }

  static Eigen::Isometry3d restingPoseIn(const std::vector<ToolTruth>& tools, const std::string& name) {
    for (const auto& tool : tools) {
      if (tool.name == name) return tool.tracker_T_tool;
    }
    return Eigen::Isometry3d::Identity();
  }

  // Where the scenario puts a tool at t (its motion, nobody holding it).
  Eigen::Isometry3d restingPose(double t, const std::optional<Eigen::Isometry3d>& base_T_flange,
                                const std::string& name) const {
    return restingPoseIn(world->tools(t, base_T_flange), name);
  }

  std::optional<Eigen::Isometry3d> flangeNow() const {
    if (!ur) return std::nullopt;
    return ur->armState().base_T_flange;
  }

  // The photo the wearer's headset takes, rendered and sent off this thread (a previous one finished first).
  void takePhoto(double t) {
    const auto resting = world->tools(t, flangeNow());
    const Eigen::Isometry3d rest = restingPoseIn(resting, scenario.hmd.marker_tool);
    const auto headset = camera_operator->pose(t, rest);
    const Eigen::Isometry3d board = restingPoseIn(resting, scenario.hmd.camera.board_tool);
    const auto photo = camera_operator->photoDue(t, headset.value_or(rest), board);
    {
      std::lock_guard lock(truth_mutex);
      camera_views = camera_operator->views();
    }
    if (!photo) return;
    if (photo_thread.joinable()) photo_thread.join();
    const auto& c = scenario.hmd.camera;
    hmd::BoardRenderOptions render;
    render.blur_sigma_px = c.blur_sigma_px;
    render.noise_sigma = c.noise_sigma;
    render.seed = static_cast<unsigned>(scenario.seed * 7919ULL + static_cast<std::uint64_t>(photo->view));
    const std::string intrinsics = c.send_intrinsics ? hmd::intrinsicsText(camera_operator->reportedIntrinsics()) : "";
    photo_thread = std::thread([this, t, photo = *photo, render, intrinsics] {
      try {
        const auto image = hmd::renderCheckerboard(camera_operator->board(), camera_operator->trueIntrinsics(),
                                                   photo.camera_T_grid, render);
        const bool sent = hmd->sendImage(image.width, image.height, image.pixels, intrinsics);
        event(t, "hmd photo of view " + std::to_string(photo.view) + (sent ? " sent" : " lost (not connected)"), false);
      } catch (const std::exception& e) {
        event(t, std::string("hmd photo failed: ") + e.what(), false);
      }
    });
  }

  void operateHeadset(double t) {
    const auto& spec = scenario.hmd;
    for (const auto& prompt : hmd->promptsSince(prompts_seen)) {
      event(t, "hmd prompt: " + prompt, false);
      if (cube_operator) cube_operator->onPrompt(t, prompt);
      if (board_toucher) {
        const auto flange = flangeNow();
        board_toucher->onPrompt(t, prompt, restingPose(t, flange, scenario.hmd.camera.board_tool),
                                restingPose(t, flange, scenario.hmd.board_touch.tool));
        std::lock_guard lock(truth_mutex);
        board_touches = board_toucher->touches();
      }
      if (camera_operator) {
        const auto flange = flangeNow();
        camera_operator->onPrompt(t, prompt, restingPose(t, flange, scenario.hmd.camera.board_tool),
                                  restingPose(t, flange, scenario.hmd.marker_tool));
      }
      for (const auto& r : spec.responses) {
        if (prompt.find(r.prompt_contains) != std::string::npos) {
          pending_confirmations.emplace_back(t + r.after_s, r.confirm);
        }
      }
    }
    if (camera_operator) takePhoto(t);
    if (cube_operator) {
      if (auto c = cube_operator->confirmationDue(t)) pending_confirmations.emplace_back(t, *c);
      std::lock_guard lock(truth_mutex);
      cube_matches = cube_operator->matches();
    }
    timeline_confirmed.resize(spec.confirmations.size(), false);
    for (std::size_t i = 0; i < spec.confirmations.size(); ++i) {
      if (!timeline_confirmed[i] && t >= spec.confirmations[i].at_s) {
        timeline_confirmed[i] = true;
        pending_confirmations.emplace_back(t, spec.confirmations[i].confirm);
      }
    }
    for (auto it = pending_confirmations.begin(); it != pending_confirmations.end();) {
      if (t < it->first) {
        ++it;
        continue;
      }
      // Not connected: the operator's confirmation is lost, as a tap on a headset that lost its link would be.
      const bool sent = hmd->confirm(it->second);
      event(t, std::string(sent ? "hmd confirm: " : "hmd confirm lost (not connected): ") + it->second, false);
      it = pending_confirmations.erase(it);
    }
  }

  // At 10 Hz: what the emulated headset displays (its truth: what the wearer would see).
  void recordHmd(double t) {
    HmdTruth h{utc0 + t, {}, {}, {}, {}, std::nullopt};
    if (scenario.patient) h.tracker_T_ct = compact(world->trackerTCt(t));
    for (const auto& m : hmd->displayed()) {
      h.names.push_back(m.name);
      h.world_T_model.push_back(compact(m.world_T_model));
      if (tracker_T_hmd_world) h.tracker_T_model.push_back(compact(*tracker_T_hmd_world * m.world_T_model));
      h.visible.push_back(m.visible);
    }
    std::lock_guard lock(truth_mutex);
    hmd_truth.push_back(std::move(h));
  }

  void fireFaults(double t, std::vector<bool>& started, std::vector<bool>& ended) {
    for (std::size_t i = 0; i < scenario.faults.size(); ++i) {
      const Fault& f = scenario.faults[i];
      if (!started[i] && t >= f.at_s) {
        started[i] = true;
        std::string what = std::string(toString(f.kind)) + " start";
        if (f.kind == FaultKind::TrackerDisconnect) plus->stop();
        if (f.kind == FaultKind::RobotProtectiveStop) {
          if (ur) {
            ur->arm().protectiveStop();
          } else {
            what += " (no robot in the scenario)";
          }
        }
        if (f.kind == FaultKind::HmdDisconnect) {
          if (hmd) {
            hmd->stop();
          } else {
            what += " (no headset in the scenario)";
          }
        }
        if (f.kind == FaultKind::Occlusion) what += " " + f.tool;
        event(t, what);
      }
      const bool has_end = f.kind == FaultKind::Occlusion || f.kind == FaultKind::TrackerDisconnect ||
                           f.kind == FaultKind::VideoFreeze || f.kind == FaultKind::HmdDisconnect;
      if (has_end && started[i] && !ended[i] && t >= f.at_s + f.duration_s) {
        ended[i] = true;
        if (f.kind == FaultKind::HmdDisconnect && hmd) hmd->start();
        if (f.kind == FaultKind::TrackerDisconnect) {
          try {
            plus->start();
          } catch (const Error& e) {
            event(t, std::string("tracker_disconnect end failed: ") + e.what());
            continue;
          }
        }
        event(t, std::string(toString(f.kind)) + " end" + (f.kind == FaultKind::Occlusion ? " " + f.tool : ""));
      }
    }
  }

  [[nodiscard]] bool videoFrozen(double t) const {
    for (const auto& f : scenario.faults) {
      if (f.kind == FaultKind::VideoFreeze && t >= f.at_s && t < f.at_s + f.duration_s) return true;
    }
    return false;
  }

  void videoLoop() {
    const auto& us = scenario.ultrasound;
    BModeGeometry geometry{us.width, us.height, us.spacing_x_mm, us.spacing_y_mm};
    BModeNoiseModel noise;
    noise.attenuation_db_per_cm = us.attenuation_db_per_cm;
    noise.speckle = us.speckle > 0.0;
    BModeFrame frame;
    frame.device_name = us.device_name;
    frame.width = us.width;
    frame.height = us.height;
    frame.spacing_x_mm = us.spacing_x_mm;
    frame.spacing_y_mm = us.spacing_y_mm;
    const double period = 1.0 / us.rate_hz;
    double render_ms_total = 0.0;
    for (std::uint64_t tick = 0; running.load(); ++tick) {
      if (!sleepUntil(tick * period)) break;
      // The frame grabber's instants, as the tracker's: regular, whatever this process's scheduling.
      const double t = tick * period;
      if (scenario.duration_s > 0.0 && t >= scenario.duration_s) break;
      const double content_t = std::max(0.0, t - us.video_lag_s);
      const bool frozen = videoFrozen(t) && !frame.pixels.empty();
      Eigen::Isometry3d tracker_T_image = Eigen::Isometry3d::Identity();
      double render_ms = 0.0;
      if (!frozen) {
        // A frozen frame grabber repeats its last frame with fresh timestamps.
        tracker_T_image = world->trackerTImage(content_t);
        const auto start = Clock::now();
        frame.pixels = renderBModeFrame(world->echoScene(content_t), tracker_T_image, geometry, noise,
                                        scenario.seed * 1000003ULL + tick);
        render_ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
      }
      plus->publishImage(frame, utc0 + t);
      std::lock_guard lock(truth_mutex);
      if (frozen) {
        ++stats.frozen_frames;
        frame_truth.push_back({utc0 + t, content_t,
                               frame_truth.empty() ? compact(tracker_T_image) : frame_truth.back().tracker_T_image,
                               true});
      } else {
        frame_truth.push_back({utc0 + t, content_t, compact(tracker_T_image), false});
        render_ms_total += render_ms;
        stats.max_frame_render_ms = std::max(stats.max_frame_render_ms, render_ms);
      }
      ++stats.video_frames;
      const auto rendered = stats.video_frames - stats.frozen_frames;
      stats.mean_frame_render_ms = rendered ? render_ms_total / static_cast<double>(rendered) : 0.0;
    }
  }

  void replayLoop() {
    const auto& seq = *replay;
    const double speed = scenario.replay->speed;
    const bool has_images = !seq.frames.empty() && seq.frames.front().hasPixels();
    BModeFrame frame;
    frame.device_name = "Image_Image";
    frame.width = static_cast<int>(seq.geometry.size[0]);
    frame.height = static_cast<int>(seq.geometry.size[1]);
    frame.spacing_x_mm = seq.geometry.spacing[0];
    frame.spacing_y_mm = seq.geometry.spacing[1];
    double offset = 0.0;
    if (scenario.replay->wait_for_client) {
      while (running.load() && plus->stats().clients_connected == 0) std::this_thread::sleep_for(10ms);
      // The client's first requests (GET_STATUS, STT_TDATA) are answered before the first frame goes out.
      std::this_thread::sleep_for(200ms);
      offset = elapsed();
    }
    const double first = seq.frames.front().timestamp;
    const double span = seq.frames.back().timestamp - first;
    do {
      for (const auto& f : seq.frames) {
        const double t = offset + (f.timestamp - first) / speed;
        if (!sleepUntil(t)) return;
        std::vector<MeasuredTool> tools;
        for (const auto& [name, transform] : f.transforms) {
          tools.push_back({name, transform.matrix, transform.status == TransformStatus::Ok});
        }
        // The recording's own timing, lag included, shifted to now.
        const double stamp = utc0 + t;
        plus->publishTools(tools, stamp);
        if (has_images && f.hasPixels()) {
          frame.pixels = f.pixels;
          plus->publishImage(frame, stamp);
        }
        std::lock_guard lock(truth_mutex);
        ++stats.replayed_frames;
      }
      offset += span / speed + 1.0 / 30.0;
    } while (scenario.replay->loop && running.load());
    // The last frames may still be queued for a client that a loaded machine keeps waiting: `mrsns-sim run`
    // stops the room once it is finished, and a stop drops what is not written (a full-suite run lost the
    // replay's last frame so). Bounded: a client that reads nothing does not hold the room open.
    plus->waitUntilSent(5.0);
    finished = true;
  }
};

OperatingRoom::OperatingRoom(Scenario scenario) : impl_(std::make_unique<Impl>()) {
  impl_->scenario = std::move(scenario);
  const Scenario& s = impl_->scenario;
  impl_->world = std::make_unique<World>(s);
  if (s.replay) {
    io::SequenceReadOptions options;
    impl_->replay = io::readSequence(s.replay->sequence, options);
    const auto& seq = *impl_->replay;
    if (seq.frames.empty()) throw FormatError(s.replay->sequence.string() + " has no frames to replay");
    if (!seq.frames.front().hasPixels()) {
      // A tracker buffer: transforms only, which is fine.
    } else if (seq.pixel_format.scalar != PixelType::UInt8 || seq.pixel_format.components != 1 ||
               seq.geometry.size[2] != 1) {
      throw UnsupportedError(s.replay->sequence.string() +
                             ": only 8-bit single-component 2D frames can be served as B-mode IMAGE messages");
    }
    for (std::size_t i = 1; i < seq.frames.size(); ++i) {
      if (seq.frames[i].timestamp < seq.frames[i - 1].timestamp) {
        throw FormatError(s.replay->sequence.string() + ": frame " + std::to_string(i) +
                          " has an earlier timestamp than the one before; the recording cannot be replayed in order");
      }
    }
  }
  if (s.robot.enabled && s.patient) {
    // The arm must reach the patient from where the scenario puts its base.
    const Eigen::Vector3d ct_in_base = s.robot.tracker_T_base.inverse() * impl_->world->trackerTCt(0.0).translation();
    if (ct_in_base.norm() > kUr5ReachMm) {
      throw InvalidArgumentError("the robot base is " + std::to_string(static_cast<int>(ct_in_base.norm())) +
                                 " mm from the patient, beyond the UR5's 850 mm reach: move robot.base_to_tracker "
                                 "closer to the patient");
    }
  }
}

OperatingRoom::~OperatingRoom() {
  stop();
}

void OperatingRoom::start() {
  if (impl_->running) return;
  const Scenario& s = impl_->scenario;
  PlusServerOptions plus_options;
  plus_options.bind_address = s.tracker.bind_address;
  plus_options.port = s.tracker.port;
  plus_options.max_header_version = s.tracker.max_header_version;
  plus_options.send_valid_transforms_only = s.tracker.send_valid_transforms_only;
  // Each room's controller has its own serial number (digits, as a real one's), told to the workstation
  // with the tracker's identity: it then never drives a controller of another room, or a real arm.
  std::string serial;
  if (s.robot.enabled) {
    std::random_device device;
    serial = "2018" + std::to_string(1000000 + device() % 9000000);
    plus_options.robot_serial = serial;
  }
  impl_->plus = std::make_unique<PlusServerEmulator>(plus_options);
  impl_->plus->start();
  if (s.robot.enabled) {
    robot::UrSimulatorOptions ur;
    ur.host = s.tracker.bind_address;
    ur.rtde_port = s.robot.rtde_port;
    ur.dashboard_port = s.robot.dashboard_port;
    ur.secondary_port = s.robot.secondary_port;
    ur.realtime_port = s.robot.realtime_port;
    for (int i = 0; i < 6; ++i) {
      ur.arm.q0[i] = s.robot.start_joints[static_cast<std::size_t>(i)];
      if (const auto& range = s.robot.joint_limits[static_cast<std::size_t>(i)]) {
        ur.arm.limits.min_q[i] = range->first;
        ur.arm.limits.max_q[i] = range->second;
      }
    }
    ur.arm.stops_lost = s.robot.stops_lost;
    ur.serial_number = serial;
    try {
      impl_->ur = std::make_unique<robot::UrSimulator>(ur);
    } catch (...) {
      impl_->plus->stop();
      throw;
    }
  }
  if (s.hmd.enabled) {
    // The headset keeps trying to reach the workstation's hologram stream, as a HoloLens app does.
    HmdEmulatorOptions hmd;
    hmd.host = s.hmd.host;
    hmd.port = s.hmd.port;
    hmd.unity = s.hmd.unity;
    hmd.drift_mm_per_min = s.hmd.drift_mm_per_min;
    hmd.jitter_mm = s.hmd.jitter_mm;
    hmd.seed = s.seed;
    impl_->hmd = std::make_unique<HmdEmulator>(hmd);
    if (!s.hmd.marker_tool.empty()) {
      // A headset anchors its world frame where it is when it starts; its marker tells the truth of that place.
      for (const auto& tool : impl_->world->tools(0.0, std::nullopt)) {
        if (tool.name == s.hmd.marker_tool) impl_->tracker_T_hmd_world = tool.tracker_T_tool * s.hmd.marker_T_world;
      }
    }
    if (s.hmd.cube.enabled && impl_->tracker_T_hmd_world) {
      impl_->cube_operator = std::make_unique<CubeOperator>(s.hmd.cube, s.seed);
    }
    if (s.hmd.camera.enabled && impl_->tracker_T_hmd_world) {
      impl_->camera_operator = std::make_unique<CameraOperator>(s.hmd.camera, s.tracker.volume, s.seed);
    }
    if (s.hmd.board_touch.enabled) {
      for (const auto& tool : s.tools) {
        if (tool.name == s.hmd.board_touch.tool && tool.tip_tool) {
          impl_->board_toucher = std::make_unique<BoardToucher>(s.hmd.board_touch, s.hmd.camera, *tool.tip_tool, s.seed);
        }
      }
    }
    impl_->hmd->start();
  }
  impl_->t0 = Clock::now();
  impl_->utc0 = unixTimeSeconds();
  impl_->running = true;
  if (impl_->replay) {
    impl_->replay_thread = std::thread([this] { impl_->replayLoop(); });
  } else {
    impl_->tracker_thread = std::thread([this] { impl_->trackerLoop(); });
    if (s.ultrasound.enabled) impl_->video_thread = std::thread([this] { impl_->videoLoop(); });
  }
}

void OperatingRoom::stop() {
  if (!impl_) return;
  impl_->running = false;
  for (auto* th : {&impl_->tracker_thread, &impl_->video_thread, &impl_->replay_thread, &impl_->photo_thread}) {
    if (th->joinable()) th->join();
  }
  if (impl_->ur) impl_->ur->stop();
  if (impl_->plus) impl_->plus->stop();
  if (impl_->hmd) impl_->hmd->stop();
}

bool OperatingRoom::finished() const {
  return impl_->finished.load();
}

OperatingRoomEndpoints OperatingRoom::endpoints() const {
  OperatingRoomEndpoints e;
  e.host = impl_->scenario.tracker.bind_address;
  if (impl_->plus) e.plus_port = impl_->plus->port();
  if (impl_->ur) {
    e.robot = true;
    e.rtde_port = impl_->ur->rtdePort();
    e.dashboard_port = impl_->ur->dashboardPort();
    e.secondary_port = impl_->ur->secondaryPort();
    e.realtime_port = impl_->ur->realtimePort();
  }
  return e;
}

OperatingRoomStats OperatingRoom::stats() const {
  OperatingRoomStats s;
  {
    std::lock_guard lock(impl_->truth_mutex);
    s = impl_->stats;
  }
  if (impl_->running || impl_->t0 != Clock::time_point{}) s.elapsed_s = impl_->elapsed();
  if (impl_->hmd) {
    const auto h = impl_->hmd->stats();
    s.hmd_connected = h.connected;
    s.hmd_transforms = h.transforms;
    s.hmd_meshes = h.meshes;
  }
  if (impl_->plus) {
    const auto p = impl_->plus->stats();
    s.transform_messages = p.transform_messages;
    s.tdata_messages = p.tdata_messages;
    s.image_messages = p.image_messages;
    s.clients_connected = p.clients_connected;
  }
  return s;
}

void OperatingRoom::writeTruth(const std::filesystem::path& path) const {
  using Json = nlohmann::json;
  Json j;
  j["format"] = "mrsns-truth/1";
  j["note"] = "Written by mrsns-sim for mrsns-sim score only: the workstation must never read it.";
  j["static"] = Json::parse(impl_->world->staticTruthJson());
  j["utc_start"] = impl_->utc0;
  {
    std::lock_guard lock(impl_->truth_mutex);
    j["tools"] = impl_->tool_names;
    j["pose_layout"] = "[x_mm, y_mm, z_mm, qw, qx, qy, qz] in the tracker frame";
    j["visibility_codes"] = {toString(Visibility::Visible), toString(Visibility::OutOfVolume),
                             toString(Visibility::LineOfSightBlocked), toString(Visibility::OccludedByFault)};
    Json samples = Json::array();
    for (const auto& r : impl_->tracker_truth) {
      Json poses = Json::array(), vis = Json::array();
      for (const auto& tool : r.tools) {
        poses.push_back(tool.pose);
        vis.push_back(tool.visibility);
      }
      samples.push_back({{"t", r.t}, {"utc", r.utc}, {"poses", poses}, {"visibility", vis}});
    }
    j["tracker_samples"] = samples;
    Json frames = Json::array();
    for (const auto& f : impl_->frame_truth) {
      frames.push_back(
          {{"utc", f.utc}, {"content_t", f.content_t}, {"tracker_T_image", f.tracker_T_image}, {"frozen", f.frozen}});
    }
    j["video_frames"] = frames;
    Json displayed = Json::array();
    for (const auto& h : impl_->hmd_truth) {
      Json d{{"utc", h.utc}, {"models", h.names}, {"world_T_model", h.world_T_model}, {"visible", h.visible}};
      if (!h.tracker_T_model.empty()) d["tracker_T_model"] = h.tracker_T_model;
      if (h.tracker_T_ct) d["tracker_T_ct"] = *h.tracker_T_ct;
      displayed.push_back(d);
    }
    j["hmd_displayed"] = displayed;
    Json matches = Json::array();
    for (const auto& m : impl_->cube_matches) {
      const auto& e = m.perception_error_mm;
      matches.push_back({{"view", m.view},
                         {"prompt_t", m.prompt_t},
                         {"hold_t", std::isfinite(m.hold_t) ? Json(m.hold_t) : Json(nullptr)},
                         {"perception_error_mm", {e.x(), e.y(), e.z()}},
                         {"depth_error_mm", m.depth_error_mm},
                         {"confirmed", m.confirmed}});
    }
    if (!matches.empty()) j["hmd_cube_matches"] = matches;
    Json photos = Json::array();
    for (const auto& v : impl_->camera_views) {
      photos.push_back({{"view", v.view},
                        {"prompt_t", v.prompt_t},
                        {"photo_t", v.photo_t >= 0.0 ? Json(v.photo_t) : Json(nullptr)},
                        {"distance_mm", v.distance_mm},
                        {"tilt_deg", v.tilt_deg},
                        {"reachable", v.reachable}});
    }
    if (!photos.empty()) j["hmd_camera_views"] = photos;
    Json touches = Json::array();
    for (const auto& b : impl_->board_touches) {
      const auto& e = b.placement_error_mm;
      touches.push_back({{"corner", b.corner}, {"prompt_t", b.prompt_t}, {"placement_error_mm", {e.x(), e.y(), e.z()}}});
    }
    if (!touches.empty()) j["board_touches"] = touches;
    if (impl_->tracker_T_hmd_world) {
      Json m = Json::array();
      for (int r = 0; r < 4; ++r) {
        for (int c = 0; c < 4; ++c) m.push_back(impl_->tracker_T_hmd_world->matrix()(r, c));
      }
      j["HeadsetWorldToTracker"] = m;
    }
    Json events = Json::array();
    for (const auto& e : impl_->events) events.push_back({{"t", e.t}, {"utc", e.utc}, {"event", e.what}});
    j["events"] = events;
  }
  const auto tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    if (!out) throw FileError("cannot write the truth file " + path.string() + " (is its folder writable?)");
    out << j.dump() << "\n";
    if (!out) throw FileError("writing the truth file " + path.string() + " failed (disk full?)");
  }
  std::filesystem::rename(tmp, path);
}

}  // namespace mrsns::simulation
