// mrsns-cli session create|sample|run|info|steps.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "cli_runner.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

TEST(CliSession, CreateRunInfoRoundTrip) {
  const auto dir = scratchDirectory("session") / "s";
  auto r = runCli({"session", "create", dir.string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir / "session.json"));

  r = runCli(
      {"session", "run", dir.string(), "robot-calibration", "--param", "poses=8", "--param", "seed=3", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["step"], "robot-calibration");
  EXPECT_EQ(j["figures"]["poses"], 8);
  EXPECT_GT(j["figures"]["fre_rms_mm"].get<double>(), 0.0);

  r = runCli({"session", "info", dir.string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto info = nlohmann::json::parse(r.out);
  bool found = false;
  for (const auto& s : info["steps"]) {
    if (s["name"] == "robot-calibration") {
      found = true;
      EXPECT_EQ(s["status"], "ok");
    } else {
      EXPECT_EQ(s["status"], "not run");
    }
  }
  EXPECT_TRUE(found);
  EXPECT_EQ(info["steps"].size(), 26u) << "every workflow step, run or not";
}

TEST(CliSession, SampleSessionAndStepList) {
  const auto dir = scratchDirectory("session") / "from-sample";
  auto r = runCli({"session", "sample", dir.string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(std::filesystem::exists(std::filesystem::path(j["sample"].get<std::string>()) / "session.json"));
  EXPECT_TRUE(std::filesystem::exists(dir / "session.json"));
  r = runCli({"session", "steps", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto steps = nlohmann::json::parse(r.out)["steps"];
  ASSERT_EQ(steps.size(), 26u);
  EXPECT_EQ(steps[0]["name"], "import-ct") << "the patient's data come first";
  EXPECT_EQ(steps[0]["group"], "data");
  EXPECT_EQ(steps[22]["name"], "checkerboard-digitisation") << "the board digitised before the camera uses it";
  EXPECT_EQ(steps[23]["name"], "hmd-camera-calibration");
  EXPECT_EQ(steps[12]["name"], "pivot-calibration") << "the tools are calibrated before anything uses them";
}

TEST(CliSession, ErrorsAreOneLineWithExitCodes) {
  const auto dir = scratchDirectory("session");
  auto r = runCli({"session", "info", (dir / "missing").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("session create"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;

  ASSERT_EQ(runCli({"session", "create", (dir / "s").string()}).exit_code, 0);
  r = runCli({"session", "create", (dir / "s").string()});
  EXPECT_EQ(r.exit_code, 1) << "created over an existing session";
  r = runCli({"session", "run", (dir / "s").string(), "warp-drive"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("registration"), std::string::npos) << "lists the valid steps: " << r.err;
  r = runCli({"session", "run", (dir / "s").string(), "connect-devices", "--param", "duration"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("NAME=VALUE"), std::string::npos) << r.err;
  r = runCli({"session", "run", (dir / "s").string(), "connect-devices", "--param", "speed=2"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("duration_s"), std::string::npos) << "names the parameters it takes: " << r.err;
  r = runCli({"session"});
  EXPECT_EQ(r.exit_code, 2);
  // A corrupt session.json: exit 1 with the reason.
  std::ofstream(dir / "s" / "session.json") << "{\"version\": 1, \"steps\": {";
  r = runCli({"session", "info", (dir / "s").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("not valid JSON"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace mrsns::test
