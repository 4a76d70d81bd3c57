// hmd-trial, hmd-calibrate-cube and latency through the real binary.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "cli_runner.h"
#include "mrsns/io/pose_csv.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

TEST(CliHmdTrial, PrintsTheFig7Comparison) {
  const auto r = runCli({"hmd-trial", "--trials", "4", "--seed", "3", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  for (const char* m : {"compensated", "uncompensated", "pointer"}) {
    ASSERT_TRUE(j["methods"].contains(m)) << m;
    EXPECT_GT(j["methods"][m]["rms_mm"]["mean"].get<double>(), 0.0);
    EXPECT_GT(j["methods"][m]["rms_mm"]["std"].get<double>(), 0.0);
    EXPECT_EQ(j["methods"][m]["rms_mm"]["per_trial"].size(), 4u);
  }
  EXPECT_TRUE(j.contains("improvement_vs_uncompensated_percent"));
  EXPECT_TRUE(j.contains("improvement_vs_pointer_percent"));
  EXPECT_DOUBLE_EQ(j["noise_model"]["tracking_sd_mm_per_axis"].get<double>(), 0.35);
  EXPECT_TRUE(j["noise_model"].contains("hand_tremor"));
  EXPECT_TRUE(j["noise_model"].contains("depth_perception"));
  EXPECT_EQ(j["trials"], 4);
}

TEST(CliHmdTrial, UsageErrorsExitTwo) {
  EXPECT_EQ(runCli({"hmd-trial", "--trials", "1"}).exit_code, 2);
  EXPECT_EQ(runCli({"hmd-trial", "--bogus"}).exit_code, 2);
}

// Two views of an 8-vertex cube, 20 samples per fiducial with 0.3 mm noise (tracker frame).
std::string writeCubePoints(const std::filesystem::path& dir, const Eigen::Isometry3d& tracker_T_hologram,
                            int fiducials = 8, bool coplanar = false) {
  std::mt19937 rng(9);
  std::normal_distribution<double> n(0.0, 0.3);
  const auto path = dir / "cube_points.csv";
  std::ofstream out(path);
  out << "# view, fiducial, tracker point (mm), hologram point (mm)\n"
      << "view,fiducial,x_tracker,y_tracker,z_tracker,x_hologram,y_hologram,z_hologram\n";
  for (const char* view : {"front", "left"}) {
    for (int i = 0; i < fiducials; ++i) {
      const Eigen::Vector3d h(i & 1 ? 30 : -30, i & 2 ? 30 : -30, coplanar ? 0.0 : (i & 4 ? 530 : 470));
      for (int k = 0; k < 20; ++k) {
        const Eigen::Vector3d t = tracker_T_hologram * h + Eigen::Vector3d(n(rng), n(rng), n(rng));
        out << view << ",v" << i << "," << t.x() << "," << t.y() << "," << t.z() << "," << h.x() << "," << h.y() << ","
            << h.z() << "\n";
      }
    }
  }
  return path.string();
}

TEST(CliHmdCalibrateCube, RecoversHologramToTracker) {
  const auto dir = scratchDirectory("cli_hmd_cube");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(100, -50, 1500);
  const auto r = runCli({"hmd-calibrate-cube", "--points", writeCubePoints(dir, T), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["views"].size(), 2u);
  EXPECT_EQ(j["views"][0]["view"], "front");
  EXPECT_EQ(j["views"][0]["tremor_compensated_fiducials"], 8);
  // Each centre averages ~20 samples of 0.3 mm noise: ~0.07 mm per axis, so rigid RMS ~0.1 mm.
  EXPECT_LT(j["views"][0]["rigid"]["rms_mm"].get<double>(), 0.3);
  EXPECT_TRUE(j["views"][0]["affine"].contains("dlt_condition_number"));
  const auto m = j["HologramToTracker"].get<std::vector<double>>();
  ASSERT_EQ(m.size(), 16u);
  // Translation within 0.5 mm (0.1 mm centre noise, 500 mm lever of a ~0.01 deg rotation error).
  EXPECT_NEAR(m[3], 100.0, 0.5);
  EXPECT_NEAR(m[7], -50.0, 0.5);
  EXPECT_NEAR(m[11], 1500.0, 0.5);
  EXPECT_NEAR(m[0], T(0, 0), 1e-3);
}

// The marker-frame form: cube vertices in the cube-marker frame with each sample's CubeToTracker.
TEST(CliHmdCalibrateCube, MarkerFrameColumns) {
  const auto dir = scratchDirectory("cli_hmd_cube_marker");
  Eigen::Isometry3d tracker_T_hologram = Eigen::Isometry3d::Identity();
  tracker_T_hologram.linear() = Eigen::AngleAxisd(-0.4, Eigen::Vector3d(0, 1, 1).normalized()).toRotationMatrix();
  tracker_T_hologram.translation() = Eigen::Vector3d(-20, 300, 1200);
  // The cube (marker frame = cube centre) sits on its hologram at (0, 0, 500), rotated by 0.3 rad.
  Eigen::Isometry3d hologram_T_cube = Eigen::Isometry3d::Identity();
  hologram_T_cube.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  hologram_T_cube.translation() = Eigen::Vector3d(0, 0, 500);
  const Eigen::Isometry3d tracker_T_cube = tracker_T_hologram * hologram_T_cube;
  const auto path = dir / "marker.csv";
  std::ofstream out(path);
  out << "view,fiducial,x_marker,y_marker,z_marker,m00,m01,m02,m03,m10,m11,m12,m13,m20,m21,m22,m23,"
         "x_hologram,y_hologram,z_hologram\n";
  out.precision(12);
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d v(i & 1 ? 30 : -30, i & 2 ? 30 : -30, i & 4 ? 30 : -30);
    const Eigen::Vector3d h = hologram_T_cube * v;
    out << "front," << i << "," << v.x() << "," << v.y() << "," << v.z();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) out << "," << tracker_T_cube(r, c);
    }
    out << "," << h.x() << "," << h.y() << "," << h.z() << "\n";
  }
  out.close();
  const auto r = runCli({"hmd-calibrate-cube", "--points", path.string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_LT(j["views"][0]["rigid"]["rms_mm"].get<double>(), 1e-6);
  EXPECT_EQ(j["views"][0]["tremor_compensated_fiducials"], 0);  // one sample each: used as is
  const auto m = j["HologramToTracker"].get<std::vector<double>>();
  for (int k = 0; k < 12; ++k) EXPECT_NEAR(m[k], tracker_T_hologram(k / 4, k % 4), 1e-6) << k;
}

TEST(CliHmdCalibrateCube, BadFilesExitOneWithOneLine) {
  const auto dir = scratchDirectory("cli_hmd_cube_bad");
  const auto missing = runCli({"hmd-calibrate-cube", "--points", (dir / "nope.csv").string(), "--json"});
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find("nope.csv"), std::string::npos) << missing.err;
  EXPECT_TRUE(missing.out.empty());

  const auto three =
      runCli({"hmd-calibrate-cube", "--points", writeCubePoints(dir, Eigen::Isometry3d::Identity(), 3), "--json"});
  EXPECT_EQ(three.exit_code, 1);
  EXPECT_NE(three.err.find("at least 4"), std::string::npos) << three.err;

  const auto flat = runCli(
      {"hmd-calibrate-cube", "--points", writeCubePoints(dir, Eigen::Isometry3d::Identity(), 8, true), "--json"});
  EXPECT_EQ(flat.exit_code, 1);
  EXPECT_NE(flat.err.find("coplanar"), std::string::npos) << flat.err;

  const auto garbage = dir / "garbage.csv";
  std::ofstream(garbage) << "view,fiducial,x_tracker,y_tracker,z_tracker,x_hologram,y_hologram,z_hologram\n"
                         << "front,a,1,2,abc,0,0,0\n";
  const auto g = runCli({"hmd-calibrate-cube", "--points", garbage.string()});
  EXPECT_EQ(g.exit_code, 1);
  EXPECT_NE(g.err.find("line 2"), std::string::npos) << g.err;
  EXPECT_EQ(std::count(g.err.begin(), g.err.end(), '\n'), 1);

  const auto no_column = dir / "no_column.csv";
  std::ofstream(no_column) << "view,fiducial,x,y,z\nfront,a,1,2,3\n";
  const auto c = runCli({"hmd-calibrate-cube", "--points", no_column.string()});
  EXPECT_EQ(c.exit_code, 1);
  EXPECT_NE(c.err.find("x_hologram"), std::string::npos) << c.err;

  EXPECT_EQ(runCli({"hmd-calibrate-cube"}).exit_code, 2);  // --points is required
}

// Walking head (see tests/hmd/test_latency.cpp): tracker at 120 Hz, HMD at 60 Hz in its own
// frame, 40 ms late.
void writeWalk(const std::filesystem::path& tracker, const std::filesystem::path& hmd, double latency) {
  auto head = [](double t) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(1500.0 * std::sin(2 * M_PI * 0.05 * t), 30.0 * std::sin(M_PI * 1.8 * t),
                                      1650.0 + 20.0 * std::sin(2 * M_PI * 1.8 * t));
    T.linear() = Eigen::AngleAxisd(0.1 * std::sin(2 * M_PI * 0.2 * t), Eigen::Vector3d::UnitZ()).toRotationMatrix();
    return T;
  };
  Eigen::Isometry3d slam_T_tracker = Eigen::Isometry3d::Identity();
  slam_T_tracker.linear() = Eigen::AngleAxisd(1.1, Eigen::Vector3d(0, 1, 0)).toRotationMatrix();
  slam_T_tracker.translation() = Eigen::Vector3d(-200, 40, 900);
  std::vector<Eigen::Isometry3d> pt, ph;
  std::vector<double> tt, th;
  for (int k = 0; k < 120 * 20; ++k) {
    tt.push_back(k / 120.0);
    pt.push_back(head(tt.back()));
  }
  for (int k = 0; k < 60 * 20; ++k) {
    th.push_back(0.2 + k / 60.0);
    ph.push_back(slam_T_tracker * head(th.back() - latency));
  }
  io::writePoseCsv(tracker, pt, tt);
  io::writePoseCsv(hmd, ph, th);
}

