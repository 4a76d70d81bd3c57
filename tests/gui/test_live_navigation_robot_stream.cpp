// Live navigation on the real main window under Xvfb: the "Stop robot" button
// stops the arm through its supervisor while navigation goes on (tracking,
// recording, plots), Re-arm resumes; and the hologram stream button serves
// the navigation loop's live transforms to an OpenIGTLink client that cannot
// move or stop the robot.
#include <gtest/gtest.h>

#include <QLabel>
#include <QPushButton>
#include <QSpinBox>
#include <filesystem>
#include <mutex>
#include <thread>

#include "function_panel.h"
#include "gui_test_app.h"
#include "live_navigation.h"
#include "main_window.h"
#include "message_presenter.h"
#include "mrsns/core/error.h"
#include "mrsns/igtlink/client.h"
#include "mrsns/igtlink/server.h"
#include "mrsns/igtlink/string_message.h"
#include "mrsns/igtlink/transform.h"
#include "mrsns/workflow/navigation.h"
#include "mrsns/workflow/steps.h"
#include "output_panel.h"
#include "plot_widget.h"
#include "sample_window_fixture.h"
#include "test_data.h"

namespace {

using mrsns::gui::MainWindow;
using mrsns::gui::RecordingPresenter;
namespace fs = std::filesystem;

/// Robot in the loop with the watchdog and staleness limits loosened: on a
/// loaded test machine only what the test does may stop the arm (the
/// supervisor's own limits have their tests in tests/robot).
mrsns::workflow::NavigationOptions robotOptions() {
  mrsns::workflow::NavigationOptions options;
  options.robot.robot = "simulated";
  options.robot.max_missed_cycles = 5000;
  options.robot.max_cycle_time_s = 0.5;
  options.silence_timeout_s = 1.0;
  return options;
}

/// A port nobody listens on now (the OS picks it).
int freePort() {
  mrsns::igtlink::ServerOptions o;
  o.port = 0;
  mrsns::igtlink::Server probe(o);
  probe.start();
  const int port = probe.port();
  probe.stop();
  return port;
}

class LiveNavigationRobotStreamTest : public mrsns::test::SampleWindowTest {
 protected:
  LiveNavigationRobotStreamTest() : SampleWindowTest("gui-live-stream") {}
};

TEST_F(LiveNavigationRobotStreamTest, StopRobotStopsTheArmAndNavigationGoesOnThenReArmResumes) {
  if (!mrsns::test::haveSampleSession()) GTEST_SKIP() << "no bundled sample session";
  auto window = makeWindow();
  ASSERT_TRUE(window->openSampleSession()) << messages();
  ASSERT_TRUE(window->startNavigation(robotOptions())) << messages();
  auto* live = window->liveNavigation();
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return live->status().supervisor_state == "Advancing"; }, 15000))
      << "live->status().supervisor_state == \"Advancing\"";

  QTest::mouseClick(window->findChild<QPushButton*>("robotStop"), Qt::LeftButton);
  EXPECT_TRUE(window->navigating()) << "the operator's stop ended the navigation";
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return live->status().supervisor_state == "Paused"; }, 5000))
      << "live->status().supervisor_state == \"Paused\"";
  // stopJ brings the arm to rest; rest = below the supervisor's acknowledge threshold.
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return live->status().arm_speed_rad_s <= 1e-6; }, 5000))
      << "live->status().arm_speed_rad_s <= 1e-6";
  auto* output = window->outputPanel();
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return output->robotStopBanner().contains("operator"); }, 5000))
      << "output->robotStopBanner().contains(\"operator\")";
  // The banner adds the arm's time to rest, measured from the pause command.
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return output->robotStopBanner().contains("arm at rest"); }, 5000))
      << output->robotStopBanner().toStdString();
  EXPECT_FALSE(output->robotStopBanner().contains("stop sent")) << output->robotStopBanner().toStdString();
  const auto at_rest = live->status();
  EXPECT_TRUE(at_rest.operator_stopped);
  // Tracking, recording and the plots go on; the arm gets no motion command.
  const auto distance_points = output->distancePlot()->pointCount();
  ASSERT_TRUE(
      mrsns::test::waitUntil([&] { return live->status().frames_recorded > at_rest.frames_recorded + 20; }, 5000))
      << "live->status().frames_recorded > at_rest.frames_recorded + 20";
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return output->distancePlot()->pointCount() > distance_points; }, 5000))
      << "output->distancePlot()->pointCount() > distance_points";
  const auto later = live->status();
  EXPECT_TRUE(later.running);
  EXPECT_EQ(later.motion_commands, at_rest.motion_commands);
  EXPECT_LE(later.arm_speed_rad_s, 1e-6);
  EXPECT_TRUE(recorder_->messages.empty()) << messages();
  const auto png = mrsns::test::guiArtifactDir() / "main_window_navigation_operator_stop.png";
  ASSERT_TRUE(window->saveScreenshot(QString::fromStdString(png.string()))) << messages();

  // Re-arm: the placement resumes and the banner goes.
  auto* rearm = window->findChild<QPushButton*>("robotRearm");
  ASSERT_TRUE(rearm->isEnabled());
  QTest::mouseClick(rearm, Qt::LeftButton);
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return live->status().motion_commands > later.motion_commands; }, 5000))
      << "live->status().motion_commands > later.motion_commands";
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return output->robotStopBanner().isEmpty(); }, 5000))
      << "output->robotStopBanner().isEmpty()";
  EXPECT_FALSE(live->status().robot_stopped);

  window->stopNavigation();
  const auto record = window->sessionState()["steps"]["navigation"];
  EXPECT_EQ(record["status"], "ok") << record.dump();
  EXPECT_EQ(record["figures"]["robot"]["motion_commands_after_stop"].get<int>(), 0) << record.dump();
}

