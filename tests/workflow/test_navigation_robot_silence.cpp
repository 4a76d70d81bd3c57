// A tracker that stays connected but falls silent (a PlusServer whose tracker stopped sending) must stop
// the robot too: the poses age past the supervisor's limit, or the source marks them stale, while the
// connection itself is fine. The PlusServer here is an in-process OpenIGTLink server.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "mrsns/igtlink/server.h"
#include "mrsns/workflow/navigation.h"
#include "mrsns/core/wall_clock.h"

namespace mrsns::workflow {
namespace {

using namespace std::chrono_literals;

igtlink::Message plusTransform(const std::string& name, const Eigen::Isometry3d& pose, double t) {
  auto m = igtlink::makeMessage(name, igtlink::TransformContent::fromIsometry(pose), t);
  m.metadata.push_back({"TransformStatus", igtlink::kEncodingUsAscii, "OK"});
  return m;
}

TEST(NavigationRobotSilence, ASilentButConnectedTrackerStopsTheArmAsATrackingLoss) {
  igtlink::ServerOptions server_options;
  server_options.port = 0;
  igtlink::Server server(server_options);
  server.start();
  std::atomic<bool> streaming{true}, quit{false};
  std::thread plus([&] {
    // PlusServer at 60 Hz: the patient reference still, the probe 40 mm beside it.
    Eigen::Isometry3d patient = Eigen::Isometry3d::Identity(), probe = Eigen::Isometry3d::Identity();
    patient.translation() << 0, 0, -1000;
    probe.translation() << 40, 0, -990;
    while (!quit) {
      if (streaming) {
        const double t = unixTimeSeconds();
        server.broadcast(plusTransform("PatientToTracker", patient, t), igtlink::HeaderVersion::kV2,
                         igtlink::Channel::Stream);
        server.broadcast(plusTransform("ProbeToTracker", probe, t), igtlink::HeaderVersion::kV2,
                         igtlink::Channel::Stream);
      }
      std::this_thread::sleep_for(16ms);
    }
  });

  NavigationOptions o;
  o.devices.source = "plus";
  o.devices.port = server.port();
  o.robot.robot = "simulated";
  o.robot.max_cycle_time_s = 0.2;  // stops here must come from tracking (the watchdog is tested in tests/robot)
  o.robot.max_missed_cycles = 200;
  NavigationLoop loop(o);
  loop.start();
  const auto until = [&](const std::function<bool()>& done, std::chrono::milliseconds deadline) {
    const auto end = std::chrono::steady_clock::now() + deadline;
    while (!done() && std::chrono::steady_clock::now() < end) std::this_thread::sleep_for(5ms);
    return done();
  };
  const bool advancing = until([&] { return loop.status().supervisor_state == "Advancing"; }, 6000ms);
  streaming = false;  // the tracker goes silent; the connection stays up
  const bool stopped = until([&] { return loop.status().robot_stopped; }, 3000ms);
  const auto s = loop.status();
  const auto log = loop.robotTransitions();
  loop.stop();
  quit = true;
  plus.join();
  server.stop();

  ASSERT_TRUE(advancing) << s.supervisor_state << " " << s.last_transition;
  ASSERT_TRUE(stopped) << s.supervisor_state;
  const NavigationRobotTransition* stop = nullptr;
  for (const auto& t : log) {
    if (!stop && t.to == "Stopped") stop = &t;
  }
  ASSERT_NE(stop, nullptr);
  EXPECT_EQ(stop->from, "Advancing");
  // Which check fires first depends on the source's own stale timer (0.2 s) against the supervisor's age
  // limit (0.25 s); both are tracking losses, none is a disconnection.
  EXPECT_TRUE(stop->reason == "PatientStale" || stop->reason == "ToolStale" || stop->reason == "PatientNotTracked" ||
              stop->reason == "ToolNotTracked")
      << stop->reason << ": " << stop->detail;
  EXPECT_EQ(s.source.state, tracking::SourceState::Running) << "still connected";
}

}  // namespace
}  // namespace mrsns::workflow
