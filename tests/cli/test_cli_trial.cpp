// mrsns-cli trial: the whole phantom trial writes a report whose JSON has
// every figure the module steps produce, and an HTML page.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "cli_runner.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

TEST(CliTrial, ShortTrialReportHasEveryFigure) {
  const auto dir = scratchDirectory("trial") / "report";
  const auto r = runCli(
      {"trial", "--out", dir.string(), "--seed", "2", "--navigation-s", "1.2", "--deformation-cases", "1", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  const auto printed = nlohmann::json::parse(r.out);
  EXPECT_TRUE(printed["ok"].get<bool>());
  std::ifstream in(dir / "report.json");
  ASSERT_TRUE(in) << "no report.json";
  const auto report = nlohmann::json::parse(in);
  const auto& steps = report["steps"];
  const bool have_plus = findDataFile("plus/fCal_Test_Calibration_3NWires.igs.mha").has_value();
  // Each module's figures (JSON pointers into steps/<step>/figures).
  const std::vector<std::pair<std::string, std::vector<std::string>>> expected = {
      {"connect-devices", {"/rate_hz", "/tools/ProbeToTracker/ok"}},
      {"us-spatial-calibration",
       {"/validation/reprojection_3d_mean_mm", "/calibration/reprojection_3d_mean_mm", "/pixel_spacing_mm",
        "/transforms/ImageToProbe"}},
      {"us-temporal-calibration", {"/tracker_lag_ms", "/curve"}},
      {"robot-calibration", {"/fre_rms_mm", "/tre_at_patient_mm", "/transforms/RobotBaseToTracker"}},
      {"registration",
       {"/landmarks/fre_rms_mm", "/landmarks/tre/rms", "/surface/rms_mm", "/surface/tre/rms", "/targets",
        "/transforms/CTToPatient"}},
      {"hmd-calibration", {"/rigid_rms_mm", "/tre_at_patient_mm", "/transforms/HoloLensToTracker"}},
      {"navigation",
       {"/batches", "/frames_in_file", "/mean_loop_latency_ms", "/robot_stopped", "/stop_reason",
        "/deformation/posterior_sd_mean_mm", "/deformation/posterior_fp_mm", "/deformation/prior_sd_mean_mm",
        "/deformation/update_ms_p50"}},
      {"robot-placement", {"/entry_error_mm/mean", "/target_error_mm/mean", "/angle_error_deg/mean", "/paths"}},
  };
  for (const auto& [step, pointers] : expected) {
    SCOPED_TRACE(step);
    ASSERT_TRUE(steps.contains(step));
    if (!have_plus && step.rfind("us-", 0) == 0) {
      EXPECT_EQ(steps[step]["status"], "skipped");
      continue;
    }
    EXPECT_EQ(steps[step]["status"], "ok") << steps[step].dump();
    for (const auto& p : pointers) {
      EXPECT_TRUE(steps[step]["figures"].contains(nlohmann::json::json_pointer(p))) << p;
    }
  }
  // The simulated tracker loss stopped the robot, with the reason.
  EXPECT_TRUE(steps["navigation"]["figures"]["robot_stopped"].get<bool>());
  // Paper 001's figures are beside ours.
  EXPECT_EQ(report["paper"]["placement_distance_deviation_mm"]["mean"], 1.04);
  std::ifstream html(dir / "index.html");
  std::stringstream page;
  page << html.rdbuf();
  EXPECT_NE(page.str().find("Figures beside the papers"), std::string::npos);
  EXPECT_NE(page.str().find("1.04 &plusmn; 0.27"), std::string::npos);
  EXPECT_TRUE(std::filesystem::exists(dir / "session" / "session.json"));
}

TEST(CliTrial, RefusesANonEmptyReportFolder) {
  const auto dir = scratchDirectory("trial");
  std::ofstream(dir / "keep.txt") << "mine";
  const auto r = runCli({"trial", "--out", dir.string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("not empty"), std::string::npos) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir / "keep.txt"));
}

}  // namespace
}  // namespace mrsns::test
