// The live navigation view and the sample session at start, on the real main
// window under Xvfb: tools moving, a simulated tracker loss stopping the
// robot with its reason in the output area (no dialog), the recording intact,
// the plots filled from the run, and the sample's models facing the camera.
#include <gtest/gtest.h>

#include <QCheckBox>
#include <QLabel>
#include <QProcess>
#include <QProcessEnvironment>
#include <QPushButton>
#include <QRegularExpression>
#include <QSignalSpy>
#include <QStatusBar>
#include <filesystem>
#include <iostream>

#include "display_area.h"
#include "function_panel.h"
#include "gui_test_app.h"
#include "live_navigation.h"
#include "main_window.h"
#include "message_presenter.h"
#include "mrsns/core/error.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/rendering/scene.h"
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

/// Pixels of the planned screw paths' colour (0.30, 0.75, 0.95): blue over
/// green over red under any light, also behind the 25 % pink tissue
/// (0.75 * path + 0.25 * tissue keeps b > 1.4 r and g > 1.2 r), unlike bone,
/// the red vessel, the tissue alone and the grey-blue background (b/r ~1.5
/// but g/r ~1.17 and dark).
int countPathPixels(const QImage& image) {
  int count = 0;
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      const QColor c = image.pixelColor(x, y);
      if (c.blue() < 90) continue;
      const double r = std::max(c.red(), 1);
      if (c.blue() > 1.4 * r && c.green() > 1.25 * r) ++count;
    }
  }
  return count;
}

/// Fraction of pixels differing from the corner (background) colour.
double foregroundFraction(const QImage& image) {
  const QColor bg = image.pixelColor(0, 0);
  long long n = 0;
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      const QColor c = image.pixelColor(x, y);
      if (std::abs(c.red() - bg.red()) + std::abs(c.green() - bg.green()) + std::abs(c.blue() - bg.blue()) > 24) ++n;
    }
  }
  return static_cast<double>(n) / (static_cast<double>(image.width()) * image.height());
}

class LiveNavigationTest : public mrsns::test::SampleWindowTest {
 protected:
  LiveNavigationTest() : SampleWindowTest("gui-live") {}
};

