// CLI: calibrate-us on the PLUS fCal recordings, and its error paths.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli_runner.h"
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
  EXPECT_LE(j["validation"]["reprojection_3d_mm"]["mean"].get<double>(), 1.20);
  EXPECT_GT(j["validation"]["reprojection_3d_mm"]["std"].get<double>(), 0.0);
  EXPECT_LT(j["calibration"]["reprojection_3d_mm"]["mean"].get<double>(), 1.25);
  EXPECT_GE(j["calibration"]["frames_used"].get<int>(), 160);
  EXPECT_TRUE(j["calibration"]["frames_rejected"].is_array());
  EXPECT_EQ(j["calibration"]["segmentation"]["total"].get<int>(), 188);
  EXPECT_EQ(j["validation"]["reprojection_2d_px"].size(), 9u);
  EXPECT_LT(j["reference"]["max_corner_distance_mm"].get<double>(), 5.0);
  const auto written = readText(out_config);
  EXPECT_NE(written.find("From=\"Image\" To=\"Probe\""), std::string::npos);
  EXPECT_NE(written.find("PhantomDefinition"), std::string::npos);

  // PLUS's criterion lands within 1 mm of PLUS's ImageToProbe at the corners.
  const auto m =
      runCli({"calibrate-us", "--config", config.string(), "--calibration", calibration.string(), "--validation",
              validation.string(), "--reference-results", results.string(), "--objective", "middle-wire", "--json"});
  ASSERT_EQ(m.exit_code, 0) << m.err;
  EXPECT_LT(nlohmann::json::parse(m.out)["reference"]["max_corner_distance_mm"].get<double>(), 1.0);
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
