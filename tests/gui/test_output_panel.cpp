#include <gtest/gtest.h>

#include <QLabel>
#include <QTreeWidget>
#include <cmath>
#include <numeric>

#include "gui_test_app.h"
#include "output_panel.h"
#include "plot_widget.h"
#include "step_list.h"

using mrsns::gui::formatFigure;
using mrsns::gui::OutputPanel;

TEST(OutputPanel, FormatsFiguresWithTheUnitOfTheirSuffix) {
  EXPECT_EQ(formatFigure("fre_mm", 0.41234), QStringLiteral("0.412 mm"));
  EXPECT_EQ(formatFigure("angle_deg", 12.345), QStringLiteral("12.35°"));
  EXPECT_EQ(formatFigure("offset_s", -0.0123), QStringLiteral("-0.012 s"));
  EXPECT_EQ(formatFigure("latency_ms", 123.45), QStringLiteral("123.5 ms"));
  EXPECT_EQ(formatFigure("frames", 42), QStringLiteral("42"));
  EXPECT_EQ(formatFigure("ok", true), QStringLiteral("yes"));
  EXPECT_EQ(formatFigure("state", "halted"), QStringLiteral("halted"));
  EXPECT_EQ(formatFigure("size_px", nlohmann::json::array({40, 36, 24})), QStringLiteral("40, 36, 24 px"));
  EXPECT_EQ(formatFigure("list", nlohmann::json::array({1, 2, 3, 4, 5})), QStringLiteral("[5 values]"));
  EXPECT_EQ(formatFigure("nan_mm", std::nan("")), QStringLiteral("—"));
}

TEST(OutputPanel, ALiveRegistrationShowsItsPredictedTreAndNoStaleOne) {
  mrsns::test::guiApp();
  OutputPanel panel;
  panel.showStepResult("registration", "ok", {{"surface", {{"tre", {{"rms", 0.04}}}}}});
  EXPECT_EQ(panel.readout("tre"), QStringLiteral("0.040 mm"));
  // Acquired from the devices there is no truth to measure the TRE against: the predicted one, said so.
  panel.showStepResult("registration", "ok",
                       {{"landmarks", {{"fre_rms_mm", 0.23}}}, {"tre_predicted_at_screws", {{"rms", 0.137}}}});
  EXPECT_EQ(panel.readout("fre"), QStringLiteral("0.230 mm"));
  EXPECT_EQ(panel.readout("tre"), QStringLiteral("0.137 mm (predicted)"));
  panel.showStepResult("registration", "failed", {{"landmarks", {{"matched", 2}}}});
  EXPECT_EQ(panel.readout("tre"), QStringLiteral("—")) << "not the earlier registration's";
}

TEST(OutputPanel, StepFiguresReachReadoutsTreeAndPlots) {
  mrsns::test::guiApp();
  OutputPanel panel;
  EXPECT_EQ(panel.readout("fre"), QStringLiteral("—"));
  panel.showStepResult("registration", "ok", {{"fre_mm", 0.5}, {"tre_mm", 1.25}, {"points", 6}});
  EXPECT_EQ(panel.readout("fre"), QStringLiteral("0.500 mm"));
  EXPECT_EQ(panel.readout("tre"), QStringLiteral("1.250 mm"));
  // Another step's "rms" must not overwrite the registration read-outs.
  panel.showStepResult("us-spatial-calibration", "ok", {{"rms_mm", 0.8}, {"residuals_mm", {0.7, 0.9, 0.8, 0.75}}});
  EXPECT_EQ(panel.readout("fre"), QStringLiteral("0.500 mm"));
  EXPECT_EQ(panel.readout("us_calibration"), QStringLiteral("0.800 mm"));
  EXPECT_EQ(panel.residualPlot()->pointCount(), 4u);
  panel.showStepResult("us-temporal-calibration", "ok", {{"offset_s", -0.05}});
  EXPECT_EQ(panel.readout("temporal_offset"), QStringLiteral("-0.050 s"));

  auto* tree = panel.findChild<QTreeWidget*>("outputFigures");
  ASSERT_NE(tree, nullptr);
  EXPECT_EQ(tree->topLevelItemCount(), 3);
  // Re-running a step replaces its rows instead of adding a second entry.
  panel.showStepResult("registration", "ok", {{"fre_mm", 0.4}});
  EXPECT_EQ(tree->topLevelItemCount(), 3);
  EXPECT_EQ(panel.readout("fre"), QStringLiteral("0.400 mm"));
}

