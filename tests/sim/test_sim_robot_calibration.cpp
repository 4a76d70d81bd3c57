// The robot calibration acquired live from mrsns-sim, from outside: the
// workstation drives the room's UR controller (RTDE, real-time script,
// dashboard) through stations whose flange rotations span three axes, the
// room's tracker sees the flange marker, and AX = YB gives MarkerToFlange and
// RobotBaseToTracker; `mrsns-sim score` judges both against the truth. The
// station pairs recomputed offline by `mrsns-cli robot-calibrate` give the same
// calibration. A tracker of one room never drives another room's controller.
//
// Noise model: tracker 0.12 mm RMS position and 0.05 deg RMS orientation per
// sample; the simulated arm reaches its joint targets exactly (no encoder or
// kinematic error: the UR5's 0.1 mm repeatability is not modelled).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <fstream>
#include <thread>

#include "mrsns/robot/dashboard_client.h"

#include "sim_process.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

using Json = nlohmann::json;

std::filesystem::path writeRobotScenario(const std::filesystem::path& dir, int seed, const std::string& marker_to_flange,
                                         const std::string& robot_extra = "") {
  const auto file = dir / "robot.json";
  std::ofstream(file) << R"({"format": "mrsns-scenario/1", "name": "robot calibration", "seed": )" << seed << R"(,
    "tracker": {"port": 0, "noise": {"position_rms_mm": 0.12, "orientation_rms_deg": 0.05}},
    "tools": [{"name": "PatientToTracker", "marker_radius_mm": 40, "start": {"translation_mm": [0, 0, -1400]}}],
    "patient": {"generated_phantom": {"spacing_mm": 2.0}, "reference_tool": "PatientToTracker"},
    "robot": {"base_to_tracker": {"translation_mm": [400, 300, -1450], "rotation_deg": [0, 0, 20]},
              "marker_to_flange": )"
                      << marker_to_flange << R"(, "marker_tool": "FlangeToTracker")" << robot_extra << R"(}})";
  return file;
}

struct RobotRoom {
  std::unique_ptr<SimProcess> sim;
  Json ready;
  std::filesystem::path truth;
};

RobotRoom startRobotRoom(const std::filesystem::path& dir, int seed, const std::string& marker_to_flange,
                         const std::string& robot_extra = "") {
  RobotRoom room;
  room.truth = dir / "truth.json";
  room.sim = std::make_unique<SimProcess>(std::vector<std::string>{
      "run", "--scenario", writeRobotScenario(dir, seed, marker_to_flange, robot_extra).string(), "--truth",
      room.truth.string(),
      "--ready-file", (dir / "ready.json").string(), "--any-ports", "--duration", "0", "--json"});
  room.ready = room.sim->waitReady(dir / "ready.json");
  return room;
}

std::vector<std::string> robotParams(const Json& tracker_room, const Json& robot_room) {
  return {"--param", "source=ur",
          "--param", "port=" + std::to_string(tracker_room["plus_port"].get<int>()),
          "--param", "ur_rtde_port=" + std::to_string(robot_room["robot"]["rtde"].get<int>()),
          "--param", "ur_script_port=" + std::to_string(robot_room["robot"]["realtime"].get<int>()),
          "--param", "ur_dashboard_port=" + std::to_string(robot_room["robot"]["dashboard"].get<int>())};
}