TEST_F(LiveNavigationRobotStreamTest, HologramStreamCarriesTheLiveTransformsAndClientsCannotMoveTheRobot) {
  if (!mrsns::test::haveSampleSession()) GTEST_SKIP() << "no bundled sample session";
  auto window = makeWindow();
  ASSERT_TRUE(window->openSampleSession()) << messages();
  const int port = freePort();
  window->findChild<QSpinBox*>("hologramPort")->setValue(port);
  QTest::mouseClick(window->findChild<QPushButton*>("hologramStream"), Qt::LeftButton);
  ASSERT_TRUE(window->hologramStreaming()) << messages();

  // Navigation takes the stream over on the same port.
  ASSERT_TRUE(window->startNavigation(robotOptions())) << messages();
  auto* live = window->liveNavigation();
  ASSERT_EQ(live->status().hologram_port, port) << messages();
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return live->status().supervisor_state == "Advancing"; }, 15000))
      << "live->status().supervisor_state == \"Advancing\"";

  std::mutex mutex;
  std::vector<Eigen::Matrix4d> stylus;
  bool got_model = false;
  mrsns::igtlink::ClientOptions client_options;
  client_options.host = "127.0.0.1";
  client_options.port = static_cast<std::uint16_t>(port);
  mrsns::igtlink::Client hmd(client_options);
  hmd.onMessage([&](const mrsns::igtlink::Message& m) {
    std::lock_guard lock(mutex);
    if (m.header.type == "POLYDATA") got_model = true;
    if (m.header.type != "TRANSFORM" || m.header.device_name != "StylusToTracker") return;
    if (const auto* t = m.as<mrsns::igtlink::TransformContent>()) stylus.push_back(t->matrix);
  });
  hmd.start();
  auto received = [&] {
    std::lock_guard lock(mutex);
    return stylus.size();
  };
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return received() >= 20; }, 10000)) << "received() >= 20";
  const auto before = live->status();
  const auto transitions = live->status().last_transition;

  // What a hostile or confused client could try: report the patient lost,
  // move the drill, send robot commands.
  Eigen::Isometry3d far = Eigen::Isometry3d::Identity();
  far.translation() << 500, 500, 500;
  for (int i = 0; i < 30; ++i) {
    auto lost =
        mrsns::igtlink::makeMessage("PatientToTracker", mrsns::igtlink::TransformContent::fromIsometry(far), 0.0);
    lost.metadata.push_back({"TransformStatus", mrsns::igtlink::kEncodingUsAscii, "INVALID"});
    EXPECT_TRUE(hmd.send(lost, mrsns::igtlink::HeaderVersion::kV2));
    EXPECT_TRUE(hmd.send(
        mrsns::igtlink::makeMessage("DrillToTracker", mrsns::igtlink::TransformContent::fromIsometry(far), 0.0)));
    EXPECT_TRUE(hmd.send(mrsns::igtlink::makeMessage(
        "CMD", mrsns::igtlink::StringContent{mrsns::igtlink::kEncodingUsAscii, "stopj(2)"})));
    std::this_thread::sleep_for(std::chrono::milliseconds(4));
  }
  const auto sent_before = received();
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return received() >= sent_before + 10; }, 10000))
      << "received() >= sent_before + 10";
  ASSERT_TRUE(
      mrsns::test::waitUntil([&] { return live->status().motion_commands > before.motion_commands + 10; }, 5000))
      << "live->status().motion_commands > before.motion_commands + 10";
  const auto after = live->status();
  EXPECT_FALSE(after.robot_stopped) << after.stop_reason;
  EXPECT_EQ(after.last_transition, transitions) << "a client's message changed the supervisor's state";
  EXPECT_GE(after.hologram_clients, 1u);
  EXPECT_TRUE(window->findChild<QLabel*>("hologramStatus")->text().contains("live tracking"))
      << window->findChild<QLabel*>("hologramStatus")->text().toStdString();
  {
    // The simulated stylus pivots (and has 0.25 mm noise): its pose changes.
    std::lock_guard lock(mutex);
    EXPECT_TRUE(got_model) << "the models were not sent";
    double moved_mm = 0.0;
    for (const auto& m : stylus) {
      moved_mm = std::max(moved_mm, (m.block<3, 1>(0, 3) - stylus.front().block<3, 1>(0, 3)).norm());
    }
    EXPECT_GT(moved_mm, 0.1);
  }
  hmd.stop();

  // After navigation the window serves the models again on the same port.
  window->stopNavigation();
  EXPECT_TRUE(window->hologramStreaming());
  EXPECT_TRUE(window->findChild<QPushButton*>("hologramStream")->isChecked());
  EXPECT_TRUE(recorder_->messages.empty()) << messages();
  window->stopHologramStream();
}

}  // namespace
