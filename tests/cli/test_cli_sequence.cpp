// mrsns-cli on PLUS sequences and device sets: info (text and JSON), convert
// round trip, and the exit codes for bad input and bad usage.
// GCC 12 reports a false -Wrestrict on "literal" + std::string at -O3 (GCC bug 105651).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wrestrict"
#endif
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli_runner.h"
#include "test_data.h"

namespace mrsns {
namespace {

constexpr const char* kCalibration = "plus/fCal_Test_Calibration_3NWires.igs.mha";

nlohmann::json parseOnly(const std::string& out) {
  // One JSON object and nothing else on stdout.
  return nlohmann::json::parse(out);
}

TEST(CliSequence, InfoJsonReportsFramesAndTransforms) {
  MRSNS_REQUIRE_DATA(path, kCalibration);
  const auto result = test::runCli({"info", "--json", path.string()});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const auto j = parseOnly(result.out);
  EXPECT_EQ(j.at("kind"), "sequence");
  EXPECT_EQ(j.at("file"), path.string());
  EXPECT_EQ(j.at("frames"), 188);
  EXPECT_EQ(j.at("compressed"), true);
  EXPECT_EQ(j.at("image").at("size"), nlohmann::json::array({820, 616}));
  EXPECT_EQ(j.at("image").at("pixel_type"), "uint8");
  EXPECT_EQ(j.at("image").at("orientation"), "MFA");
  std::vector<std::string> names;
  for (const auto& t : j.at("transforms")) {
    names.push_back(t.at("name"));
    EXPECT_EQ(t.at("valid_frames"), 188);
    EXPECT_EQ(t.at("invalid_frames"), 0);
    EXPECT_EQ(t.at("missing_frames"), 0);
  }
  EXPECT_EQ(names, (std::vector<std::string>{"ProbeToTracker", "ReferenceToTracker", "StylusToTracker"}));
  const auto& time = j.at("timestamps");
  EXPECT_EQ(time.at("first").get<double>(), 425.398686);
  EXPECT_EQ(time.at("last").get<double>(), 440.246214);
  // 187 intervals over the recording's span.
  EXPECT_NEAR(time.at("mean_rate_hz").get<double>(), 187.0 / (440.246214 - 425.398686), 1e-9);
  EXPECT_EQ(j.at("custom_fields").size(), 2u);
}

TEST(CliSequence, InfoTextIsReadable) {
  MRSNS_REQUIRE_DATA(path, kCalibration);
  const auto result = test::runCli({"info", path.string()});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("Frames: 188 of 820x616 uint8"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("ProbeToTracker: 188 valid, 0 invalid, 0 missing"), std::string::npos) << result.out;
}

TEST(CliSequence, ConvertRoundTripThroughNrrd) {
  MRSNS_REQUIRE_DATA(path, kCalibration);
  const auto dir = test::scratchDirectory("convert");
  const auto nrrd = dir / "calib.seq.nrrd";
  const auto back = dir / "back.igs.mha";
  auto result = test::runCli({"convert", "--json", path.string(), nrrd.string()});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(parseOnly(result.out).at("frames"), 188);
  result = test::runCli({"convert", "--no-compress", nrrd.string(), back.string()});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  result = test::runCli({"info", "--json", back.string()});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const auto j = parseOnly(result.out);
  EXPECT_EQ(j.at("frames"), 188);
  EXPECT_EQ(j.at("compressed"), false);
  EXPECT_EQ(j.at("transforms").size(), 3u);
  EXPECT_EQ(std::filesystem::file_size(back) > 820u * 616u * 188u, true);
  std::filesystem::remove_all(dir);
}

TEST(CliSequence, TruncatedFileFailsWithOneLine) {
  MRSNS_REQUIRE_DATA(path, kCalibration);
  const auto dir = test::scratchDirectory("truncated");
  const auto cut = dir / "cut.igs.mha";
  {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream buffer;
    buffer << in.rdbuf();
    const std::string bytes = buffer.str();
    std::ofstream out(cut, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 3));
  }
  const auto result = test::runCli({"info", "--json", cut.string()});
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_TRUE(result.out.empty()) << result.out;
  ASSERT_FALSE(result.err.empty());
  EXPECT_EQ(result.err.find('\n'), result.err.size() - 1) << result.err;
  EXPECT_NE(result.err.find("cut.igs.mha"), std::string::npos) << result.err;
}

TEST(CliSequence, MissingArgumentIsUsageError) {
  EXPECT_EQ(test::runCli({"info"}).exit_code, 2);
  EXPECT_EQ(test::runCli({"convert", "only-one.igs.mha"}).exit_code, 2);
}

TEST(CliDeviceSet, InfoJsonSummarisesThePhantom) {
  MRSNS_REQUIRE_DATA(path, "plus/PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml");
  const auto result = test::runCli({"info", "--json", path.string()});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const auto j = parseOnly(result.out);
  EXPECT_EQ(j.at("kind"), "device-set");
  EXPECT_EQ(j.at("phantom").at("name"), "fCAL");
  EXPECT_EQ(j.at("phantom").at("wires"), 9);
  EXPECT_EQ(j.at("phantom").at("landmarks").size(), 8u);
  EXPECT_EQ(j.at("coordinate_definitions").size(), 3u);
  EXPECT_EQ(j.at("segmentation").at("attributes").at("ApproximateSpacingMmPerPixel"), "0.078");
}

}  // namespace
}  // namespace mrsns