TEST(CliLatency, RecoversTheInjectedLatency) {
  const auto dir = scratchDirectory("cli_latency");
  writeWalk(dir / "tracker.csv", dir / "hmd.csv", 0.040);
  const auto r =
      runCli({"latency", "--tracker", (dir / "tracker.csv").string(), "--hmd", (dir / "hmd.csv").string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  // Within half the HMD sample period (8.3 ms).
  EXPECT_NEAR(j["events"]["latency_ms_mean"].get<double>(), 40.0, 8.3 / 2);
  EXPECT_NEAR(j["cross_correlation"]["latency_ms"].get<double>(), 40.0, 8.3 / 2);
  EXPECT_GT(j["events"]["count"].get<int>(), 20);
  EXPECT_LT(j["prediction"]["kalman"]["rms_translation_mm"].get<double>(),
            j["prediction"]["none"]["rms_translation_mm"].get<double>());
}

TEST(CliLatency, BadInputExitsOne) {
  const auto dir = scratchDirectory("cli_latency_bad");
  writeWalk(dir / "tracker.csv", dir / "hmd.csv", 0.040);
  const auto missing =
      runCli({"latency", "--tracker", (dir / "missing.csv").string(), "--hmd", (dir / "hmd.csv").string(), "--json"});
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find("missing.csv"), std::string::npos) << missing.err;
  // Poses without timestamps.
  io::writePoseCsv(dir / "untimed.csv", std::vector<Eigen::Isometry3d>(30, Eigen::Isometry3d::Identity()));
  const auto untimed =
      runCli({"latency", "--tracker", (dir / "untimed.csv").string(), "--hmd", (dir / "hmd.csv").string()});
  EXPECT_EQ(untimed.exit_code, 1);
  EXPECT_NE(untimed.err.find("timestamps"), std::string::npos) << untimed.err;
  EXPECT_EQ(runCli({"latency", "--tracker", (dir / "tracker.csv").string()}).exit_code, 2);
}

}  // namespace
}  // namespace mrsns::test
