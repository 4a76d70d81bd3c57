// The robot-placement step on the in-process simulated tracker and arm: the paths it is given are placed in
// that order, a supervisor stop fails the step and leaves the remaining paths unstarted (the surgeon looks
// first), and what it cannot place is refused before anything moves. The placement in mrsns-sim's room, scored
// from its truth, is in tests/cli/test_cli_trial.cpp; the scorer on synthetic truth in
// tests/sim/test_score_placement.cpp.
#include <gtest/gtest.h>

#include "mrsns/core/error.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/workflow/steps.h"
#include "test_data.h"

namespace mrsns::workflow {
namespace {

Session plannedAndRegistered(const std::string& name) {
  auto session = Session::create(test::scratchDirectory(name) / "session");
  EXPECT_TRUE(runStep(session, "import-phantom", {{"spacing_mm", 1.5}}, {}).ok);
  EXPECT_TRUE(runStep(session, "registration", {}, {}).ok);
  return session;
}

std::string errorOf(Session& session, const nlohmann::json& params) {
  try {
    runStep(session, "robot-placement", params, {});
  } catch (const InvalidArgumentError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(RobotPlacementStep, ThePathsGivenArePlacedInThatOrder) {
  auto session = plannedAndRegistered("placement-order");
  const auto plans = session.plans();
  ASSERT_EQ(plans.size(), 4u);
  // As the command line passes it: text.
  const auto result = runStep(session, "robot-placement", {{"paths", "2"}}, {});
  ASSERT_TRUE(result.ok) << result.summary;
  const auto& paths = result.figures["paths"];
  ASSERT_EQ(paths.size(), 1u);
  EXPECT_EQ(paths[0]["index"], 2);
  EXPECT_EQ(paths[0]["name"], plans[2].name);
  EXPECT_EQ(paths[0]["outcome"], "placed");
  // Its tracking is recorded, every batch with the drill's marker.
  const auto recording = io::readSequence(session.resolve(paths[0]["tracking"].get<std::string>()));
  EXPECT_GT(recording.frames.size(), 100u);
  EXPECT_NE(result.summary.find("1 of 1"), std::string::npos) << result.summary;
}

TEST(RobotPlacementStep, AStopFailsTheStepAndTheRemainingPathsAreNotStarted) {
  auto session = plannedAndRegistered("placement-stop");
  // The patient's reference lost 1 s into the first path (approaching): the supervisor stops the arm.
  const auto result = runStep(
      session, "robot-placement",
      {{"paths", {1, 3}}, {"dropout_tool", "PatientToTracker"}, {"dropout_start_s", 1.0}, {"dropout_duration_s", 1.0}},
      {});
  EXPECT_FALSE(result.ok);
  const auto& paths = result.figures["paths"];
  ASSERT_EQ(paths.size(), 1u) << "path 3 must not start after the stop";
  EXPECT_EQ(paths[0]["outcome"], "stopped");
  EXPECT_EQ(paths[0]["stop_reason"], "PatientNotTracked") << paths[0].dump();
  EXPECT_TRUE(paths[0].contains("utc_stop"));
  EXPECT_LT(paths[0]["utc_start"].get<double>(), paths[0]["utc_stop"].get<double>());
  EXPECT_EQ(result.figures["placed"], 0);
  EXPECT_EQ(result.figures["planned"], 2);
  EXPECT_NE(result.summary.find("the rest not started"), std::string::npos) << result.summary;
  bool logged = false;
  for (const auto& line : session.state()["log"]) {
    logged |= line["message"].get<std::string>().find("remaining paths were not started") != std::string::npos;
  }
  EXPECT_TRUE(logged);
}

TEST(RobotPlacementStep, WhatCannotBePlacedIsRefusedBeforeAnythingMoves) {
  {
    auto empty = Session::create(test::scratchDirectory("placement-empty") / "session");
    EXPECT_NE(errorOf(empty, nlohmann::json::object()).find("run registration first"), std::string::npos);
  }
  auto session = plannedAndRegistered("placement-refused");
  EXPECT_NE(errorOf(session, {{"paths", {4}}}).find("not an index in 0..3"), std::string::npos);
  EXPECT_NE(errorOf(session, {{"paths", "1,x"}}).find("non-empty list"), std::string::npos);
  EXPECT_NE(errorOf(session, {{"paths", nlohmann::json::array()}}).find("non-empty list"), std::string::npos);
  EXPECT_NE(errorOf(session, {{"robot_path", 1}}).find("give paths="), std::string::npos);
  EXPECT_NE(errorOf(session, {{"robot", "none"}}).find("places nothing"), std::string::npos);
  EXPECT_NE(errorOf(session, {{"path_timeout_s", 1.0}}).find("path_timeout_s"), std::string::npos);
  EXPECT_NE(errorOf(session, {{"pathz", "0"}}).find("pathz"), std::string::npos);
  EXPECT_TRUE(session.step("robot-placement").is_null()) << "nothing recorded for a refused run";
}

}  // namespace
}  // namespace mrsns::workflow
