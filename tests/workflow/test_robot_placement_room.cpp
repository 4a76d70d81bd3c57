// Robot placement in the simulated operating room (simulation::OperatingRoom in process, behind its PlusServer
// and its UR controller), judged from outside by the room's scorer. The session's registration and its robot and
// drill calibrations are the room's own geometry, given exactly (the test plays those steps; their errors are
// scored by their own tests), so what is measured is the loop: navigation, the supervisor and the arm.
//
// Noise model: tracker 0.12 mm RMS position and 0.05 deg RMS orientation per sample (the scenario's default);
// the simulated UR reaches its joint targets exactly.
//
// Without a fault both paths are drilled to their ends, each within a millimetre of its plan (the tracker's
// noise on the drill's marker and the patient's reference is a tenth of that). With the patient's reference
// occluded while the first path advances: the supervisor stops the arm, the second path is not started, and the
// truth shows how soon after the fault the stop came and how little the drill moved after it.
#include <gtest/gtest.h>

#include <iostream>
#include <nlohmann/json.hpp>

#include "matrix_json.h"
#include "mrsns/simulation/operating_room.h"
#include "mrsns/simulation/scenario.h"
#include "mrsns/simulation/score.h"
#include "mrsns/workflow/steps.h"
#include "test_data.h"

namespace mrsns::workflow {
namespace {

using Json = nlohmann::json;

struct PlacementRun {
  StepResult result;
  Json score;  ///< scored.robot_placement
};

/// The room (the default scenario's patient, robot and drill, nothing else), the session's steps played with its
/// geometry, then robot-placement of paths 0 and 1; `faults` the scenario's.
PlacementRun placeInRoom(const std::string& name, const Json& faults) {
  const auto dir = test::scratchDirectory(name);
  const Json s = {{"format", "mrsns-scenario/1"},
                  {"seed", 3},
                  {"duration_s", 0.0},
                  {"tracker", {{"port", 0}, {"rate_hz", 60}}},
                  {"tools", {{{"name", "PatientToTracker"}, {"start", {{"translation_mm", {0, 0, -1400}}}}}}},
                  {"patient",
                   {{"generated_phantom", {{"spacing_mm", 2.0}}},
                    {"reference_tool", "PatientToTracker"},
                    {"ct_to_reference", {{"translation_mm", {0.0, 90.0, -30.0}}, {"rotation_deg", {90.0, 0.0, 0.0}}}}}},
                  {"robot",
                   {{"ports", {{"rtde", 0}, {"dashboard", 0}, {"secondary", 0}, {"realtime", 0}}},
                    {"base_to_tracker", {{"translation_mm", {400.0, 300.0, -1450.0}}}},
                    {"marker_to_flange", {{"translation_mm", {0.0, 0.0, 40.0}}, {"rotation_deg", {0.0, 0.0, 30.0}}}},
                    {"drill_tip_mm", {0.0, 0.0, 150.0}}}},
                  {"faults", faults}};
  const auto scenario = simulation::parseScenario(s.dump(), dir);

  auto session = Session::create(dir / "session");
  EXPECT_TRUE(runStep(session, "import-phantom", {{"spacing_mm", 2.0}}, {}).ok);
  const auto& robot = scenario.robot;
  const Eigen::Isometry3d marker_T_flange = robot.flange_T_marker.inverse();
  Eigen::Isometry3d marker_T_tip = Eigen::Isometry3d::Identity();
  marker_T_tip.translation() = marker_T_flange * robot.drill_tip_flange;
  const Eigen::Vector3d shaft_marker = marker_T_flange.linear() * robot.drill_tip_flange.normalized();
  const auto tip = marker_T_tip.translation();
  session.recordStep(
      "registration",
      {{"status", "ok"},
       {"figures",
        {{"transforms", {{"CTToPatient", test::rowMajorJson(scenario.patient->reference_T_ct.matrix())}}}}}});
  session.recordStep("robot-calibration",
                     {{"status", "ok"},
                      {"params", {{"marker", robot.marker_tool}}},
                      {"figures",
                       {{"transforms",
                         {{"RobotBaseToTracker", test::rowMajorJson(robot.tracker_T_base.matrix())},
                          {"MarkerToFlange", test::rowMajorJson(robot.flange_T_marker.matrix())}}}}}});
  session.recordStep(
      "drill-calibration",
      {{"status", "ok"},
       {"figures",
        {{"tool", "Flange"}, {"transforms", {{"FlangeTipToFlange", test::rowMajorJson(marker_T_tip.matrix())}}}}}});
  session.recordStep("drill-spin-calibration",
                     {{"status", "ok"},
                      {"figures",
                       {{"tool", "Flange"},
                        {"shaft_marker", {shaft_marker.x(), shaft_marker.y(), shaft_marker.z()}},
                        {"tip_marker_mm", {tip.x(), tip.y(), tip.z()}}}}});

  simulation::OperatingRoom room(scenario);
  room.start();
  const auto e = room.endpoints();
  PlacementRun run;
  run.result = runStep(session, "robot-placement",
                       {{"source", "plus"},
                        {"port", e.plus_port},
                        {"robot", "ur"},
                        {"ur_rtde_port", e.rtde_port},
                        {"ur_script_port", e.realtime_port},
                        {"ur_dashboard_port", e.dashboard_port},
                        {"paths", {0, 1}}},
                       {});
  room.writeTruth(dir / "truth.json");
  room.stop();
  const auto score = Json::parse(simulation::scoreSession(session.folder(), dir / "truth.json"));
  EXPECT_TRUE(score["scored"].contains("robot_placement")) << score.dump();
  run.score = score["scored"].value("robot_placement", Json::object());
  return run;
}

TEST(RobotPlacementRoom, WithoutAFaultBothPathsAreDrilledAlongTheirPlans) {
  const auto run = placeInRoom("placement-room", Json::array());
  ASSERT_TRUE(run.result.ok) << run.result.summary << "\n" << run.result.figures.dump();
  EXPECT_EQ(run.score["placed"], 2) << run.score.dump();
  EXPECT_TRUE(run.score["stops"].empty());
  for (const auto& path : run.score["paths"]) {
    SCOPED_TRACE(path["name"].get<std::string>());
    // The chain is exact: only the tracker's noise (0.12 mm RMS per sample, on two markers) and the arm's
    // servo remain; 1 mm and 1 deg are several times what they make, a wrong transform makes centimetres.
    EXPECT_LT(path["entry_error_mm"].get<double>(), 1.0);
    EXPECT_LT(path["target_error_mm"].get<double>(), 1.0);
    EXPECT_LT(path["angle_error_deg"].get<double>(), 1.0);
  }
}

TEST(RobotPlacementRoom, AnOcclusionWhileAdvancingStopsTheArmAndTheTruthShowsHowLittleItMovedAfter) {
  // 11 s into the room: the arm aligned on the first path (about 8 s from its start pose) and advancing.
  const auto run =
      placeInRoom("placement-room-fault",
                  {{{"kind", "occlusion"}, {"tool", "PatientToTracker"}, {"at_s", 11.0}, {"duration_s", 2.0}}});
  EXPECT_FALSE(run.result.ok);
  const auto& paths = run.result.figures["paths"];
  ASSERT_EQ(paths.size(), 1u) << "the second path is not started after a stop";
  EXPECT_EQ(paths[0]["outcome"], "stopped");
  EXPECT_EQ(paths[0]["stop_reason"], "PatientNotTracked") << paths[0].dump();
  ASSERT_EQ(run.score["stops"].size(), 1u) << run.score.dump();
  const auto& stop = run.score["stops"][0];
  EXPECT_EQ(stop["fault"], "occlusion start PatientToTracker") << stop.dump();
  // The PlusServer sends valid transforms only: the workstation's source calls a tool lost after 0.2 s without
  // one, then the supervisor stops within a control cycle; 400 ms leaves room for a loaded machine's scheduling.
  EXPECT_GT(stop["fault_to_stop_command_ms"].get<double>(), 150.0) << "the stop cannot precede the staleness limit";
  EXPECT_LT(stop["fault_to_stop_command_ms"].get<double>(), 400.0);
  // Until the stop the drill advanced at 5 mm/s, no faster; after the stop command the arm stops within its
  // stopping limit, a fraction of a millimetre at that speed.
  EXPECT_LT(stop["tip_path_after_fault_mm"].get<double>(), 5.0 * stop["fault_to_rest_s"].get<double>() + 0.2);
  EXPECT_LT(stop["tip_path_after_stop_mm"].get<double>(), 0.5);
  std::cout << "fault -> stop command " << stop["fault_to_stop_command_ms"] << " ms, tip path after the fault "
            << stop["tip_path_after_fault_mm"] << " mm, after the stop " << stop["tip_path_after_stop_mm"]
            << " mm, at rest " << stop["fault_to_rest_s"] << " s after the fault\n";
}

}  // namespace
}  // namespace mrsns::workflow
