// calibrate-pivot, calibrate-spin and register-points through the real
// binary: synthetic inputs written to files, and the real PLUS recording.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "cli_runner.h"
#include "mrsns/core/rigid.h"
#include "mrsns/io/pose_csv.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// Pivoting poses about a tip at (5, -3, 150) in the marker frame, 0.2 mm 3D
// RMS position noise.
std::filesystem::path writePivotCsv(const std::filesystem::path& dir, double max_tilt, const std::string& name) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 0.2 / std::sqrt(3.0));
  const Eigen::Vector3d tip(5, -3, 150);
  const Eigen::Vector3d pivot(10, 20, -900);
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i < 120; ++i) {
    Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
    p.linear() = so3Exp(Eigen::Vector3d(max_tilt * uniform(rng), max_tilt * uniform(rng), 0.0));
    p.translation() = pivot - p.linear() * tip + Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng));
    poses.push_back(p);
  }
  const auto path = dir / name;
  io::writePoseCsv(path, poses);
  return path;
}

TEST(CliCalibratePivot, CsvPosesGiveTipAndQualityFigures) {
  const auto dir = scratchDirectory("pivot");
  const auto csv = writePivotCsv(dir, 30 * kDeg, "pivot.csv");
  const auto tfm = dir / "TipToStylus.tfm";
  const auto result = runCli({"calibrate-pivot", "--csv", csv.string(), "--output", tfm.string(), "--json"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const auto json = nlohmann::json::parse(result.out);
  EXPECT_NEAR(json["tip_marker_mm"][0].get<double>(), 5.0, 0.3);
  EXPECT_NEAR(json["tip_marker_mm"][1].get<double>(), -3.0, 0.3);
  EXPECT_NEAR(json["tip_marker_mm"][2].get<double>(), 150.0, 0.3);
  EXPECT_LT(json["rms_mm"].get<double>(), 0.3);
  EXPECT_GT(json["rotation_range_deg"].get<double>(), 20.0);
  EXPECT_EQ(json["residuals_mm"].size(), 120u);
  EXPECT_TRUE(std::filesystem::exists(tfm));
}

TEST(CliCalibratePivot, StaticToolIsRefusedWithExitOne) {
  const auto dir = scratchDirectory("pivot");
  const auto csv = writePivotCsv(dir, 0.5 * kDeg, "static.csv");
  const auto result = runCli({"calibrate-pivot", "--csv", csv.string(), "--json"});
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_TRUE(result.out.empty());
  EXPECT_NE(result.err.find("pivot the tool further"), std::string::npos) << result.err;
}

TEST(CliCalibratePivot, NeedsExactlyOnePoseSource) {
  EXPECT_EQ(runCli({"calibrate-pivot", "--json"}).exit_code, 1);
  EXPECT_EQ(runCli({"calibrate-pivot", "--inlier-threshold", "-1", "--csv", "x.csv"}).exit_code, 2);
}

TEST(CliCalibratePivot, RealRecordingStylusPosesAreRefusedAsNotPivoting) {
  // In the PLUS N-wire recording the stylus lies still beside the phantom
  // (StylusToReference turns by less than 1 deg over all frames): the
  // real-data path must read every frame and refuse with the reason.
  MRSNS_REQUIRE_DATA(recording, "plus/fCal_Test_Calibration_3NWires.igs.mha");
  const auto result =
      runCli({"calibrate-pivot", "--sequence", recording.string(), "--transform", "StylusToReference", "--json"});
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_TRUE(result.out.empty());
  EXPECT_NE(result.err.find("the tool rotated only 0."), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("pivot the tool further"), std::string::npos) << result.err;
  // With the range check lowered to zero, the remaining guard (conditioning)
  // still refuses: a still tool cannot determine its tip.
  const auto forced = runCli({"calibrate-pivot", "--sequence", recording.string(), "--transform", "StylusToReference",
                              "--min-rotation-deg", "0", "--json"});
  EXPECT_EQ(forced.exit_code, 1) << forced.out;
  EXPECT_NE(forced.err.find("ill-conditioned"), std::string::npos) << forced.err;
}

TEST(CliCalibratePivot, UnknownTransformNamesTheAvailableOnes) {
  MRSNS_REQUIRE_DATA(recording, "plus/fCal_Test_Calibration_3NWires.igs.mha");
  const auto result = runCli({"calibrate-pivot", "--sequence", recording.string(), "--transform", "NeedleToTracker"});
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.err.find("StylusToTracker"), std::string::npos) << result.err;
}

void writeFcsv(const std::filesystem::path& path, const std::vector<std::pair<std::string, Eigen::Vector3d>>& points) {
  std::ofstream out(path);
  out << "# Markups fiducial file version = 4.11\n# CoordinateSystem = LPS\n"
         "# columns = id,x,y,z,ow,ox,oy,oz,vis,sel,lock,label,desc,associatedNodeID\n";
  int id = 0;
  for (const auto& [label, p] : points) {
    out << "vtkMRMLMarkupsFiducialNode_" << id++ << ',' << p.x() << ',' << p.y() << ',' << p.z() << ",0,0,0,1,1,1,0,"
        << label << ",,\n";
  }
}

TEST(CliRegisterPoints, RecoversTransformFlagsBadPointAndPredictsTre) {
  const auto dir = scratchDirectory("register");
  const std::vector<Eigen::Vector3d> ct{{0, 0, 0},    {40, 5, 10},   {-35, 8, 20},
                                        {5, 45, -10}, {10, -40, 15}, {-20, -15, 40}};
  Eigen::Isometry3d patient_T_ct = Eigen::Isometry3d::Identity();
  patient_T_ct.linear() = so3Exp(Eigen::Vector3d(0.2, -0.4, 1.0));
  patient_T_ct.translation() = Eigen::Vector3d(100, 50, -20);
  std::vector<std::pair<std::string, Eigen::Vector3d>> moving, fixed;
  for (std::size_t i = 0; i < ct.size(); ++i) {
    const std::string label = "F-" + std::to_string(i + 1);
    moving.emplace_back(label, ct[i]);
    fixed.emplace_back(label, patient_T_ct * ct[i]);
  }
  // Shuffle the fixed order: pairing goes by label.
  std::swap(fixed[0], fixed[4]);
  fixed[2].second += Eigen::Vector3d(6, -5, 4);  // F-3 was digitised on the wrong screw
  writeFcsv(dir / "patient.fcsv", fixed);
  writeFcsv(dir / "ct.fcsv", moving);
  writeFcsv(dir / "targets.fcsv", {{"C5-left", Eigen::Vector3d(10, 10, 60)}});
  const auto result =
      runCli({"register-points", (dir / "patient.fcsv").string(), (dir / "ct.fcsv").string(), "--targets",
              (dir / "targets.fcsv").string(), "--output", (dir / "t.h5").string(), "--json"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const auto json = nlohmann::json::parse(result.out);
  EXPECT_EQ(json["pairing"], "label");
  EXPECT_EQ(json["points"], 6);
  ASSERT_FALSE(json["suspect_points"].empty());
  EXPECT_EQ(json["suspect_points"][0], "F-3");
  EXPECT_GT(json["targets"][0]["predicted_tre_rms_mm"].get<double>(), 0.0);
  EXPECT_TRUE(std::filesystem::exists(dir / "t.h5"));
}

TEST(CliRegisterPoints, MismatchedCountsExitOne) {
  const auto dir = scratchDirectory("register");
  writeFcsv(dir / "a.fcsv", {{"A", {0, 0, 0}}, {"B", {10, 0, 0}}, {"C", {0, 10, 0}}});
  writeFcsv(dir / "b.fcsv", {{"X", {0, 0, 0}}, {"Y", {10, 0, 0}}, {"Z", {0, 10, 0}}, {"W", {0, 0, 10}}});
  const auto result = runCli({"register-points", (dir / "a.fcsv").string(), (dir / "b.fcsv").string()});
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.err.find("different numbers of points"), std::string::npos) << result.err;
}

TEST(CliRegisterPoints, CollinearPointsExitOne) {
  const auto dir = scratchDirectory("register");
  writeFcsv(dir / "a.fcsv", {{"A", {0, 0, 0}}, {"B", {10, 0, 0}}, {"C", {20, 0, 0}}});
  const auto result = runCli({"register-points", (dir / "a.fcsv").string(), (dir / "a.fcsv").string()});
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.err.find("collinear"), std::string::npos) << result.err;
}

}  // namespace
}  // namespace mrsns::test