TEST(OutputPanel, LiveSamplesColourTheDistanceBySeverity) {
  mrsns::test::guiApp();
  OutputPanel panel;
  panel.showLiveSample(0.0, 8.0, 20.0, "ok");
  auto* distance = panel.findChild<QLabel*>("output_tip_to_tissue");
  ASSERT_NE(distance, nullptr);
  EXPECT_EQ(distance->property("severity").toInt(), 0);
  panel.showLiveSample(0.1, 1.5, 25.0, "halted: tracking lost");
  EXPECT_EQ(distance->property("severity").toInt(), 2);
  EXPECT_EQ(panel.readout("supervisor"), QStringLiteral("halted: tracking lost"));
  EXPECT_EQ(panel.findChild<QLabel*>("output_supervisor")->property("severity").toInt(), 2);
  EXPECT_EQ(panel.distancePlot()->pointCount(), 2u);
  const auto& counts = panel.latencyPlot()->histogramCounts();
  EXPECT_EQ(std::accumulate(counts.begin(), counts.end(), 0), 2);
}

TEST(OutputPanel, SessionStateShowsEveryRecordedStep) {
  mrsns::test::guiApp();
  OutputPanel panel;
  const nlohmann::json state = {
      {"version", 1},
      {"steps",
       {{"registration", {{"status", "ok"}, {"figures", {{"fre_mm", 0.3}}}}},
        {"navigation", {{"status", "ok"}, {"figures", {{"latency_ms", {10.0, 12.0, 11.0}}}}}}}}};
  panel.showSessionState(state);
  EXPECT_EQ(panel.readout("fre"), QStringLiteral("0.300 mm"));
  EXPECT_EQ(panel.findChild<QTreeWidget*>("outputFigures")->topLevelItemCount(), 2);
  const auto& counts = panel.latencyPlot()->histogramCounts();
  EXPECT_EQ(std::accumulate(counts.begin(), counts.end(), 0), 3);
  panel.showSessionState(nlohmann::json::object());  // a fresh session: everything cleared
  EXPECT_EQ(panel.readout("fre"), QStringLiteral("—"));
}

TEST(OutputPanel, NestedWorkflowFiguresFillReadoutsAndCurves) {
  mrsns::test::guiApp();
  OutputPanel panel;
  // The shapes mrsns::workflow records (registration, temporal calibration, navigation).
  panel.showStepResult(
      "registration", "ok",
      {{"landmarks", {{"fre_rms_mm", 0.41}, {"fre_expected_mm", 0.5}}},
       {"surface", {{"rms_mm", 0.3}, {"tre", {{"rms", 0.92}, {"max", 1.4}}}}},
       {"targets", {{{"name", "C5L"}, {"tre_surface_mm", 0.8}}, {{"name", "C5R"}, {"tre_surface_mm", 1.0}}}}});
  EXPECT_EQ(panel.readout("fre"), QStringLiteral("0.410 mm"));
  EXPECT_EQ(panel.readout("tre"), QStringLiteral("0.920 mm"));
  EXPECT_EQ(panel.residualPlot()->pointCount(), 2u);  // TRE per target
  panel.showStepResult("us-temporal-calibration", "ok",
                       {{"tracker_lag_ms", -12.5},
                        {"curve",
                         {{{"lag_ms", -20.0}, {"reprojection_3d_mean_mm", 1.6}},
                          {{"lag_ms", -10.0}, {"reprojection_3d_mean_mm", 1.2}},
                          {{"lag_ms", 0.0}, {"reprojection_3d_mean_mm", 1.5}}}}});
  EXPECT_EQ(panel.readout("temporal_offset"), QStringLiteral("-12.50 ms"));
  EXPECT_EQ(panel.residualPlot()->pointCount(), 3u);  // the lag curve replaced the targets
  panel.showStepResult("navigation", "ok",
                       {{"mean_loop_latency_ms", 4.2},
                        {"robot_stopped", true},
                        {"stop_reason", "tracking lost"},
                        {"deformation", {{"posterior_sd_mean_mm", 1.5}, {"paper_posterior_sd_mean_mm", 1.52}}}});
  EXPECT_EQ(panel.readout("latency"), QStringLiteral("4.20 ms"));
  EXPECT_EQ(panel.readout("supervisor"), QStringLiteral("robot stopped: tracking lost"));
  EXPECT_EQ(panel.findChild<QLabel*>("output_supervisor")->property("severity").toInt(), 2);
  EXPECT_EQ(panel.readout("deformation"), QStringLiteral("1.500 mm"));
}