TEST_F(LiveNavigationTest, TrackerLossStopsTheRobotAndTheOutputAreaSaysWhy) {
  if (!mrsns::test::haveSampleSession()) GTEST_SKIP() << "no bundled sample session";
  auto window = makeWindow();
  ASSERT_TRUE(window->openSampleSession()) << messages();
  // The patient reference marker vanishes 1.0 s in, for 1.5 s (the simulated
  // tracker reports it INVALID): the supervisor must stop the robot.
  // The loop's own supervisor (no robot arm): the robot_stopped flag.
  mrsns::workflow::NavigationOptions options;
  options.robot.robot = "none";
  options.devices.dropout_tool = "PatientToTracker";
  options.devices.dropout_start_s = 1.0;
  options.devices.dropout_duration_s = 1.5;
  ASSERT_TRUE(window->startNavigation(options)) << messages();
  EXPECT_TRUE(window->navigating());
  auto* toggle = window->findChild<QPushButton*>("navigationLive");
  ASSERT_NE(toggle, nullptr);
  EXPECT_TRUE(toggle->isChecked());
  // Steps wait while navigation records into the session.
  EXPECT_FALSE(window->findChild<QPushButton*>("step_registration")->isEnabled());

  // Tools are tracked and drawn before the loss.
  const auto& scene = window->displayArea()->scene();
  EXPECT_TRUE(scene.contains(mrsns::gui::kStylusObject));
  auto* output = window->outputPanel();
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return output->latencyPlot()->histogramCounts().size() > 0; }, 10000))
      << "no loop latency sample in the histogram";
  // Before the loss the tracked stylus is drawn where the tracker puts it.
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return window->outputPanel()->readout("tip_to_tissue") != "—"; }, 10000));
  // The simulated sweep's B-mode frames follow the tracked probe.
  EXPECT_TRUE(mrsns::test::waitUntil([&] { return scene.contains(mrsns::gui::kUltrasoundObject); }, 5000));
  if (window->displayArea()->hasOpenGlViews()) {
    const auto live_png = mrsns::test::guiArtifactDir() / "main_window_live_navigation.png";
    ASSERT_TRUE(window->saveScreenshot(QString::fromStdString(live_png.string()))) << messages();
    // The whole simulated room (fitted view): probe with its US slice, stylus, flange, drill.
    window->displayArea()->scene().resetCamera();
    window->displayArea()->renderScene();
    window->findChild<QWidget*>("view3d")->grab().toImage().save(
        QString::fromStdString((mrsns::test::guiArtifactDir() / "view3d_live_navigation_room.png").string()));
    window->displayArea()->resetCamera();
  }

  auto* banner = window->findChild<QLabel*>("navigationBanner");
  ASSERT_NE(banner, nullptr);
  EXPECT_FALSE(banner->isVisible());
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return output->robotStopBanner().contains("PatientToTracker"); }, 15000))
      << output->robotStopBanner().toStdString();
  EXPECT_TRUE(banner->isVisible());
  const QString text = output->robotStopBanner();
  EXPECT_TRUE(text.contains("ROBOT STOPPED")) << text.toStdString();
  // The time of the stop: a wall-clock time and the time since start, about
  // the dropout's start (1.0 s; the supervisor runs every batch or 20 ms).
  EXPECT_TRUE(text.contains(QRegularExpression("\\d\\d:\\d\\d:\\d\\d"))) << text.toStdString();
  const auto since = QRegularExpression("\\(([0-9.]+) s after start\\)").match(text);
  ASSERT_TRUE(since.hasMatch()) << text.toStdString();
  EXPECT_NEAR(since.captured(1).toDouble(), 1.0, 0.3) << text.toStdString();
  EXPECT_TRUE(output->readout("supervisor").contains("stopped")) << output->readout("supervisor").toStdString();
  // Dialog-free: nothing was presented to click away.
  EXPECT_TRUE(recorder_->messages.empty()) << messages();
  const auto png = mrsns::test::guiArtifactDir() / "main_window_navigation_robot_stopped.png";
  ASSERT_TRUE(window->saveScreenshot(QString::fromStdString(png.string()))) << messages();

  // Soft-tissue tracking runs from the loop's deformation hook: the model
  // error curve grows while navigating (the simulation takes a moment to build).
  EXPECT_TRUE(mrsns::test::waitUntil([&] { return output->deformationPlot()->pointCount() >= 12; }, 20000))
      << "no soft-tissue model error over time";
  // The tip-to-vessel curve has points from before the loss and, once the
  // patient reference is back (2.5 s), after it: a loaded machine may have
  // polled only a few times in the first second (the screenshots above).
  EXPECT_TRUE(mrsns::test::waitUntil([&] { return output->distancePlot()->pointCount() > 5; }, 15000))
      << "the tip-to-vessel distance curve stays short";

  QTest::mouseClick(toggle, Qt::LeftButton);
  EXPECT_FALSE(window->navigating());
  EXPECT_FALSE(toggle->isChecked());
  EXPECT_TRUE(window->findChild<QPushButton*>("step_registration")->isEnabled());
  EXPECT_FALSE(scene.contains(mrsns::gui::kStylusObject));

  // The run is the session's navigation step; its recording is intact.
  const auto state = window->sessionState();
  ASSERT_TRUE(state["steps"].contains("navigation"));
  const auto& record = state["steps"]["navigation"];
  EXPECT_EQ(record["status"], "ok") << record.dump();
  EXPECT_TRUE(record["figures"]["robot_stopped"].get<bool>());
  EXPECT_NE(record["figures"]["stop_reason"].get<std::string>().find("PatientToTracker"), std::string::npos);
  const fs::path recording = fs::path(window->sessionFolder().toStdString()) / record["outputs"][0].get<std::string>();
  ASSERT_TRUE(fs::exists(recording)) << recording;
  ASSERT_TRUE(fs::exists(fs::path(recording).replace_extension(".raw")));
  const auto header = mrsns::io::readSequenceHeader(recording);
  EXPECT_GT(header.frames.size(), 0u);
  // stop() syncs: every frame the loop appended is in the file.
  EXPECT_EQ(header.frames.size(), record["figures"]["frames_recorded"].get<std::size_t>());
  // Frames during the loss carry the patient reference as not OK.
  std::size_t invalid = 0;
  for (const auto& frame : header.frames) {
    const auto it = frame.transforms.find("PatientToTracker");
    if (it != frame.transforms.end() && it->second.status != mrsns::TransformStatus::Ok) ++invalid;
  }
  EXPECT_GT(invalid, 0u) << "the dropout is not in the recording";

  // The plots keep the run: latency histogram and tip-to-vessel distance over time.
  EXPECT_GT(output->latencyPlot()->histogramCounts().size(), 0u);
  EXPECT_EQ(output->distancePlot()->seriesCount(), 1);
  EXPECT_GT(output->distancePlot()->pointCount(), 5u);
  EXPECT_EQ(record["figures"]["tip_to_tissue_mm"].size(), output->distancePlot()->pointCount());
  // Per-frame posterior error against the simulation's ground truth, from
  // the prior (model mean) on; its convergence is test_live_deformation's.
  const auto& deformation = record["figures"]["deformation_error_mm"];
  ASSERT_GE(deformation.size(), 12u);
  EXPECT_EQ(deformation.size(), output->deformationPlot()->pointCount());
  EXPECT_EQ(deformation.size(), record["figures"]["deformation_error_mm_time_s"].size());
  EXPECT_EQ(deformation[0].get<double>(), record["figures"]["deformation_prior_error_mm"].get<double>());
  for (const auto& e : deformation) EXPECT_TRUE(e.get<double>() > 0.0 && e.get<double>() < 20.0) << e;
  EXPECT_TRUE(recorder_->messages.empty()) << messages();
}

