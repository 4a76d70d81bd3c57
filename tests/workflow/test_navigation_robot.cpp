// The robot in the navigation loop: a simulated tracker feeds the SafetySupervisor of a simulated UR5
// running its ControlLoop in real time; a tracker loss must stop the arm through the supervisor, keep the
// recording intact and refuse a re-arm until tracking is back. Real threads: every wait below polls until
// a condition holds or a generous deadline passes (the deadlines are not speed requirements).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <thread>

#include "mrsns/core/error.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/workflow/navigation.h"
#include "test_data.h"
#include "navigation_test_log.h"
#include "wait_for.h"

namespace mrsns::workflow {
namespace {

using ::mrsns::test::describe;
using ::mrsns::test::firstStop;
using ::mrsns::test::waitFor;

using namespace std::chrono_literals;

NavigationOptions robotOptions(const std::filesystem::path& recording) {
  NavigationOptions o;
  o.recording = recording;
  o.robot.robot = "simulated";
  o.sync_interval_s = 0.2;
  // Stops in these tests must come from tracking: the watchdog has its own tests in tests/robot, and this
  // shared, non-real-time test machine may skip control cycles under load.
  o.robot.max_cycle_time_s = 0.2;
  o.robot.max_missed_cycles = 200;
  // Likewise a tracker thread starved for 0.25 s on an overloaded machine is a genuine stale-pose stop;
  // these tests script other losses (staleness: test_navigation_robot_silence.cpp).
  o.silence_timeout_s = 1.0;
  return o;
}

// After a stop: the arm comes to rest within its stopping-time limit, stays at rest, and no motion command
// goes out while the supervisor is stopped.
void expectStoppedAndStill(NavigationLoop& loop) {
  ASSERT_TRUE(waitFor([&] { return !std::isnan(loop.status().time_to_stop_s); }, 3000ms))
      << "the arm never came to rest: " << loop.status().last_transition;
  const auto at_rest = loop.status();
  EXPECT_LE(at_rest.time_to_stop_s, at_rest.stop_time_limit_s);
  EXPECT_GT(at_rest.stop_time_limit_s, 0.0);
  EXPECT_GE(at_rest.stop_latency_cycles, 1);
  EXPECT_GE(at_rest.stop_latency_ms, 0.0);
  for (int i = 0; i < 10; ++i) {
    std::this_thread::sleep_for(20ms);
    const auto s = loop.status();
    EXPECT_LE(s.arm_speed_rad_s, 1e-6) << "sample " << i;
    EXPECT_EQ(s.motion_commands, at_rest.motion_commands) << "a motion command after the stop";
    EXPECT_EQ(s.motion_commands_after_stop, 0u);
    EXPECT_TRUE(s.supervisor_state == "Stopped" || s.supervisor_state == "Fault") << s.supervisor_state;
  }
}

// Runs until the supervisor stops; checks the stop came from the supervisor with `reason` while the robot
// was moving along the plan, and that the workflow names the lost transform.
void expectTrackingStop(NavigationLoop& loop, const std::string& reason, const std::string& lost) {
  ASSERT_TRUE(waitFor([&] { return loop.status().robot_stopped; }, 6000ms))
      << "no stop; supervisor " << loop.status().supervisor_state << describe(loop.robotTransitions());
  const auto log = loop.robotTransitions();
  const auto* stop = firstStop(log);
  ASSERT_NE(stop, nullptr) << describe(log);
  EXPECT_EQ(stop->reason, reason) << describe(log);
  EXPECT_EQ(stop->from, "Advancing") << "the loss was scripted for the advance" << describe(log);
  EXPECT_EQ(stop->command, "StopJ");
  if (!lost.empty()) {
    EXPECT_NE(stop->tracking.find(lost), std::string::npos) << stop->tracking;
  }
  const auto s = loop.status();
  EXPECT_EQ(s.supervisor_stop, reason);
  EXPECT_NE(s.stop_reason.find(reason), std::string::npos) << s.stop_reason;
  if (!lost.empty()) {
    EXPECT_NE(s.stop_reason.find(lost), std::string::npos) << s.stop_reason;
  }
  bool event = false;
  for (const auto& e : loop.events()) event |= e.kind == "safety-stop" && e.message.find(reason) != std::string::npos;
  EXPECT_TRUE(event);
  expectStoppedAndStill(loop);
}

TEST(NavigationRobot, PatientLossWhileAdvancingStopsTheArmThroughTheSupervisorAndKeepsTheRecording) {
  const auto path = test::scratchDirectory("navrobot") / "patient.mhd";
  auto o = robotOptions(path);
  o.devices.dropout_tool = "PatientToTracker";
  o.devices.dropout_start_s = 2.2;
  o.devices.dropout_duration_s = 3.0;
  NavigationLoop loop(o);
  loop.start();
  ASSERT_TRUE(waitFor([&] { return loop.status().supervisor_state == "Advancing"; }, 4000ms))
      << loop.status().supervisor_state << describe(loop.robotTransitions());
  EXPECT_GT(loop.status().motion_commands, 0u);
  expectTrackingStop(loop, "PatientNotTracked", "PatientToTracker");
  const double stop_time = firstStop(loop.robotTransitions())->time_s;
  loop.stop();
  const auto status = loop.status();

  // (d) The recording: every batch, in order, including the second before the stop and the loss itself.
  const auto recording = io::readSequence(path);
  ASSERT_EQ(recording.frames.size(), status.frames_recorded);
  EXPECT_EQ(status.frames_recorded, status.batches);
  std::size_t last_second = 0, lost_before_stop = 0, advancing = 0, stopped = 0;
  for (std::size_t i = 0; i < recording.frames.size(); ++i) {
    const auto& f = recording.frames[i];
    if (i > 0) {
      ASSERT_GT(f.timestamp, recording.frames[i - 1].timestamp) << "frame " << i;
    }
    const double arrival = std::stod(f.custom_fields.at("ArrivalTime"));
    if (arrival <= stop_time && arrival > stop_time - 1.0) ++last_second;
    if (arrival <= stop_time && f.transformStatus("PatientToTracker") == TransformStatus::Invalid) ++lost_before_stop;
    const auto state = f.custom_fields.find("SupervisorState");
    if (state != f.custom_fields.end()) {
      advancing += state->second == "Advancing";
      stopped += state->second == "Stopped";
    }
  }
  // The tracker runs at 60 Hz: a second holds ~60 batches; even a loaded machine delivers a good part.
  EXPECT_GT(last_second, 10u);
  EXPECT_GE(lost_before_stop, 1u) << "the sample that showed the loss is recorded before the stop";
  EXPECT_GT(advancing, 0u);
  EXPECT_GT(stopped, 0u);
  EXPECT_GT(recording.frames.back().transforms.count("DrillToTracker"), 0u) << "the drill marker is recorded";
}

TEST(NavigationRobot, PatientLossDuringTheApproachStopsTheMovingArmWithinItsStoppingLimit) {
  // The approach moves the tip at up to 40 mm/s: the joints have real speed to lose here.
  auto o = robotOptions({});
  o.devices.dropout_tool = "PatientToTracker";
  o.devices.dropout_start_s = 0.7;
  o.devices.dropout_duration_s = 3.0;
  NavigationLoop loop(o);
  loop.start();
  ASSERT_TRUE(waitFor([&] { return loop.status().robot_stopped; }, 4000ms)) << describe(loop.robotTransitions());
  const auto log = loop.robotTransitions();
  const auto* stop = firstStop(log);
  ASSERT_NE(stop, nullptr);
  EXPECT_EQ(stop->from, "Aligning") << describe(log);
  EXPECT_EQ(stop->reason, "PatientNotTracked");
  expectStoppedAndStill(loop);
}

TEST(NavigationRobot, ProbeLossStopsTheArmAsToolNotTracked) {
  auto o = robotOptions(test::scratchDirectory("navrobot") / "probe.mhd");
  o.devices.dropout_tool = "ProbeToTracker";
  o.devices.dropout_start_s = 2.2;
  o.devices.dropout_duration_s = 3.0;
  NavigationLoop loop(o);
  loop.start();
  expectTrackingStop(loop, "ToolNotTracked", "ProbeToTracker");
}

TEST(NavigationRobot, DrillMarkerLossStopsTheArmAsToolNotTracked) {
  auto o = robotOptions({});
  o.devices.dropout_tool = "DrillToTracker";
  o.devices.dropout_start_s = 2.2;
  o.devices.dropout_duration_s = 3.0;
  NavigationLoop loop(o);
  loop.start();
  expectTrackingStop(loop, "ToolNotTracked", "DrillToTracker");
}

TEST(NavigationRobot, KilledTrackerStopsTheArmAsTrackerDisconnected) {
  const auto path = test::scratchDirectory("navrobot") / "killed.mhd";
  NavigationLoop loop(robotOptions(path));
  loop.start();
  ASSERT_TRUE(waitFor([&] { return loop.status().supervisor_state == "Advancing"; }, 4000ms))
      << describe(loop.robotTransitions());
  loop.killTracker();
  expectTrackingStop(loop, "TrackerDisconnected", "");
  EXPECT_FALSE(loop.rearm()) << "no tracker, no re-arm";
  loop.stop();
  EXPECT_EQ(io::readSequence(path).frames.size(), loop.status().frames_recorded);
}

TEST(NavigationRobot, RearmIsRefusedWhileTrackingIsLostAndAcceptedOnceItIsBack) {
  auto o = robotOptions({});
  o.devices.dropout_tool = "PatientToTracker";
  o.devices.dropout_start_s = 2.2;
  o.devices.dropout_duration_s = 1.2;
  NavigationLoop loop(o);
  loop.start();
  ASSERT_TRUE(waitFor([&] { return loop.status().robot_stopped; }, 6000ms)) << describe(loop.robotTransitions());
  expectStoppedAndStill(loop);
  // Still inside the dropout (it ends 1.2 s after it began; the stop and the rest took well under that on
  // an idle machine, and a refusal is what the state says either way).
  const bool refused = !loop.rearm();
  bool refusal_event = false;
  for (const auto& e : loop.events()) {
    refusal_event |= e.kind == "rearm-refused" && e.message.find("PatientToTracker") != std::string::npos;
  }
  if (refused) {
    EXPECT_TRUE(refusal_event);
    EXPECT_TRUE(loop.status().robot_stopped);
    EXPECT_EQ(loop.status().supervisor_state, "Stopped");
  } else {
    ADD_FAILURE() << "re-armed while the patient reference was still in its dropout";
  }
  // Tracking comes back: the acknowledge goes through and the robot waits in Ready.
  ASSERT_TRUE(waitFor(
      [&] {
        std::this_thread::sleep_for(45ms);  // the operator presses re-arm now and then, not in a busy loop
        return loop.rearm();
      },
      4000ms))
      << loop.status().stop_reason;
  auto s = loop.status();
  EXPECT_FALSE(s.robot_stopped);
  EXPECT_TRUE(s.stop_reason.empty());
  ASSERT_TRUE(waitFor([&] { return loop.status().supervisor_state == "Ready"; }, 1000ms));
  // ... and moves again only when asked.
  EXPECT_TRUE(loop.startRobot());
  EXPECT_TRUE(waitFor([&] { return loop.status().supervisor_state == "Aligning"; }, 1000ms))
      << loop.status().supervisor_state;
  loop.stop();
}

TEST(NavigationRobot, WithoutALossTheRobotFollowsThePlanAndReturnsToReady) {
  auto o = robotOptions({});
  o.robot.plan.target = o.robot.plan.entry + Eigen::Vector3d(0, 0, 5);  // a short path keeps the test short
  o.robot.advance_speed_mm_s = 20.0;
  NavigationLoop loop(o);
  loop.start();
  ASSERT_TRUE(waitFor(
      [&] {
        const auto log = loop.robotTransitions();
        return !log.empty() && log.back().detail == "path finished";
      },
      8000ms))
      << describe(loop.robotTransitions());
  loop.stop();
  const auto s = loop.status();
  EXPECT_FALSE(s.robot_stopped) << s.stop_reason;
  EXPECT_EQ(s.robot_stops, 0u);
  EXPECT_EQ(s.supervisor_state, "Ready");
  EXPECT_GT(s.motion_commands, 100u);
  EXPECT_EQ(firstStop(loop.robotTransitions()), nullptr) << describe(loop.robotTransitions());
}

TEST(NavigationRobot, BadRobotOptionsAreRefusedWithAClearMessage) {
  auto o = robotOptions({});
  o.robot.robot = "ur10";
  try {
    NavigationLoop loop(o);
    FAIL();
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("none or simulated"), std::string::npos) << e.what();
  }
  o = robotOptions({});
  o.robot.control_rate_hz = 0.0;
  EXPECT_THROW(NavigationLoop{o}, InvalidArgumentError);
  o = robotOptions({});
  o.robot.plan.target = o.robot.plan.entry;
  EXPECT_THROW(NavigationLoop{o}, InvalidArgumentError);
  // Without a robot the status says so and the supervisor fields stay empty.
  NavigationLoop none(NavigationOptions{});
  EXPECT_EQ(none.status().robot, "none");
  EXPECT_TRUE(none.robotTransitions().empty());
  EXPECT_FALSE(none.startRobot());
}

}  // namespace
}  // namespace mrsns::workflow
