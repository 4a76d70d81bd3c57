// `mrsns-cli robot-trial` (one trial, JSON with the deviations, noise model and stops; bad values are
// errors, bad syntax usage errors) and `mrsns-cli robot-calibrate` on a synthetic station file with a
// known answer.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "cli_runner.h"
#include "mrsns/core/rigid.h"
#include "mrsns/io/pose_csv.h"
#include "test_data.h"

namespace {

using mrsns::test::runCli;

TEST(CliRobotTrial, OneTrialPrintsDeviationsNoiseModelAndStops) {
  const auto r = runCli({"robot-trial", "--trials", "1", "--seed", "2", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["verb"], "robot-trial");
  EXPECT_EQ(j["placements"], 2);
  for (const char* key : {"distance_deviation_mm", "angle_deviation_deg"}) {
    ASSERT_TRUE(j[key].contains("mean")) << key;
    ASSERT_TRUE(j[key].contains("std")) << key;
    EXPECT_GE(j[key]["mean"].get<double>(), 0.0);
  }
  EXPECT_TRUE(j["stops"].contains("total"));
  EXPECT_TRUE(j["stops"]["by_reason"].is_object());
  EXPECT_DOUBLE_EQ(j["noise_model"]["tracking_noise_rms_mm"].get<double>(), 0.35);
  EXPECT_EQ(j["per_placement"].size(), 2u);
  EXPECT_EQ(j["paper"]["distance_deviation_mm"]["mean"], 1.04);
}

TEST(CliRobotTrial, BadValuesAreErrorsAndBadSyntaxIsUsage) {
  auto r = runCli({"robot-trial", "--trials", "0", "--json"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("trials"), std::string::npos) << r.err;
  EXPECT_TRUE(r.out.empty());
  r = runCli({"robot-trial", "--trials", "many"});
  EXPECT_EQ(r.exit_code, 2);
}

TEST(CliRobotCalibrate, RecoversKnownTransformsFromStationPairs) {
  // Stations: flange rotations about well-spread axes; the tracker sees the marker exactly.
  Eigen::Isometry3d flange_T_marker = Eigen::Isometry3d::Identity();
  flange_T_marker.linear() = mrsns::so3Exp(Eigen::Vector3d(0.2, -0.4, 0.9));
  flange_T_marker.translation() << 30, 40, 80;
  Eigen::Isometry3d base_T_tracker = Eigen::Isometry3d::Identity();
  base_T_tracker.linear() = mrsns::so3Exp(Eigen::Vector3d(0.1, 1.9, 0.3));
  base_T_tracker.translation() << -500, 1000, 600;
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Eigen::Isometry3d> rows;
  for (int i = 0; i < 10; ++i) {
    Eigen::Isometry3d b = Eigen::Isometry3d::Identity();
    b.linear() = mrsns::so3Exp(0.5 * Eigen::Vector3d(u(rng), u(rng), u(rng)));
    b.translation() << -400 + 50 * u(rng), -200 + 50 * u(rng), 300 + 50 * u(rng);
    rows.push_back(b);
    rows.push_back(base_T_tracker.inverse() * b * flange_T_marker);
  }
  const auto dir = mrsns::test::scratchDirectory("robot_calibrate");
  const auto file = dir / "stations.csv";
  mrsns::io::writePoseCsv(file, rows);
  auto r = runCli({"robot-calibrate", "--poses", file.string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["stations"], 10);
  // The CSV keeps ~1e-6 relative precision, so the answer holds to ~1e-3 mm.
  const auto m = j["MarkerToFlange"].get<std::vector<double>>();
  ASSERT_EQ(m.size(), 16u);
  EXPECT_NEAR(m[3], 30, 1e-3);
  EXPECT_NEAR(m[7], 40, 1e-3);
  EXPECT_NEAR(m[11], 80, 1e-3);
  const auto t = j["TrackerToBase"].get<std::vector<double>>();
  EXPECT_NEAR(t[3], -500, 1e-2);
  EXPECT_NEAR(t[7], 1000, 1e-2);
  EXPECT_LT(j["residual_rms_mm"].get<double>(), 1e-2);
  EXPECT_EQ(j["residuals"].size(), 10u);

  // An odd number of poses cannot be paired; a degenerate (single-axis) set is refused.
  rows.pop_back();
  mrsns::io::writePoseCsv(dir / "odd.csv", rows);
  r = runCli({"robot-calibrate", "--poses", (dir / "odd.csv").string(), "--json"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("pairs"), std::string::npos) << r.err;
  rows.clear();
  for (int i = 0; i < 8; ++i) {
    Eigen::Isometry3d b = Eigen::Isometry3d::Identity();
    b.linear() = mrsns::so3Exp(Eigen::Vector3d(0, 0, 0.3 * i));
    rows.push_back(b);
    rows.push_back(base_T_tracker.inverse() * b * flange_T_marker);
  }
  mrsns::io::writePoseCsv(dir / "one_axis.csv", rows);
  r = runCli({"robot-calibrate", "--poses", (dir / "one_axis.csv").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("degenerate"), std::string::npos) << r.err;
  r = runCli({"robot-calibrate"});
  EXPECT_EQ(r.exit_code, 2);
}

}  // namespace