TEST_F(LiveNavigationTest, WithTheRobotInTheLoopTheSupervisorStopsItAndTheBannerSaysWhy) {
  if (!mrsns::test::haveSampleSession()) GTEST_SKIP() << "no bundled sample session";
  auto window = makeWindow();
  ASSERT_TRUE(window->openSampleSession()) << messages();
  // The simulated UR5 follows the sample's first planned path; the patient
  // reference is lost 1.5 s in. Watchdog and staleness limits are loosened
  // so that a test machine's load cannot stop the arm first (the workflow
  // tests do the same); the loss is what must stop it.
  mrsns::workflow::NavigationOptions options;
  options.robot.robot = "simulated";
  options.robot.max_missed_cycles = 5000;
  options.robot.max_cycle_time_s = 0.5;
  options.silence_timeout_s = 1.0;
  options.devices.dropout_tool = "PatientToTracker";
  options.devices.dropout_start_s = 1.5;
  options.devices.dropout_duration_s = 3.0;  // still lost when Re-arm is clicked below
  ASSERT_TRUE(window->startNavigation(options)) << messages();
  EXPECT_TRUE(window->displayArea()->scene().contains(mrsns::gui::kDrillObject));
  auto* output = window->outputPanel();
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return output->robotStopBanner().contains("PatientToTracker"); }, 15000))
      << output->robotStopBanner().toStdString();
  EXPECT_TRUE(output->robotStopBanner().contains("PatientNotTracked")) << output->robotStopBanner().toStdString();
  // The supervisor's figures follow: the stop latency, then the arm at rest.
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return output->robotStopBanner().contains("arm at rest"); }, 5000))
      << output->robotStopBanner().toStdString();
  EXPECT_TRUE(output->robotStopBanner().contains("stop sent")) << output->robotStopBanner().toStdString();
  EXPECT_TRUE(output->navigationStatus().contains("robot Stopped")) << output->navigationStatus().toStdString();
  EXPECT_TRUE(recorder_->messages.empty()) << messages();

  const auto commands_at_rest = window->liveNavigation()->status().motion_commands;

  // Re-arm while the reference is still lost is refused (the status bar says
  // so) and, past several 50 ms polls, the banner stays, the supervisor is
  // still Stopped and no motion command went out.
  auto* rearm = window->findChild<QPushButton*>("robotRearm");
  ASSERT_NE(rearm, nullptr);
  ASSERT_TRUE(rearm->isEnabled());
  QTest::mouseClick(rearm, Qt::LeftButton);
  ASSERT_TRUE(
      mrsns::test::waitUntil([&] { return window->statusBar()->currentMessage().contains("Re-arm refused"); }, 5000))
      << window->statusBar()->currentMessage().toStdString();
  (void)mrsns::test::waitUntil([] { return false; }, 300);
  EXPECT_FALSE(output->robotStopBanner().isEmpty());
  EXPECT_TRUE(window->liveNavigation()->status().robot_stopped);
  EXPECT_EQ(window->liveNavigation()->status().supervisor_state, "Stopped");
  EXPECT_EQ(window->liveNavigation()->status().motion_commands, commands_at_rest);
  const auto png = mrsns::test::guiArtifactDir() / "main_window_navigation_supervisor_stop.png";
  ASSERT_TRUE(window->saveScreenshot(QString::fromStdString(png.string()))) << messages();

  window->stopNavigation();
  const auto record = window->sessionState()["steps"]["navigation"];
  const auto& robot = record["figures"]["robot"];
  EXPECT_EQ(robot["robot"], "simulated");
  EXPECT_EQ(robot["supervisor_stop"], "PatientNotTracked") << robot.dump();
  // Nothing moved the arm after the stop.
  EXPECT_EQ(robot["motion_commands_after_stop"].get<int>(), 0) << robot.dump();
  // The stop goes out within a few 2 ms control cycles of the lost sample's
  // arrival (modules/workflow measures ~1 cycle); 100 ms would be a broken feed.
  ASSERT_TRUE(robot["stop_latency_ms"].is_number()) << robot.dump();
  EXPECT_LT(robot["stop_latency_ms"].get<double>(), 100.0) << robot.dump();
  const fs::path recording = fs::path(window->sessionFolder().toStdString()) / record["outputs"][0].get<std::string>();
  EXPECT_GT(mrsns::io::readSequenceHeader(recording).frames.size(), 0u);
}

