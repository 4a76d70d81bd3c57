// CLI: calibrate-us on the PLUS fCal recordings, and its error paths.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <random>
#include <sstream>

#include "cli_runner.h"
#include "mrsns/io/device_set.h"
#include "mrsns/io/landmarks_io.h"
#include "mrsns/io/sequence_file.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

std::string readText(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(CliUltrasound, CalibrateUsOnPlusRecordings) {
  MRSNS_REQUIRE_DATA(config, "plus/PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml");
  MRSNS_REQUIRE_DATA(calibration, "plus/fCal_Test_Calibration_3NWires.igs.mha");
  MRSNS_REQUIRE_DATA(validation, "plus/fCal_Test_Validation_3NWires.igs.mha");
  MRSNS_REQUIRE_DATA(results, "plus/FreehandCalibration3NWires.results.xml");
  const auto dir = scratchDirectory("calibrate-us");
  const auto out_config = dir / "calibrated.xml";
  const auto r = runCli({"calibrate-us", "--config", config.string(), "--calibration", calibration.string(),
                         "--validation", validation.string(), "--reference-results", results.string(),
                         "--output-config", out_config.string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["image_to_probe"].size(), 16u);
  EXPECT_DOUBLE_EQ(j["image_to_probe"][15].get<double>(), 1.0);
  // Row-major: row 0 column 3 is the x translation (PLUS: 11.16 mm).
  EXPECT_NEAR(j["image_to_probe"][3].get<double>(), 11.2, 2.0);
  // The default calibrates as PLUS's fCal does (streams as recorded) with
  // both residual sets: the two goals in one result, validation
  // <= 1.20 mm (PLUS 1.247) and the image corners within 1 mm of PLUS's
  // ImageToProbe (module test: 1.19 mm, 0.60 mm).
  EXPECT_EQ(j["objective"], "both");
  EXPECT_FALSE(j["tracker_lag_estimated"].get<bool>());
  EXPECT_EQ(j["tracker_lag_ms"].get<double>(), 0.0);
  EXPECT_LE(j["validation"]["reprojection_3d_mm"]["mean"].get<double>(), 1.20);
  EXPECT_GT(j["validation"]["reprojection_3d_mm"]["std"].get<double>(), 0.0);
  EXPECT_LE(j["calibration"]["reprojection_3d_mm"]["mean"].get<double>(), 1.16);
  EXPECT_GE(j["calibration"]["frames_used"].get<int>(), 160);
  EXPECT_TRUE(j["calibration"]["frames_rejected"].is_array());
  EXPECT_EQ(j["calibration"]["segmentation"]["total"].get<int>(), 188);
  EXPECT_EQ(j["validation"]["reprojection_2d_px"].size(), 9u);
  EXPECT_LT(j["reference"]["max_corner_distance_mm"].get<double>(), 1.0);
  // PLUS's matrix on our segmentation (which is PLUS's) gives PLUS's figure.
  EXPECT_NEAR(j["reference"]["validation"]["reprojection_3d_mm"]["mean"].get<double>(), 1.247, 0.01);
  // The lag check: the sweep fits far better at ~0.5 s and says what to do.
  ASSERT_TRUE(j.contains("tracker_lag_check"));
  EXPECT_TRUE(j["tracker_lag_check"]["significant"].get<bool>());
  EXPECT_NEAR(j["tracker_lag_check"]["lag_ms"].get<double>(), 490.0, 79.0);
  EXPECT_NE(j["tracker_lag_check"]["advice"].get<std::string>().find("--tracker-lag-ms auto"), std::string::npos);
  const auto written = readText(out_config);
  EXPECT_NE(written.find("From=\"Image\" To=\"Probe\""), std::string::npos);
  EXPECT_NE(written.find("PhantomDefinition"), std::string::npos);

  // PLUS's criterion alone lands on PLUS's matrix; --no-lag-check skips the search.
  const auto m = runCli({"calibrate-us", "--config", config.string(), "--calibration", calibration.string(),
                         "--validation", validation.string(), "--reference-results", results.string(), "--objective",
                         "middle-wire", "--no-lag-check", "--json"});
  ASSERT_EQ(m.exit_code, 0) << m.err;
  const auto mj = nlohmann::json::parse(m.out);
  EXPECT_LT(mj["reference"]["max_corner_distance_mm"].get<double>(), 0.2);
  EXPECT_NEAR(mj["validation"]["reprojection_3d_mm"]["mean"].get<double>(), 1.247, 0.02);
  EXPECT_FALSE(mj["tracker_lag_estimated"].get<bool>());
  EXPECT_FALSE(mj.contains("tracker_lag_check"));
  EXPECT_EQ(mj["objective"], "middle-wire");

  // Text mode says the same and warns about the lag.
  const auto t = runCli({"calibrate-us", "--config", config.string(), "--calibration", calibration.string(),
                         "--validation", validation.string()});
  ASSERT_EQ(t.exit_code, 0) << t.err;
  EXPECT_NE(t.out.find("warning: the calibration sweep fits best with a tracker lag"), std::string::npos) << t.out;
}

// The lag estimated from the calibration sweep, the configuration written
// with it, and that configuration driving a volume reconstruction of the
// same sweep in the phantom's frame.
TEST(CliUltrasound, EstimatedLagCalibrationFeedsVolumeReconstruction) {
  MRSNS_REQUIRE_DATA(config, "plus/PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml");
  MRSNS_REQUIRE_DATA(calibration, "plus/fCal_Test_Calibration_3NWires.igs.mha");
  MRSNS_REQUIRE_DATA(validation, "plus/fCal_Test_Validation_3NWires.igs.mha");
  const auto dir = scratchDirectory("calibrate-us-lag");
  const auto out_config = dir / "calibrated.xml";
  const auto r = runCli({"calibrate-us", "--config", config.string(), "--calibration", calibration.string(),
                         "--validation", validation.string(), "--objective", "middle-wire", "--tracker-lag-ms", "auto",
                         "--output-config", out_config.string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(j["tracker_lag_estimated"].get<bool>());
  // Within one frame period (79 ms) of the 485 ms the module test pins down.
  EXPECT_NEAR(j["tracker_lag_ms"].get<double>(), 485.0, 79.0);
  EXPECT_EQ(j["tracker_lag_curve"].size(), 101u);
  EXPECT_LT(j["validation"]["reprojection_3d_mm"]["mean"].get<double>(), 0.75);

  const auto volume = dir / "sweep.nrrd";
  const auto v = runCli({"reconstruct-volume", "--config", out_config.string(), "--sequence", calibration.string(),
                         "--tracker-lag-ms", std::to_string(j["tracker_lag_ms"].get<double>()), "--to", "Phantom",
                         "--spacing", "1.0", "--every", "3", "--out", volume.string(), "--json"});
  ASSERT_EQ(v.exit_code, 0) << v.err;
  const auto vj = nlohmann::json::parse(v.out);
  EXPECT_EQ(vj["frame"], "Phantom");
  EXPECT_GE(vj["frames"].get<int>(), 55);
  EXPECT_GT(vj["filled_fraction"].get<double>(), 0.2);
  EXPECT_EQ(vj["size"].size(), 3u);
  EXPECT_TRUE(std::filesystem::exists(volume));

  // The shipped configuration has no ImageToProbe yet: one line, exit 1.
  const auto bad = runCli({"reconstruct-volume", "--config", config.string(), "--sequence", calibration.string(),
                           "--out", (dir / "x.nrrd").string(), "--json"});
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("ImageToProbe"), std::string::npos) << bad.err;
  EXPECT_EQ(std::count(bad.err.begin(), bad.err.end(), '\n'), 1) << bad.err;
  const auto lag = runCli({"calibrate-us", "--config", config.string(), "--calibration", calibration.string(),
                           "--validation", validation.string(), "--tracker-lag-ms", "soon", "--json"});
  EXPECT_EQ(lag.exit_code, 1);
  EXPECT_NE(lag.err.find("--tracker-lag-ms"), std::string::npos) << lag.err;
}

TEST(CliUltrasound, CalibrateUsRefusesConfigWithoutPhantom) {
  MRSNS_REQUIRE_DATA(config, "plus/PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml");
  MRSNS_REQUIRE_DATA(validation, "plus/fCal_Test_Validation_3NWires.igs.mha");
  auto text = readText(config);
  const auto begin = text.find("<PhantomDefinition>");
  const auto end = text.find("</PhantomDefinition>");
  ASSERT_NE(begin, std::string::npos);
  text.erase(begin, end + std::string("</PhantomDefinition>").size() - begin);
  const auto dir = scratchDirectory("no-phantom");
  const auto bad = dir / "no_phantom.xml";
  std::ofstream(bad) << text;
  const auto r = runCli({"calibrate-us", "--config", bad.string(), "--calibration", validation.string(), "--validation",
                         validation.string(), "--json"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE((r.out + r.err).find("hantom"), std::string::npos) << r.out << r.err;
}

TEST(CliUltrasound, CalibrateUsUsageErrors) {
  const auto r = runCli({"calibrate-us", "--config", "x.xml"});
  EXPECT_EQ(r.exit_code, 2);
  const auto missing = runCli({"calibrate-us", "--config", "/nonexistent/cfg.xml", "--calibration", "a.mha",
                               "--validation", "b.mha", "--json"});
  EXPECT_EQ(missing.exit_code, 1);
}

}  // namespace
}  // namespace mrsns::test

namespace mrsns::test {
namespace {

// A combined PLUS-like recording: B-mode frames of a flat target moving up
// and down, and a ProbeToTracker transform per frame that reports the
// motion `lag_s` late (the tracker lags).
TrackedSequence temporalRecording(double lag_s, bool with_pixels, double fps) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  const auto m = [](double t) {
    return 8.0 * (std::sin(2.0 * std::numbers::pi * 0.8 * t) + 0.4 * std::sin(2.0 * std::numbers::pi * 0.37 * t + 1.0));
  };
  TrackedSequence s;
  const int w = 64, h = 128;
  s.geometry.size = {w, h, 1};
  for (int i = 0; i < static_cast<int>(12 * fps); ++i) {
    TrackedFrame f;
    f.timestamp = 10.0 + i / fps;
    Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
    pose(2, 3) = m(f.timestamp - lag_s);
    f.transforms["ProbeToTracker"] = FrameTransform{pose, TransformStatus::Ok};
    if (with_pixels) {
      const double line_y = 64.0 + 2.5 * m(f.timestamp);
      f.pixels.resize(static_cast<std::size_t>(w * h));
      for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
          const double v = 20.0 + 200.0 * std::exp(-0.5 * std::pow((y - line_y) / 2.0, 2)) + 6.0 * std::abs(noise(rng));
          f.pixels[static_cast<std::size_t>(y * w + x)] = static_cast<std::uint8_t>(std::min(v, 255.0));
        }
      }
    }
    s.frames.push_back(std::move(f));
  }
  return s;
}

TEST(CliUltrasound, CalibrateTemporalCombinedAndSeparateFiles) {
  const auto dir = scratchDirectory("calibrate-temporal");
  io::writeSequence(dir / "combined.igs.mha", temporalRecording(0.064, true, 25.0));
  auto r = runCli({"calibrate-temporal", "--sequence", (dir / "combined.igs.mha").string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto j = nlohmann::json::parse(r.out);
  EXPECT_NEAR(j["tracker_lag_ms"].get<double>(), 64.0, 3.0);
  EXPECT_EQ(j["transform"], "ProbeToTracker");

  // As PLUS records them: a tracker buffer at 60 Hz without images
  // (DimSize = 0 0 N) and a video buffer without transforms.
  auto tracker = temporalRecording(0.064, false, 60.0);
  tracker.geometry.size = {0, 0, 1};
  io::writeSequence(dir / "tracker.igs.mha", tracker);
  std::ifstream header(dir / "tracker.igs.mha");
  std::string line;
  bool zero_dims = false;
  while (std::getline(header, line) && line.rfind("ElementDataFile", 0) != 0) {
    zero_dims = zero_dims || line == "DimSize = 0 0 " + std::to_string(tracker.frames.size());
  }
  EXPECT_TRUE(zero_dims) << "the tracker buffer is not written as PLUS writes one";
  auto video = temporalRecording(0.0, true, 25.0);
  for (auto& f : video.frames) f.transforms.clear();
  io::writeSequence(dir / "video.igs.mha", video);
  r = runCli({"calibrate-temporal", "--tracker", (dir / "tracker.igs.mha").string(), "--video",
              (dir / "video.igs.mha").string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  j = nlohmann::json::parse(r.out);
  EXPECT_NEAR(j["tracker_lag_ms"].get<double>(), 64.0, 2.0);
  EXPECT_GT(j["correlation"].get<double>(), 0.9);
}

TEST(CliUltrasound, CalibrateTemporalRefusesNoLineAndBadArguments) {
  MRSNS_REQUIRE_DATA(validation, "plus/fCal_Test_Validation_3NWires.igs.mha");
  // The N-wire recording has no flat target moving up and down.
  const auto r = runCli({"calibrate-temporal", "--sequence", validation.string(), "--json"});
  EXPECT_EQ(r.exit_code, 1);
  const auto both = runCli({"calibrate-temporal", "--sequence", validation.string(), "--tracker", "a.mha", "--json"});
  EXPECT_EQ(both.exit_code, 1);
  EXPECT_NE((both.out + both.err).find("either"), std::string::npos);
}

}  // namespace
}  // namespace mrsns::test

namespace mrsns::test {
namespace {

TEST(CliUltrasound, RegisterPhantomFromStylusPoints) {
  MRSNS_REQUIRE_DATA(config, "plus/PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml");
  const auto cfg = io::readDeviceSet(config);
  Eigen::Matrix4d truth = cfg.findTransform("Phantom", "Reference")->to_T_from;
  LandmarkSet tips;
  for (const auto& l : cfg.requirePhantom().landmarks) {
    Landmark landmark;
    landmark.label = l.name;
    landmark.position = (truth * l.position_phantom.homogeneous()).head<3>();
    tips.points.push_back(landmark);
  }
  const auto dir = scratchDirectory("register-phantom");
  io::writeLandmarks(tips, dir / "tips.mrk.json");
  const auto out = dir / "registered.xml";
  const auto r = runCli({"register-phantom", "--config", config.string(), "--points", (dir / "tips.mrk.json").string(),
                         "--output-config", out.string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  // PLUS's stored matrix is rounded to 6 digits: FRE well under 0.05 mm.
  EXPECT_LT(j["fre_rms_mm"].get<double>(), 0.05);
  EXPECT_NEAR(j["phantom_to_reference"][3].get<double>(), truth(0, 3), 0.05);
  EXPECT_TRUE(std::filesystem::exists(out));
  const auto reread = io::readDeviceSet(out);
  EXPECT_LT((reread.findTransform("Phantom", "Reference")->to_T_from - truth).norm(), 0.05);

  tips.points.pop_back();
  io::writeLandmarks(tips, dir / "seven.mrk.json");
  const auto bad =
      runCli({"register-phantom", "--config", config.string(), "--points", (dir / "seven.mrk.json").string()});
  EXPECT_EQ(bad.exit_code, 1);
}

}  // namespace
}  // namespace mrsns::test