TEST(OutputPanel, SeriesOfASubResultReachThePlots) {
  mrsns::test::guiApp();
  OutputPanel panel;
  // A step whose deformation figures carry a per-frame error curve and whose
  // loop reports per-batch latencies: the plots fill from them.
  const nlohmann::json figures = {{"batches", 4},
                                  {"loop_latency_ms", {0.2, 0.3, 0.25, 0.4}},
                                  {"deformation",
                                   {{"posterior_sd_mean_mm", 1.2},
                                    {"error_per_frame_mm", {2.6, 2.4, 2.0, 1.7, 1.6}},
                                    {"error_per_frame_mm_time_s", {0.0, 0.05, 0.1, 0.15, 0.2}}}},
                                  {"transforms", {{"CTToPatient", {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}}}}};
  panel.showStepResult("navigation", "ok", figures);
  const auto& counts = panel.latencyPlot()->histogramCounts();
  EXPECT_EQ(std::accumulate(counts.begin(), counts.end(), 0), 4);
  EXPECT_EQ(panel.deformationPlot()->seriesCount(), 1);
  EXPECT_EQ(panel.deformationPlot()->pointCount(), 5u);
  // A matrix is not a curve.
  EXPECT_EQ(panel.residualPlot()->pointCount(), 0u);
  EXPECT_EQ(panel.readout("deformation"), QStringLiteral("1.200 mm"));
}

TEST(OutputPanel, RobotStopBannerShowsTheReasonAndTheTimeUntilCleared) {
  mrsns::test::guiApp();
  OutputPanel panel;
  panel.show();
  auto* banner = panel.findChild<QLabel*>("navigationBanner");
  ASSERT_NE(banner, nullptr);
  EXPECT_FALSE(banner->isVisible());
  EXPECT_TRUE(panel.robotStopBanner().isEmpty());
  panel.showRobotStop("tracking lost: PatientToTracker INVALID", "12:00:01.250 (1.25 s after start)");
  EXPECT_TRUE(banner->isVisible());
  EXPECT_TRUE(panel.robotStopBanner().contains("PatientToTracker INVALID"));
  EXPECT_TRUE(panel.robotStopBanner().contains("12:00:01.250"));
  EXPECT_EQ(panel.findChild<QLabel*>("output_supervisor")->property("severity").toInt(), 2);
  panel.beginLiveNavigation();  // a new run starts without the old banner
  EXPECT_FALSE(banner->isVisible());
  EXPECT_TRUE(panel.robotStopBanner().isEmpty());
}

// The step row shows the figure that judges the step: for a calibration
// with a held-out set, its validation error, not the fitted set's.
TEST(OutputPanel, StepHeadlinePrefersTheValidationFigure) {
  const nlohmann::json us = {{"calibration", {{"reprojection_3d_mean_mm", 1.148}}},
                             {"validation", {{"reprojection_3d_mean_mm", 1.191}}},
                             {"tracker_lag_ms", 0.0}};
  EXPECT_EQ(mrsns::gui::stepHeadline(us), QStringLiteral("1.19 mm"));
  EXPECT_EQ(mrsns::gui::stepHeadline({{"landmarks", {{"fre_rms_mm", 0.245}}}}), QStringLiteral("0.245 mm"));
  EXPECT_EQ(mrsns::gui::stepHeadline({{"tracker_lag_ms", 512.0}}), QStringLiteral("512.0 ms"));
}