TEST_F(LiveNavigationTest, RefusedWithoutASessionWithAMessageAndTheButtonBackOff) {
  auto window = makeWindow();
  auto* toggle = window->findChild<QPushButton*>("navigationLive");
  ASSERT_NE(toggle, nullptr);
  QTest::mouseClick(toggle, Qt::LeftButton);
  EXPECT_FALSE(window->navigating());
  EXPECT_FALSE(toggle->isChecked());
  ASSERT_EQ(recorder_->messages.size(), 1u);
  EXPECT_TRUE(recorder_->messages.back().text.contains("session")) << messages();
  // A bad device option is refused before anything runs.
  ASSERT_TRUE(window->createSession(QString::fromStdString((scratch_ / "session").string())));
  mrsns::workflow::NavigationOptions options;
  options.devices.source = "no-such-tracker";
  EXPECT_FALSE(window->startNavigation(options));
  EXPECT_FALSE(toggle->isChecked());
  ASSERT_EQ(recorder_->messages.size(), 2u);
  EXPECT_TRUE(recorder_->messages.back().text.contains("no-such-tracker")) << messages();

  // While navigation records into the session, other work on sessions waits.
  mrsns::workflow::NavigationOptions ok_options;
  ok_options.robot.robot = "none";
  ASSERT_TRUE(window->startNavigation(ok_options)) << messages();
  EXPECT_TRUE(toggle->isChecked());
  EXPECT_FALSE(window->openSampleSession());
  EXPECT_FALSE(window->runStep("registration"));
  ASSERT_EQ(recorder_->messages.size(), 4u) << messages();
  EXPECT_TRUE(recorder_->messages.back().text.contains("Stop it first")) << messages();
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return window->liveNavigation()->status().batches > 0; }, 10000));
  window->stopNavigation();
  EXPECT_FALSE(toggle->isChecked());
  EXPECT_EQ(window->sessionState()["steps"]["navigation"]["status"], "ok");
}