TEST(SimRobotCalibration, DrivenStationsCalibrateTheRobotToTheTrackerOverTwoSeedsAndOfflineAgrees) {
  int seed = 0;
  for (const std::string marker : {R"({"translation_mm": [0, 0, 40]})",
                                   R"({"translation_mm": [12, -30, 55], "rotation_deg": [10, 0, -25]})"}) {
    ++seed;
    SCOPED_TRACE("seed " + std::to_string(seed));
    const auto dir = scratchDirectory("sim-robot-calibration-" + std::to_string(seed));
    auto room = startRobotRoom(dir, seed, marker);
    ASSERT_FALSE(room.ready.is_null()) << room.sim->wait().err;
    const auto session = dir / "session";
    ASSERT_EQ(runCli({"session", "create", session.string()}).exit_code, 0);
    std::vector<std::string> args = {"session", "run", session.string(), "robot-calibration", "--param",
                                     "seed=" + std::to_string(seed), "--json"};
    const auto params = robotParams(room.ready, room.ready);
    args.insert(args.end(), params.begin(), params.end());
    const auto step = runCli(args);
    room.sim->terminate();
    EXPECT_EQ(room.sim->wait(30.0).exit_code, 0);
    ASSERT_EQ(step.exit_code, 0) << step.err << step.out;
    const auto f = Json::parse(step.out)["figures"];
    EXPECT_TRUE(f["simulated"].get<bool>());
    EXPECT_EQ(f["poses"], 10);
    EXPECT_EQ(f["validation_error_mm"]["count"], 2);

    // Scored from outside. Each station's marker pose is the mean of ~50 samples of 0.12 mm RMS noise; the
    // calibration from ten of them cannot be worse than one sample's noise.
    const auto score = runSim({"score", session.string(), room.truth.string(), "--json"});
    ASSERT_EQ(score.exit_code, 0) << score.err;
    const auto s = Json::parse(score.out)["scored"]["robot_calibration"];
    EXPECT_LT(s["translation_error_mm"].get<double>(), 0.12) << s.dump();
    EXPECT_LT(s["error_500mm_mm"].get<double>(), 0.12) << s.dump();
    EXPECT_LT(s["marker_to_flange_translation_error_mm"].get<double>(), 0.12) << s.dump();
    EXPECT_LT(f["validation_error_mm"]["max"].get<double>(), 0.12);
    std::printf("[ figures ] seed %d: RobotBaseToTracker %.3f mm / %.4f deg (%.3f mm 500 mm from the base), "
                "MarkerToFlange %.3f mm; fit residual %.3f mm, validation %.3f mm; %.0f s\n",
                seed, s["translation_error_mm"].get<double>(), s["rotation_error_deg"].get<double>(),
                s["error_500mm_mm"].get<double>(), s["marker_to_flange_translation_error_mm"].get<double>(),
                f["residual_rms_mm"].get<double>(), f["validation_error_mm"]["mean"].get<double>(),
                f["recorded"]["seconds"].get<double>());

    // The stations recomputed offline.
    const auto offline = runCli({"robot-calibrate", "--poses",
                                 (session / f["recorded"]["stations_file"].get<std::string>()).string(), "--json"});
    ASSERT_EQ(offline.exit_code, 0) << offline.err;
    const auto o = Json::parse(offline.out);
    Eigen::Matrix4d tracker_to_base, robot_base_to_tracker;
    for (int i = 0; i < 16; ++i) {
      tracker_to_base(i / 4, i % 4) = o["TrackerToBase"][static_cast<std::size_t>(i)].get<double>();
      robot_base_to_tracker(i / 4, i % 4) = f["transforms"]["RobotBaseToTracker"][static_cast<std::size_t>(i)].get<double>();
    }
    // The same up to the refined solver's convergence on inputs read back from text (1e-8 mm here).
    const Eigen::Matrix4d product = tracker_to_base * robot_base_to_tracker;
    const double rotation_difference = (product.block(0, 0, 3, 3) - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
    const double translation_difference_mm = product.block(0, 3, 3, 1).norm();
    EXPECT_LT(rotation_difference, 1e-9);
    EXPECT_LT(translation_difference_mm, 1e-6);
    EXPECT_EQ(slurpFile(session / "session.json").find("truth"), std::string::npos);
  }
}

TEST(SimRobotCalibration, AStationBeyondTheControllersJointLimitIsSkippedWithTheReasonAndTheRestCalibrate) {
  // The controller's safety configuration narrows the last wrist joint to +/-15 deg (a cable routed through the
  // tool): on the way to a station that turns the flange further, the arm meets that limit and the controller
  // raises a protective stop, as a UR does. The step skips that station, waits for the operator to unlock the
  // stop, and goes on from where the arm stands.
  const auto dir = scratchDirectory("sim-robot-calibration-unreachable");
  auto room = startRobotRoom(dir, 3, R"({"translation_mm": [0, 0, 40]})", R"(, "joint_limits_deg": {"5": [-15, 15]})");
  ASSERT_FALSE(room.ready.is_null()) << room.sim->wait().err;
  const auto session = dir / "session";
  ASSERT_EQ(runCli({"session", "create", session.string()}).exit_code, 0);
  std::vector<std::string> args = {"session", "run", session.string(), "robot-calibration", "--param", "seed=3",
                                   "--json"};
  const auto params = robotParams(room.ready, room.ready);
  args.insert(args.end(), params.begin(), params.end());
  // The operator at the teach pendant: after each protective stop, inspects the arm and unlocks it (the UR allows
  // that 5 s after the stop). The workstation waits for this; it never unlocks a protective stop itself.
  std::atomic<bool> finished{false};
  std::atomic<int> unlocks{0};
  std::thread operator_at_pendant([&] {
    try {
      robot::DashboardClient dashboard(
          {"127.0.0.1", static_cast<std::uint16_t>(room.ready["robot"]["dashboard"].get<int>()), 2.0});
      while (!finished) {
        if (dashboard.safetyStatus() == robot::UrSafetyMode::ProtectiveStop) {
          std::this_thread::sleep_for(std::chrono::milliseconds(5200));
          if (dashboard.command(robot::dashboard::Command::UnlockProtectiveStop).accepted) ++unlocks;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(200));
      }
    } catch (const std::exception& e) {
      ADD_FAILURE() << "the operator's dashboard: " << e.what();
    }
  });
  const auto step = runCli(args);
  finished = true;
  operator_at_pendant.join();
  room.sim->terminate();
  EXPECT_EQ(room.sim->wait(30.0).exit_code, 0);
  EXPECT_GE(unlocks.load(), 1) << "the arm met its joint limit at least once";
  // The step's record in the session (the CLI prints JSON only when it succeeds).
  const auto result = Json::parse(slurpFile(session / "session.json"))["steps"]["robot-calibration"];
  const auto& f = result["figures"];
  int skipped = 0;
  for (const auto& station : f["stations"]) {
    if (!station.contains("skipped")) continue;
    ++skipped;
    EXPECT_NE(station["skipped"].get<std::string>().find("protective stop"), std::string::npos) << station.dump();
  }
  EXPECT_GE(skipped, 1) << "some station turns the wrist beyond 15 deg: " << f["stations"].dump();
  EXPECT_NE(result["summary"].get<std::string>().find("skipped"), std::string::npos) << result["summary"];
  // Whatever was left: a calibration from the reached stations (6 or more), or a failure that says why.
  if (step.exit_code == 0) {
    EXPECT_GE(f["poses"].get<int>(), 6);
    const auto score = runSim({"score", session.string(), room.truth.string(), "--json"});
    ASSERT_EQ(score.exit_code, 0) << score.err;
    const auto s = Json::parse(score.out)["scored"]["robot_calibration"];
    EXPECT_LT(s["error_500mm_mm"].get<double>(), 0.15) << s.dump();
    std::printf("[ figures ] %d of %zu stations skipped (joint limit), RobotBaseToTracker error 500 mm from the "
                "base %.3f mm from the %d reached\n",
                skipped, f["stations"].size(), s["error_500mm_mm"].get<double>(), f["poses"].get<int>());
  } else {
    EXPECT_NE(step.err.find("6 needed"), std::string::npos) << step.err;
  }
  // Nothing recorded is lost: the tracking of every station, reached or not, stays in the session.
  EXPECT_TRUE(std::filesystem::exists(session / f["recorded"]["file"].get<std::string>()));
}

TEST(SimRobotCalibration, CancelledMidMotionTheArmComesToRestAndTheRecordingIsKept) {
  const auto dir = scratchDirectory("sim-robot-calibration-cancel");
  auto room = startRobotRoom(dir, 3, R"({"translation_mm": [0, 0, 40]})");
  ASSERT_FALSE(room.ready.is_null()) << room.sim->wait().err;
  const auto session = dir / "session";
  ASSERT_EQ(runCli({"session", "create", session.string()}).exit_code, 0);
  std::vector<std::string> args = {cliBinary().string(), "session", "run", session.string(), "robot-calibration"};
  const auto params = robotParams(room.ready, room.ready);
  args.insert(args.end(), params.begin(), params.end());
  BackgroundProcess step(args);
  ASSERT_TRUE(step.started());
  // Stations take about 3 s each: 8 s in, the arm is on its way between two of them.
  std::this_thread::sleep_for(std::chrono::seconds(8));
  ASSERT_FALSE(step.ended()) << step.wait().err;
  step.terminate();  // SIGTERM, as Ctrl-C
  const auto r = step.wait(30.0);
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("cancelled"), std::string::npos) << r.err;
  std::this_thread::sleep_for(std::chrono::seconds(2));
  room.sim->terminate();
  ASSERT_EQ(room.sim->wait(30.0).exit_code, 0);

  // The step is recorded as cancelled and its tracking kept.
  const auto state = Json::parse(slurpFile(session / "session.json"));
  EXPECT_EQ(state["steps"]["robot-calibration"]["status"], "cancelled") << state["steps"].dump();
  bool kept = false;
  for (const auto& entry : std::filesystem::directory_iterator(session / "robot-calibration")) {
    kept = kept || (entry.path().extension() == ".mhd" && std::filesystem::file_size(entry.path()) > 0);
  }
  EXPECT_TRUE(kept) << "the recording of the stations reached so far stays in the session";

  // From the truth (the test may read it): the flange marker stops within a second of the signal and stays.
  const auto truth = Json::parse(slurpFile(room.truth));
  const auto& names = truth["tools"];
  std::size_t marker = names.size();
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i] == "FlangeToTracker") marker = i;
  }
  ASSERT_LT(marker, names.size()) << names.dump();
  const auto& samples = truth["tracker_samples"];
  ASSERT_GT(samples.size(), 120U);
  const auto position = [&](const Json& sample) {
    const auto& p = sample["poses"][marker];
    return Eigen::Vector3d(p[0].get<double>(), p[1].get<double>(), p[2].get<double>());
  };
  // The last second before the room stopped (two seconds after the cancel): no motion at all.
  const Eigen::Vector3d last = position(samples.back());
  double moved = 0.0;
  for (std::size_t i = samples.size() - 60; i < samples.size(); ++i) moved = std::max(moved, (position(samples[i]) - last).norm());
  EXPECT_LT(moved, 1e-6) << "mm: the arm is at rest";
  // ... and it had moved during the calibration.
  EXPECT_GT((position(samples.front()) - last).norm(), 1.0);
}

