// mrsns-cli session run DIR navigation --robot simulated --tracker-dropout TOOL:START_S:DURATION_S: the
// tracker loss stops the simulated robot through its safety supervisor; the JSON says why, how fast, and
// where the (intact) recording is.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "cli_runner.h"
#include "mrsns/io/sequence_file.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

TEST(CliNavStop, TrackerDropoutStopsTheSimulatedRobotAndTheJsonSaysWhy) {
  const auto dir = scratchDirectory("navstop") / "s";
  ASSERT_EQ(runCli({"session", "create", dir.string()}).exit_code, 0);
  // Without registration the robot follows the default path in front of the patient reference.
  const auto r = runCli({"session", "run", dir.string(), "navigation", "--robot", "simulated", "--tracker-dropout",
                         "PatientToTracker:2.2:1", "--param", "duration_s=3", "--param", "deformation_cases=0",
                         // stops must come from tracking, not from this shared machine's scheduling
                         "--param", "max_missed_cycles=200", "--param", "max_cycle_time_s=0.2", "--param", "silence_timeout_s=1", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["robot"], "simulated");
  EXPECT_TRUE(j["robot_stopped"].get<bool>()) << r.out;
  EXPECT_NE(j["stop_reason"].get<std::string>().find("PatientToTracker"), std::string::npos) << j["stop_reason"];
  EXPECT_NE(j["stop_reason"].get<std::string>().find("PatientNotTracked"), std::string::npos) << j["stop_reason"];
  EXPECT_EQ(j["supervisor_state"], "Stopped");
  EXPECT_GE(j["stop_latency_cycles"].get<int>(), 1);
  EXPECT_GE(j["stop_latency_ms"].get<double>(), 0.0);
  ASSERT_TRUE(j["time_to_stop_s"].is_number()) << r.out;
  EXPECT_LE(j["time_to_stop_s"].get<double>(), j["figures"]["robot"]["stop_time_limit_s"].get<double>());
  EXPECT_LE(j["arm_speed_end_rad_s"].get<double>(), 1e-6);
  const auto recording = io::readSequence(j["recording"].get<std::string>());
  EXPECT_EQ(recording.frames.size(), j["frames_recorded"].get<std::size_t>());
  EXPECT_GT(recording.frames.size(), 0u);
}

TEST(CliNavStop, BadFlagsAreUsageErrorsOrSayWhereTheyApply) {
  const auto dir = scratchDirectory("navstop") / "s";
  ASSERT_EQ(runCli({"session", "create", dir.string()}).exit_code, 0);
  for (const char* bad : {"PatientToTracker", "PatientToTracker:x:1", "PatientToTracker:1:0", ":1:1"}) {
    const auto r = runCli({"session", "run", dir.string(), "navigation", "--tracker-dropout", bad});
    EXPECT_EQ(r.exit_code, 2) << bad << ": " << r.err;
    EXPECT_NE(r.err.find("TOOL:START_S:DURATION_S"), std::string::npos) << r.err;
  }
  auto r = runCli({"session", "run", dir.string(), "navigation", "--robot", "ur10"});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  r = runCli({"session", "run", dir.string(), "robot-calibration", "--robot", "simulated"});
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("navigation step"), std::string::npos) << r.err;
  // Without a robot the JSON still has the keys, with the loop's own check.
  r = runCli({"session", "run", dir.string(), "navigation", "--robot", "none", "--tracker-dropout",
              "PatientToTracker:0.2:0.3", "--param", "duration_s=0.8", "--param", "deformation_cases=0", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["robot"], "none");
  EXPECT_TRUE(j["robot_stopped"].get<bool>());
  EXPECT_TRUE(j["stop_latency_ms"].is_null());
}

}  // namespace
}  // namespace mrsns::test
