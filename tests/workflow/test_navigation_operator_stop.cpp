// The operator's stop (NavigationLoop::stopRobot) halts the arm through its safety supervisor while the
// navigation goes on (tracking, recording, the latency series); re-arm resumes the placement. Also the
// hologram stream started on a running loop: it publishes the loop's tracked transforms. Real threads:
// every wait polls until a condition holds or a generous deadline passes (not speed requirements).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <iostream>
#include <mutex>
#include <thread>

#include "mrsns/igtlink/client.h"
#include "mrsns/igtlink/transform.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/workflow/navigation.h"
#include "test_data.h"
#include "wait_for.h"

namespace mrsns::workflow {
namespace {

using ::mrsns::test::waitFor;

using namespace std::chrono_literals;

NavigationOptions robotOptions() {
  NavigationOptions o;
  o.robot.robot = "simulated";
  o.sync_interval_s = 0.2;
  // Stops here must be the operator's: the watchdog and stale-pose stops have their own tests, and this
  // shared machine may skip control cycles or starve the tracker thread under load.
  o.robot.max_cycle_time_s = 0.2;
  o.robot.max_missed_cycles = 200;
  o.silence_timeout_s = 1.0;
  return o;
}

TEST(NavigationOperatorStop, PausesTheArmThroughTheSupervisorWhileNavigationRecords) {
  auto o = robotOptions();
  o.recording = test::scratchDirectory("navigation_operator_stop") / "operator.mhd";
  NavigationLoop loop(o);
  loop.start();
  ASSERT_TRUE(waitFor([&] { return loop.status().supervisor_state == "Advancing"; }, 4000ms))
      << loop.status().last_transition;

  ASSERT_TRUE(loop.stopRobot("Stop robot button"));
  ASSERT_TRUE(waitFor([&] { return loop.status().supervisor_state == "Paused"; }, 3000ms))
      << loop.status().last_transition;
  const auto log = loop.robotTransitions();
  ASSERT_FALSE(log.empty());
  EXPECT_EQ(log.back().to, "Paused");
  EXPECT_EQ(log.back().reason, "Operator");
  EXPECT_EQ(log.back().command, "StopJ");
  // stopJ decelerates the arm to rest; rest = every joint below the supervisor's acknowledge threshold.
  ASSERT_TRUE(waitFor([&] { return loop.status().arm_speed_rad_s <= 1e-6; }, 3000ms))
      << "the arm never came to rest: " << loop.status().arm_speed_rad_s << " rad/s";

  // The arm's time to rest is measured from the pause command, within the arm's stopping-time limit.
  ASSERT_TRUE(waitFor([&] { return !std::isnan(loop.status().time_to_stop_s); }, 3000ms));
  const auto at_rest = loop.status();
  EXPECT_GT(at_rest.stop_time_limit_s, 0.0);
  EXPECT_LE(at_rest.time_to_stop_s, at_rest.stop_time_limit_s);
  std::cout << "operator stop: arm at rest " << at_rest.time_to_stop_s * 1e3 << " ms after the pause command\n";
  EXPECT_TRUE(at_rest.robot_stopped);
  EXPECT_TRUE(at_rest.operator_stopped);
  EXPECT_NE(at_rest.stop_reason.find("operator"), std::string::npos) << at_rest.stop_reason;
  // Navigation goes on: batches arrive and are recorded, no motion command goes out.
  ASSERT_TRUE(waitFor([&] { return loop.status().frames_recorded > at_rest.frames_recorded + 10; }, 3000ms));
  const auto later = loop.status();
  EXPECT_TRUE(later.running);
  EXPECT_GT(later.batches, at_rest.batches);
  EXPECT_EQ(later.motion_commands, at_rest.motion_commands) << "a motion command after the operator's stop";
  EXPECT_LE(later.arm_speed_rad_s, 1e-6);
  EXPECT_EQ(later.supervisor_state, "Paused");
  EXPECT_TRUE(loop.stopRobot("again"));                 // a second press is accepted...
  EXPECT_EQ(loop.status().supervisor_state, "Paused");  // ...and changes nothing

  // Re-arm resumes the placement where it paused.
  ASSERT_TRUE(loop.rearm());
  ASSERT_TRUE(waitFor([&] { return loop.status().motion_commands > later.motion_commands; }, 3000ms));
  const auto resumed = loop.status();
  EXPECT_FALSE(resumed.robot_stopped);
  EXPECT_FALSE(resumed.operator_stopped);
  EXPECT_TRUE(resumed.supervisor_state == "Advancing" || resumed.supervisor_state == "Aligning")
      << resumed.supervisor_state;
  loop.stop();
  EXPECT_EQ(loop.status().motion_commands_after_stop, 0u);
  EXPECT_EQ(io::readSequenceHeader(o.recording).frames.size(), loop.status().frames_recorded);
}

TEST(NavigationOperatorStop, WithoutARobotMarksTheStopAndRearmClearsIt) {
  NavigationOptions o;
  NavigationLoop loop(o);
  loop.start();
  ASSERT_TRUE(waitFor([&] { return loop.status().batches > 3; }, 3000ms));
  EXPECT_TRUE(loop.stopRobot(""));
  auto s = loop.status();
  EXPECT_TRUE(s.robot_stopped);
  EXPECT_TRUE(s.operator_stopped);
  EXPECT_EQ(s.stop_reason, "operator: stop requested");
  EXPECT_TRUE(loop.rearm());
  s = loop.status();
  EXPECT_FALSE(s.robot_stopped);
  loop.stop();
}

TEST(NavigationLatencySeries, OneSamplePerProcessedBatchOnTheLoopClock) {
  NavigationOptions o;
  NavigationLoop loop(o);
  loop.start();
  ASSERT_TRUE(waitFor([&] { return loop.status().batches >= 20; }, 4000ms));
  loop.stop();
  const auto series = loop.latencySeries();
  const auto st = loop.status();
  ASSERT_EQ(series.size(), st.batches);
  double sum = 0.0;
  for (std::size_t i = 0; i < series.size(); ++i) {
    EXPECT_GE(series[i].latency_ms, 0.0);
    if (i > 0) {
      EXPECT_GE(series[i].time_s, series[i - 1].time_s);
    }
    sum += series[i].latency_ms;
  }
  // The status' mean is the mean of these very samples.
  EXPECT_NEAR(sum / static_cast<double>(series.size()), st.mean_loop_latency_ms, 1e-9 * (1.0 + sum));
}

TEST(NavigationHologramStream, StartedOnARunningLoopItPublishesTheMovingTools) {
  NavigationOptions o;
  o.hologram_forward_transforms = {"StylusToTracker"};
  NavigationLoop loop(o);
  loop.start();
  tracking::HologramModel model;
  model.name = "C5";
  model.frame = "Patient";
  model.mesh.vertices.resize(3, 3);
  model.mesh.vertices << 0, 0, 0, 10, 0, 0, 0, 10, 0;
  model.mesh.faces.resize(1, 3);
  model.mesh.faces << 0, 1, 2;
  const auto port = loop.streamHolograms({model}, 0);
  EXPECT_GT(port, 0);
  EXPECT_EQ(loop.status().hologram_port, port);

  std::mutex mutex;
  std::vector<Eigen::Matrix4d> stylus;
  igtlink::ClientOptions client_options;
  client_options.host = "127.0.0.1";
  client_options.port = port;
  igtlink::Client hmd(client_options);
  hmd.onMessage([&](const igtlink::Message& m) {
    if (m.header.type != "TRANSFORM" || m.header.device_name != "StylusToTracker") return;
    if (const auto* t = m.as<igtlink::TransformContent>()) {
      std::lock_guard lock(mutex);
      stylus.push_back(t->matrix);
    }
  });
  hmd.start();
  ASSERT_TRUE(waitFor(
      [&] {
        std::lock_guard lock(mutex);
        return stylus.size() >= 20;
      },
      4000ms))
      << "the stream sent no tracked transforms";
  EXPECT_GE(loop.status().hologram_clients, 1u);
  {
    // The simulated stylus pivots (and carries 0.25 mm noise): its pose changes between batches.
    std::lock_guard lock(mutex);
    double moved_mm = 0.0;
    for (const auto& m : stylus)
      moved_mm = std::max(moved_mm, (m.block<3, 1>(0, 3) - stylus.front().block<3, 1>(0, 3)).norm());
    EXPECT_GT(moved_mm, 0.1);
  }
  loop.stopHologramStream();
  EXPECT_EQ(loop.status().hologram_port, 0);
  const auto batches = loop.status().batches;
  EXPECT_TRUE(waitFor([&] { return loop.status().batches > batches + 3; }, 3000ms))
      << "navigation ended with the stream";
  hmd.stop();
  loop.stop();
}

}  // namespace
}  // namespace mrsns::workflow