TEST_F(LiveNavigationTest, SampleSessionOpensWithItsModelsAndThePlannedPathsInView) {
  if (!mrsns::test::haveSampleSession()) GTEST_SKIP() << "no bundled sample session";
  auto window = makeWindow();
  ASSERT_TRUE(window->openSampleSession()) << messages();
  const auto& scene = window->displayArea()->scene();
  for (const char* name :
       {"vertebra:C3", "vertebra:C7", "tissue:carotid_artery", "path:C5 left", "path:C6 right"}) {
    EXPECT_TRUE(scene.contains(name)) << name << " not in the scene at open";
  }
  if (!window->displayArea()->hasOpenGlViews()) GTEST_SKIP() << "no OpenGL views on this platform";
  window->displayArea()->render();
  const QImage view = window->findChild<QWidget*>("view3d")->grab().toImage();
  const auto png = mrsns::test::guiArtifactDir() / "view3d_sample_session_at_open.png";
  view.save(QString::fromStdString(png.string()));
  // The neck fills a good part of the view and the four screw paths show
  // (each 3.5 mm wide and ~30 mm long: hundreds of pixels when in view).
  EXPECT_GT(foregroundFraction(view), 0.2);
  const int path_pixels = countPathPixels(view);
  EXPECT_GT(path_pixels, 400) << "planned paths hidden in the home view";
  // Hiding the paths removes that colour: it is theirs, not something else's.
  window->findChild<QCheckBox*>("layerPaths")->setChecked(false);
  window->displayArea()->render();
  EXPECT_LT(countPathPixels(window->findChild<QWidget*>("view3d")->grab().toImage()), path_pixels / 10);
  window->findChild<QCheckBox*>("layerPaths")->setChecked(true);
}

TEST_F(LiveNavigationTest, ExecutableWithoutArgumentsOpensTheSampleSession) {
  if (!mrsns::test::haveSampleSession()) GTEST_SKIP() << "no bundled sample session";
  const auto png = mrsns::test::guiArtifactDir() / "mrsns_no_arguments.png";
  fs::remove(png);
  QProcess process;
  // A fresh install: an empty data folder, so the sample is copied and prepared.
  QProcessEnvironment env = QProcessEnvironment::systemEnvironment();
  env.insert("XDG_DATA_HOME", QString::fromStdString((scratch_ / "xdg-data").string()));
  env.insert("XDG_CONFIG_HOME", QString::fromStdString((scratch_ / "xdg-config").string()));
  process.setProcessEnvironment(env);
  process.start(QStringLiteral(MRSNS_GUI_BINARY),
                {"--screenshot", QString::fromStdString(png.string()), "--size", "1280x800"});
  ASSERT_TRUE(process.waitForFinished(60000));
  const QString err = QString::fromLocal8Bit(process.readAllStandardError());
  EXPECT_EQ(process.exitCode(), 0) << err.toStdString();
  EXPECT_TRUE(err.contains("sample-session")) << err.toStdString();
  EXPECT_TRUE(
      fs::exists(scratch_ / "xdg-data" / "MR-SNS" / "mrsns" / "sample-session" / "models" / "C5.vtp"));
  const QImage image(QString::fromStdString(png.string()));
  ASSERT_FALSE(image.isNull()) << err.toStdString();
  EXPECT_EQ(image.size(), QSize(1280, 800));
}

}  // namespace