TEST(SimRobotCalibration, OneRoomsTrackerNeverDrivesAnotherRoomsController) {
  const auto dir = scratchDirectory("sim-robot-calibration-two-rooms");
  std::filesystem::create_directories(dir / "a");
  std::filesystem::create_directories(dir / "b");
  auto a = startRobotRoom(dir / "a", 1, R"({"translation_mm": [0, 0, 40]})");
  auto b = startRobotRoom(dir / "b", 2, R"({"translation_mm": [0, 0, 40]})");
  ASSERT_FALSE(a.ready.is_null() || b.ready.is_null());
  const auto session = dir / "session";
  ASSERT_EQ(runCli({"session", "create", session.string()}).exit_code, 0);
  std::vector<std::string> args = {"session", "run", session.string(), "robot-calibration", "--json"};
  const auto params = robotParams(a.ready, b.ready);
  args.insert(args.end(), params.begin(), params.end());
  const auto r = runCli(args);
  a.sim->terminate();
  b.sim->terminate();
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.err.find("never drives another controller"), std::string::npos) << r.err;
  EXPECT_EQ(a.sim->wait(30.0).exit_code, 0);
  EXPECT_EQ(b.sim->wait(30.0).exit_code, 0);
}

}  // namespace
}  // namespace mrsns::test
