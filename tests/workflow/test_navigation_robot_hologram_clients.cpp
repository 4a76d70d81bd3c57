// The hologram stream is send-only: an HMD client that sends transforms or commands to the navigation
// loop's OpenIGTLink server while the robot advances neither moves nor stops it, and does not touch the
// tracking the supervisor reads.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "mrsns/igtlink/client.h"
#include "mrsns/igtlink/string_message.h"
#include "mrsns/workflow/navigation.h"
#include "wait_for.h"

namespace mrsns::workflow {
namespace {

using ::mrsns::test::waitFor;

using namespace std::chrono_literals;

TEST(NavigationRobotHologramClients, ClientMessagesNeitherMoveNorStopTheRobot) {
  NavigationOptions o;
  o.robot.robot = "simulated";
  o.robot.max_cycle_time_s = 0.2;  // stops here could only come from tracking (the watchdog has its own tests)
  o.robot.max_missed_cycles = 200;
  o.silence_timeout_s = 1.0;  // nor from a tracker thread starved on an overloaded machine
  o.stream_holograms = true;
  tracking::HologramModel model;
  model.name = "C5";
  model.frame = "Patient";
  model.mesh.vertices.resize(3, 3);
  model.mesh.vertices << 0, 0, 0, 10, 0, 0, 0, 10, 0;
  model.mesh.faces.resize(1, 3);
  model.mesh.faces << 0, 1, 2;
  NavigationLoop loop(o, {model});
  loop.start();
  ASSERT_TRUE(waitFor([&] { return loop.status().supervisor_state == "Advancing"; }, 4000ms))
      << loop.status().last_transition;
  const auto before = loop.robotTransitions().size();

  igtlink::ClientOptions client_options;
  client_options.port = loop.status().hologram_port;
  igtlink::Client hmd(client_options);
  hmd.start();
  ASSERT_TRUE(waitFor([&] { return hmd.connected(); }, 2000ms));
  // What a hostile or confused client could try: report the patient lost, move the drill, send commands.
  Eigen::Isometry3d far = Eigen::Isometry3d::Identity();
  far.translation() << 500, 500, 500;
  for (int i = 0; i < 50; ++i) {
    auto lost = igtlink::makeMessage("PatientToTracker", igtlink::TransformContent::fromIsometry(far), 0.0);
    lost.metadata.push_back({"TransformStatus", igtlink::kEncodingUsAscii, "INVALID"});
    EXPECT_TRUE(hmd.send(lost, igtlink::HeaderVersion::kV2));
    EXPECT_TRUE(hmd.send(igtlink::makeMessage("DrillToTracker", igtlink::TransformContent::fromIsometry(far), 0.0)));
    EXPECT_TRUE(hmd.send(igtlink::makeMessage("CMD", igtlink::StringContent{igtlink::kEncodingUsAscii, "stopj(2)"})));
    std::this_thread::sleep_for(4ms);
  }
  const auto motion_before = loop.status().motion_commands;
  std::this_thread::sleep_for(300ms);
  const auto s = loop.status();
  hmd.stop();
  loop.stop();
  EXPECT_FALSE(s.robot_stopped) << s.stop_reason;
  EXPECT_EQ(s.supervisor_state, "Advancing");
  EXPECT_EQ(loop.robotTransitions().size(), before) << s.last_transition;
  EXPECT_GT(s.motion_commands, motion_before) << "the guidance kept commanding the advance";
  EXPECT_TRUE(loop.repository().getTransform("PatientToTracker").ok());
}

}  // namespace
}  // namespace mrsns::workflow
