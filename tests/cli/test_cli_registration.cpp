// calibrate-pivot, calibrate-spin and register-points through the real
// binary: synthetic inputs written to files, and the real PLUS recording;
// the MovingToFixed files of register-points and register-surface.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>

#include "../registration/surface_fixtures.h"
#include "cli_runner.h"
#include "mrsns/core/rigid.h"
#include "mrsns/io/mesh_io.h"
#include "mrsns/io/pose_csv.h"
#include "mrsns/io/transform_io.h"
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

// ---- --output MovingToFixed: the same transform whatever the extension ----

/// A verb's "fixed_T_moving" (16 numbers, row-major).
Eigen::Matrix4d reportedMatrix(const nlohmann::json& a) {
  EXPECT_EQ(a.size(), 16U);
  Eigen::Matrix4d m;
  for (int i = 0; i < 16; ++i) m(i / 4, i % 4) = a[static_cast<std::size_t>(i)].get<double>();
  return m;
}

/// The 16 numbers of a plain text matrix, read by hand (no library).
Eigen::Matrix4d plainTextMatrix(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::vector<double> v;
  double x = 0.0;
  while (in >> x) v.push_back(x);
  EXPECT_EQ(v.size(), 16U) << path << " is not a plain 4x4 matrix";
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  for (std::size_t i = 0; i < std::min<std::size_t>(v.size(), 16); ++i) m(i / 4, i % 4) = v[i];
  return m;
}

/// Every file holds fixed_T_moving by the convention: readChildToParent gives the reported matrix, a .txt
/// holds it as written, an ITK file its inverse. Rigid, translations up to ~150 mm: the inversions and
/// the 17-digit text cost a few ulps of 150 mm (~3e-14 each); 1e-11 leaves margin.
void expectMovingToFixedFiles(const std::map<std::string, std::filesystem::path>& files,
                              const Eigen::Matrix4d& reported) {
  for (const auto& [ext, file] : files) {
    SCOPED_TRACE(file.string());
    EXPECT_LT((io::readChildToParent(file) - reported).cwiseAbs().maxCoeff(), 1e-11);
    if (ext == ".txt") {
      EXPECT_LT((plainTextMatrix(file) - reported).cwiseAbs().maxCoeff(), 1e-11);
    } else {
      EXPECT_LT((io::readTransformFile(file).matrix - reported.inverse()).cwiseAbs().maxCoeff(), 1e-11);
    }
  }
}

TEST(CliMovingToFixed, RegisterSurfaceTxtAndTfmHoldTheReportedTransform) {
  const auto dir = scratchDirectory("moving-to-fixed");
  const auto truth = makePose(Eigen::Vector3d(0.1, 0.15, -0.1), Eigen::Vector3d(5, -6, 4));
  const TriangleMesh mesh = vertebraLikeMesh(41, 64);
  io::writeMesh(mesh, dir / "bone.stl");
  // Noise-free points on the surface, in the moving frame: p_moving = truth^-1 p_fixed.
  const auto moving = transformPoints(truth.inverse(), sampleSurface(mesh, 600, 0.0, 5));
  {
    std::ofstream out(dir / "points.csv");
    out.precision(17);
    for (std::size_t i = 0; i < moving.size(); ++i) {
      out << "P-" << i + 1 << ',' << moving[i].x() << ',' << moving[i].y() << ',' << moving[i].z() << '\n';
    }
  }
  std::map<std::string, std::filesystem::path> files;
  std::map<std::string, Eigen::Matrix4d> reported;
  for (const std::string ext : {".txt", ".tfm", ".h5"}) {
    files[ext] = dir / ("MovingToFixed" + ext);
    const auto result = runCli({"register-surface", "--points", (dir / "points.csv").string(), "--mesh",
                                (dir / "bone.stl").string(), "--output", files[ext].string(), "--json"});
    ASSERT_EQ(result.exit_code, 0) << result.err;
    reported[ext] = reportedMatrix(nlohmann::json::parse(result.out)["fixed_T_moving"]);
  }
  // The same inputs give the same registration (deterministic), whatever the output's extension.
  EXPECT_LT((reported[".txt"] - reported[".tfm"]).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((reported[".txt"] - reported[".h5"]).cwiseAbs().maxCoeff(), 1e-12);
  // And it is the truth (noise-free points: ICP's convergence tolerance, well below 0.01 mm).
  const auto e = poseError(Eigen::Isometry3d(reported[".tfm"]), truth, centroid(moving));
  EXPECT_LT(e.translation, 0.01);
  EXPECT_LT(e.rotation, 0.01 * kDegree);
  expectMovingToFixedFiles(files, reported[".tfm"]);
  // The files agree with each other: the .txt is not the inverse of the .tfm's meaning (the old bug).
  EXPECT_LT((io::readChildToParent(files[".txt"]) - io::readChildToParent(files[".tfm"])).cwiseAbs().maxCoeff(), 1e-11);
  // A point of the moving data, mapped by the .txt's matrix, lands where the truth puts it.
  const Eigen::Vector4d p = plainTextMatrix(files[".txt"]) * moving.front().homogeneous();
  EXPECT_LT((p.head<3>() - truth * moving.front()).norm(), 0.01);
}

TEST(CliMovingToFixed, RegisterPointsTxtAndTfmHoldTheReportedTransform) {
  const auto dir = scratchDirectory("moving-to-fixed");
  const std::vector<Eigen::Vector3d> ct{{0, 0, 0}, {40, 5, 10}, {-35, 8, 20}, {5, 45, -10}, {10, -40, 15}};
  Eigen::Isometry3d patient_T_ct = Eigen::Isometry3d::Identity();
  patient_T_ct.linear() = so3Exp(Eigen::Vector3d(0.3, -0.5, 1.2));
  patient_T_ct.translation() = Eigen::Vector3d(-120, 80, 35);
  std::vector<std::pair<std::string, Eigen::Vector3d>> moving, fixed;
  for (std::size_t i = 0; i < ct.size(); ++i) {
    moving.emplace_back("F-" + std::to_string(i + 1), ct[i]);
    fixed.emplace_back("F-" + std::to_string(i + 1), patient_T_ct * ct[i]);
  }
  writeFcsv(dir / "patient.fcsv", fixed);
  writeFcsv(dir / "ct.fcsv", moving);
  std::map<std::string, std::filesystem::path> files;
  std::map<std::string, Eigen::Matrix4d> reported;
  for (const std::string ext : {".txt", ".tfm", ".mat"}) {
    files[ext] = dir / ("CtToPatient" + ext);
    const auto result = runCli({"register-points", (dir / "patient.fcsv").string(), (dir / "ct.fcsv").string(),
                                "--output", files[ext].string(), "--json"});
    ASSERT_EQ(result.exit_code, 0) << result.err;
    reported[ext] = reportedMatrix(nlohmann::json::parse(result.out)["fixed_T_moving"]);
  }
  EXPECT_LT((reported[".txt"] - reported[".tfm"]).cwiseAbs().maxCoeff(), 1e-12);
  // writeFcsv prints 6 significant digits: coordinates of ~100 mm are rounded by up to 5e-4 mm, so the
  // fit is within ~1e-3 of patient_T_ct (translation; the rotation within ~1e-5 over 40 mm).
  EXPECT_LT((reported[".tfm"] - patient_T_ct.matrix()).cwiseAbs().maxCoeff(), 2e-3);
  expectMovingToFixedFiles(files, reported[".tfm"]);
}

}  // namespace
}  // namespace mrsns::test
