// The navigation step with the session's plan: the loop drives the simulated robot along the first
// planned path, and a scripted tracker loss stops it through the safety supervisor; the step's figures
// carry the stop reason, the stop latency and the time to stop.
#include <gtest/gtest.h>

#include "mrsns/core/error.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/workflow/steps.h"
#include "test_data.h"

namespace mrsns::workflow {
namespace {

TEST(NavigationStepRobot, WithAPlanTheTrackerLossStopsTheRobotAndTheFiguresSayWhy) {
  auto session = Session::create(test::scratchDirectory("navstep") / "session");
  ASSERT_TRUE(runStep(session, "import-phantom", {{"spacing_mm", 1.5}}, {}).ok);
  ASSERT_TRUE(runStep(session, "registration", {}, {}).ok);
  const auto result = runStep(session, "navigation",
                              {{"duration_s", 3.0},
                               {"dropout_tool", "PatientToTracker"},
                               {"dropout_start_s", 2.2},
                               {"dropout_duration_s", 1.0},
                               {"deformation_cases", 0},
                               // Stops must come from tracking, not from this shared machine's scheduling.
                               {"max_missed_cycles", 200},
                               {"max_cycle_time_s", 0.2},
                               {"silence_timeout_s", 1.0}},
                              {});
  ASSERT_TRUE(result.ok) << result.summary;
  const auto& f = result.figures;
  ASSERT_TRUE(f.contains("robot")) << f.dump(1);
  const auto& robot = f["robot"];
  EXPECT_EQ(robot["mode"], "simulated");
  EXPECT_EQ(robot["plan"], session.plans().at(0).name);
  EXPECT_TRUE(robot["docked"].get<bool>());
  EXPECT_TRUE(f["robot_stopped"].get<bool>()) << f.dump(1);
  const std::string reason = f["stop_reason"];
  EXPECT_NE(reason.find("PatientToTracker"), std::string::npos) << reason;
  EXPECT_NE(reason.find("PatientNotTracked"), std::string::npos) << reason;
  EXPECT_EQ(robot["supervisor_stop"], "PatientNotTracked");
  EXPECT_EQ(robot["supervisor_state"], "Stopped");
  ASSERT_TRUE(f["time_to_stop_s"].is_number()) << robot.dump(1);
  EXPECT_LE(f["time_to_stop_s"].get<double>(), robot["stop_time_limit_s"].get<double>());
  EXPECT_GE(f["stop_latency_cycles"].get<int>(), 1);
  EXPECT_LE(robot["arm_speed_end_rad_s"].get<double>(), 1e-6);
  EXPECT_EQ(robot["motion_commands_after_stop"], 0);
  bool from_advancing = false;
  for (const auto& t : robot["transitions"]) from_advancing |= t["to"] == "Stopped" && t["from"] == "Advancing";
  EXPECT_TRUE(from_advancing) << robot["transitions"].dump(1);
  bool logged = false;
  for (const auto& line : session.state()["log"]) {
    logged |=
        line["message"].get<std::string>().find("robot stopped: tracking lost: PatientToTracker") != std::string::npos;
  }
  EXPECT_TRUE(logged);
  EXPECT_EQ(f["frames_in_file"], f["batches"]);
  const auto recording = io::readSequence(session.resolve(result.outputs.at(0)));
  EXPECT_EQ(recording.frames.size(), f["frames_recorded"].get<std::size_t>());
}

TEST(NavigationStepRobot, RobotParameterIsCheckedAndNoneKeepsTheRobotOut) {
  auto session = Session::create(test::scratchDirectory("navstep") / "session");
  try {
    runStep(session, "navigation", {{"robot", "ur10"}}, {});
    FAIL();
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("auto, none, simulated"), std::string::npos) << e.what();
  }
  const auto result =
      runStep(session, "navigation", {{"robot", "none"}, {"duration_s", 0.3}, {"deformation_cases", 0}}, {});
  ASSERT_TRUE(result.ok) << result.summary;
  EXPECT_FALSE(result.figures.contains("robot"));
}

}  // namespace
}  // namespace mrsns::workflow
