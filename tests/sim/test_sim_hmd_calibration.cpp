// The HMD calibration acquired with the headset, from outside (paper 001
// §II.C): the workstation serves the cube's hologram to mrsns-sim's headset
// and asks for four views; the room's operator lines the tracked cube up with
// the hologram where the headset shows it, holds it and confirms on the
// headset; the workstation compensates the tremor of each hold, calibrates each
// view and averages them. `mrsns-sim score` judges HologramToTracker against
// the headset's true world frame.
//
// Noise model (the default scenario's operator, resources/scenarios/default.json,
// hmd::CubeNoiseModel's figures): the hologram's depth misjudged by a 1.5 mm
// bias + 1.0 mm SD along each view, 0.5 mm SD across it, 0.3 deg SD per axis;
// hand tremor 0.5 mm at 8-12 Hz with 0.25 mm/s drift and 2-4 mm slips about
// once a second; the headset's world jitters 0.3 mm RMS per display frame;
// tracker 0.12 mm RMS and 0.05 deg RMS per sample.
#include <gtest/gtest.h>

#include <fstream>
#include <future>

#include "../cli/serve_process.h"
#include "sim_process.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

using Json = nlohmann::json;

/// The default room's headset and cube only (no patient, robot, probe or phantom), its headset pointed at
/// `hmd_port`, with `faults`.
std::filesystem::path writeHmdScenario(const std::filesystem::path& dir, int seed, std::uint16_t hmd_port,
                                       const Json& faults, const Json& cube = Json::object()) {
  Json s = defaultRoomWith("hmd calibration", seed, hmd_port, {"CubeToTracker", "HeadsetToTracker"});
  s["faults"] = faults;
  // Without the board (and so its camera and the stylus touching it).
  s["hmd"].erase("camera");
  s["hmd"].erase("board_touch");
  for (const auto& [key, value] : cube.items()) s["hmd"]["cube"][key] = value;
  const auto file = dir / "hmd.json";
  std::ofstream(file) << s.dump(2);
  return file;
}

struct HmdRun {
  CliResult step, offline, verb;
  Json figures, score, events;
  std::filesystem::path session;
};

HmdRun runHmdCalibration(const std::string& name, int seed, const Json& faults = Json::array(),
                         const std::vector<std::string>& extra = {}) {
  const auto dir = scratchDirectory(name);
  HmdRun run;
  run.session = dir / "session";
  const auto truth = dir / "truth.json";
  const auto hmd_port = freePort();
  SimProcess sim({"run", "--scenario", writeHmdScenario(dir, seed, hmd_port, faults).string(), "--truth",
                  truth.string(), "--ready-file", (dir / "ready.json").string(), "--any-ports", "--json"});
  const auto ready = sim.waitReady(dir / "ready.json");
  EXPECT_FALSE(ready.is_null()) << sim.wait().err;
  if (ready.is_null()) return run;
  EXPECT_EQ(ready["hmd_port"], hmd_port);
  EXPECT_EQ(runCli({"session", "create", run.session.string()}).exit_code, 0);
  std::vector<std::string> args = {"session",    "run",
                                   run.session.string(), "hmd-calibration",
                                   "--param",    "source=hmd",
                                   "--param",    "port=" + std::to_string(ready["plus_port"].get<int>()),
                                   "--param",    "hmd_port=" + std::to_string(hmd_port),
                                   "--param",    "duration_s=120",
                                   "--json"};
  args.insert(args.end(), extra.begin(), extra.end());
  run.step = runCli(args);
  sim.terminate();
  EXPECT_EQ(sim.wait(30.0).exit_code, 0);
  const auto score = runSim({"score", run.session.string(), truth.string(), "--json"});
  EXPECT_EQ(score.exit_code, 0) << score.err;
  if (score.exit_code == 0) run.score = Json::parse(score.out)["scored"];
  run.events = Json::parse(slurpFile(truth)).value("events", Json::array());
  if (run.step.exit_code != 0) return run;
  run.figures = Json::parse(run.step.out)["figures"];
  // Recomputed offline: the session's recording and holds, and the cube points through the CLI verb.
  run.offline = runCli({"session", "run", run.session.string(), "hmd-calibration", "--param", "source=file", "--param",
                        "recording=" + run.figures["recorded"]["file"].get<std::string>(), "--param",
                        "holds=" + run.figures["holds_file"].get<std::string>(), "--json"});
  const auto verb = run.figures["offline_verb"].get<std::string>();
  const auto points = verb.substr(verb.find("--points ") + 9, verb.find(" --omega") - verb.find("--points ") - 9);
  run.verb = runCli({"hmd-calibrate-cube", "--points", points, "--json"});
  return run;
}

void expectSameMatrix(const Json& a, const Json& b, double tolerance) {
  ASSERT_EQ(a.size(), 16U);
  ASSERT_EQ(b.size(), 16U);
  for (std::size_t k = 0; k < 16; ++k) EXPECT_NEAR(a[k].get<double>(), b[k].get<double>(), tolerance) << k;
}

/// Every file the step wrote into the session, and session.json, holds no truth of the room.
void expectNoTruthInSession(const std::filesystem::path& session) {
  for (const auto& entry : std::filesystem::recursive_directory_iterator(session)) {
    if (!entry.is_regular_file() || entry.path().extension() == ".raw") continue;
    const auto text = slurpFile(entry.path());
    for (const char* word : {"truth", "HeadsetWorldToTracker", "perception_error", "hmd_cube_operator"}) {
      EXPECT_EQ(text.find(word), std::string::npos) << entry.path() << " holds '" << word << "'";
    }
  }
}

TEST(SimHmdCalibration, TheCubeLinedUpInFourViewsCalibratesTheHeadsetOverTwoSeeds) {
  std::vector<std::future<HmdRun>> runs;
  for (int seed : {1, 2}) {
    runs.push_back(std::async(std::launch::async, [seed] {
      return runHmdCalibration("sim-hmd-calibration-" + std::to_string(seed), seed);
    }));
  }
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const int seed = static_cast<int>(i) + 1;
    SCOPED_TRACE("seed " + std::to_string(seed));
    const auto run = runs[i].get();
    ASSERT_EQ(run.step.exit_code, 0) << run.step.err << run.step.out;
    const auto& f = run.figures;
    EXPECT_TRUE(f["simulated"].get<bool>());
    ASSERT_EQ(f["views"].size(), 4U);
    int dropped = 0;
    for (const auto& v : f["views"]) {
      EXPECT_EQ(v["confirmed_by"], "headset") << "the operator confirmed on the headset";
      EXPECT_GT(v["samples"].get<int>(), 60) << "2 s of a 60 Hz tracker";
      dropped += v["tremor_dropped_samples"].get<int>();
    }
    // Slips come about once a second: over four 2 s holds (no slip at all: e^-8) the filter drops some (Eq. 14).
    EXPECT_GT(dropped, 0);
    EXPECT_EQ(f["acquisition"]["headset_drops"], 0);
    // Scored from outside. Error budget at the cube's hologram from the noise model: the operator's depth bias
    // (1.5 mm along each view) averages over the four views' directions to 0.69 x 1.5 = 1.04 mm; the per-match
    // errors (1.0 mm depth, 0.5 mm across, 0.3 mm headset jitter: 1.25 mm 3D RMS) average to 0.63 mm over four;
    // three times that on top of the bias, 2.9 mm, bounds it. The rotation: 0.52 deg 3D RMS per match averages
    // to 0.26 deg; three times that, 0.8 deg.
    ASSERT_TRUE(run.score.contains("hmd_calibration")) << run.score.dump();
    const auto& h = run.score["hmd_calibration"];
    EXPECT_LT(h["error_at_cube_hologram_mm"].get<double>(), 2.9) << h.dump();
    EXPECT_LT(h["rotation_error_deg"].get<double>(), 0.8) << h.dump();
    std::printf("[ figures ] seed %d: HologramToTracker error at the cube's hologram %.2f mm, rotation %.2f deg; "
                "views agree within %.1f mm, %.2f deg\n",
                seed, h["error_at_cube_hologram_mm"].get<double>(), h["rotation_error_deg"].get<double>(),
                f["view_spread"]["max_pairwise_translation_mm"].get<double>(),
                f["view_spread"]["max_pairwise_rotation_deg"].get<double>());
    // The same numbers offline, from the session's recording and holds, and from the CLI verb on the points file.
    ASSERT_EQ(run.offline.exit_code, 0) << run.offline.err;
    expectSameMatrix(Json::parse(run.offline.out)["figures"]["transforms"]["HologramToTracker"],
                     f["transforms"]["HologramToTracker"], 1e-9);
    ASSERT_EQ(run.verb.exit_code, 0) << run.verb.err;
    expectSameMatrix(Json::parse(run.verb.out)["HologramToTracker"], f["transforms"]["HologramToTracker"], 1e-9);
    expectNoTruthInSession(run.session);
  }
}

/// One room, two sessions calibrated in it one after the other with `first` and `second` parameters; both scored
/// against the room's truth.
std::pair<Json, Json> twoCalibrationsInOneRoom(const std::string& name, int seed, const std::vector<std::string>& first,
                                               const std::vector<std::string>& second) {
  const auto dir = scratchDirectory(name);
  const auto truth = dir / "truth.json";
  const auto hmd_port = freePort();
  SimProcess sim({"run", "--scenario", writeHmdScenario(dir, seed, hmd_port, Json::array()).string(), "--truth",
                  truth.string(), "--ready-file", (dir / "ready.json").string(), "--any-ports", "--json"});
  const auto ready = sim.waitReady(dir / "ready.json");
  EXPECT_FALSE(ready.is_null()) << sim.wait().err;
  if (ready.is_null()) return {};
  std::vector<std::filesystem::path> sessions = {dir / "a", dir / "b"};
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(runCli({"session", "create", sessions[i].string()}).exit_code, 0);
    std::vector<std::string> args = {"session", "run", sessions[i].string(), "hmd-calibration", "--param",
                                     "source=hmd", "--param", "port=" + std::to_string(ready["plus_port"].get<int>()),
                                     "--param", "hmd_port=" + std::to_string(hmd_port), "--json"};
    for (const auto& p : i == 0 ? first : second) args.insert(args.end(), {"--param", p});
    const auto r = runCli(args);
    EXPECT_EQ(r.exit_code, 0) << r.err;
  }
  sim.terminate();
  EXPECT_EQ(sim.wait(30.0).exit_code, 0);
  std::pair<Json, Json> scores;
  for (std::size_t i = 0; i < 2; ++i) {
    const auto score = runSim({"score", sessions[i].string(), truth.string(), "--json"});
    EXPECT_EQ(score.exit_code, 0) << score.err;
    if (score.exit_code == 0) (i == 0 ? scores.first : scores.second) = Json::parse(score.out)["scored"];
  }
  return scores;
}

TEST(SimHmdCalibration, ThePapersUncompensatedControlInTheSameRoomsOverThreeSeeds) {
  // Paper 001 Fig. 7's comparison in the room: its method (four views, tremor compensation) and its control
  // (four matches from the front view, each fiducial from the sample at the confirmation), the same operator.
  // Bounds from the noise model: the method as above (2.9 mm); the control keeps the whole 1.5 mm depth bias
  // along one view, the per-match errors (1.25 mm 3D RMS) average to 0.63 mm over four, and the confirmation's
  // sample adds the hand (0.5 mm tremor, a 2-4 mm slip 5 % of the time) averaged over four: 1.5 + 3 x 0.75 mm.
  std::vector<std::future<std::pair<Json, Json>>> runs;
  for (int seed : {1, 2, 3}) {
    runs.push_back(std::async(std::launch::async, [seed] {
      return twoCalibrationsInOneRoom("sim-hmd-control-" + std::to_string(seed), seed, {},
                                      {"views=front,front,front,front", "tremor_compensation=false"});
    }));
  }
  double sum_method = 0.0, sum_control = 0.0;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    SCOPED_TRACE("seed " + std::to_string(i + 1));
    const auto [method, control] = runs[i].get();
    ASSERT_TRUE(method.contains("hmd_calibration")) << method.dump();
    ASSERT_TRUE(control.contains("hmd_calibration")) << control.dump();
    const double m = method["hmd_calibration"]["error_at_cube_hologram_mm"].get<double>();
    const double c = control["hmd_calibration"]["error_at_cube_hologram_mm"].get<double>();
    EXPECT_LT(m, 2.9);
    EXPECT_LT(c, 3.75);
    sum_method += m;
    sum_control += c;
    std::printf("[ figures ] seed %zu: HologramToTracker error at the cube's hologram: four views compensated %.2f mm "
                "(%.2f deg), one view uncompensated %.2f mm (%.2f deg)\n",
                i + 1, m, method["hmd_calibration"]["rotation_error_deg"].get<double>(), c,
                control["hmd_calibration"]["rotation_error_deg"].get<double>());
  }
  std::printf("[ figures ] mean over 3 seeds: compensated four views %.2f mm, uncompensated front view %.2f mm\n",
              sum_method / 3.0, sum_control / 3.0);
}

TEST(SimHmdCalibration, AnOccludedHoldIsAskedAgainAndAHeadsetThatLeftIsWaitedFor) {
  // The cube's marker is hidden for the first 14 s (the first view's hold, and maybe its second try, however
  // late the step starts on a loaded machine); the headset drops off for 3 s at 28 s, a view or two later.
  const auto run = runHmdCalibration(
      "sim-hmd-calibration-faults", 3,
      Json::parse(R"([{"kind": "occlusion", "tool": "CubeToTracker", "at_s": 0.0, "duration_s": 14.0},
                      {"kind": "hmd_disconnect", "at_s": 28.0, "duration_s": 3.0}])"));
  ASSERT_EQ(run.step.exit_code, 0) << run.step.err << run.step.out;
  const auto& a = run.figures["acquisition"];
  ASSERT_FALSE(a["rejected_holds"].empty()) << a.dump();
  EXPECT_NE(a["rejected_holds"][0].get<std::string>().find("not tracked"), std::string::npos) << a.dump();
  EXPECT_GE(a["headset_drops"].get<int>(), 1) << a.dump();
  EXPECT_EQ(run.figures["views"].size(), 4U);
  EXPECT_NE(Json::parse(run.step.out)["summary"].get<std::string>().find("the headset left"), std::string::npos);
  bool dropped = false;
  for (const auto& e : run.events) dropped = dropped || e["event"].get<std::string>().find("hmd_disconnect") == 0;
  EXPECT_TRUE(dropped) << run.events.dump();
}

TEST(SimHmdCalibration, TheOperatorConfirmsWithAPedalAtTheWorkstation) {
  // The operator confirms with the foot pedal (a line on the CLI's stdin), not on the headset: the cube is held
  // long enough (10 s) for a press every 6 s to find it on the hologram. A press that lands while the cube is
  // still moving gives a hold that moved too much, which is refused and asked again.
  const auto dir = scratchDirectory("sim-hmd-calibration-pedal");
  const auto session = dir / "session";
  const auto truth = dir / "truth.json";
  const auto hmd_port = freePort();
  SimProcess sim({"run", "--scenario",
                  writeHmdScenario(dir, 5, hmd_port, Json::array(), {{"confirm_on_headset", false}, {"hold_s", 10.0}})
                      .string(),
                  "--truth", truth.string(), "--ready-file", (dir / "ready.json").string(), "--any-ports", "--json"});
  const auto ready = sim.waitReady(dir / "ready.json");
  ASSERT_FALSE(ready.is_null()) << sim.wait().err;
  ASSERT_EQ(runCli({"session", "create", session.string()}).exit_code, 0);
  const std::string command = "for i in $(seq 14); do sleep 6; echo; done | '" + cliBinary().string() +
                              "' session run '" + session.string() +
                              "' hmd-calibration --confirm-on-enter --param source=hmd --param port=" +
                              std::to_string(ready["plus_port"].get<int>()) +
                              " --param hmd_port=" + std::to_string(hmd_port) + " --param duration_s=90 --json";
  const auto step = runProgram("/bin/bash", {"-c", command});
  sim.terminate();
  EXPECT_EQ(sim.wait(30.0).exit_code, 0);
  ASSERT_EQ(step.exit_code, 0) << step.err << step.out;
  const auto figures = Json::parse(step.out)["figures"];
  ASSERT_EQ(figures["views"].size(), 4U);
  for (const auto& v : figures["views"]) EXPECT_EQ(v["confirmed_by"], "key") << "the pedal, not the headset";
  const auto score = runSim({"score", session.string(), truth.string(), "--json"});
  ASSERT_EQ(score.exit_code, 0) << score.err;
  const auto h = Json::parse(score.out)["scored"]["hmd_calibration"];
  EXPECT_LT(h["error_at_cube_hologram_mm"].get<double>(), 2.9) << h.dump();
}

TEST(SimHmdCalibration, AHeadsetThatDoesNotComeBackFailsTheStepAndKeepsWhatWasRecorded) {
  const auto run = runHmdCalibration("sim-hmd-calibration-gone", 4,
                                     Json::parse(R"([{"kind": "hmd_disconnect", "at_s": 16.0, "duration_s": 600.0}])"),
                                     {"--param", "hmd_wait_s=5"});
  ASSERT_EQ(run.step.exit_code, 1) << run.step.out;
  EXPECT_NE(run.step.err.find("the headset left and did not come back"), std::string::npos) << run.step.err;
  EXPECT_NE(run.step.err.find("kept:"), std::string::npos) << run.step.err;
  const auto folder = run.session / "hmd-calibration";
  EXPECT_TRUE(std::filesystem::exists(folder / "CubeHolds.mhd"));
  ASSERT_TRUE(std::filesystem::exists(folder / "holds.json"));
  const auto holds = Json::parse(slurpFile(folder / "holds.json"));
  EXPECT_GE(holds["holds"].size(), 1U) << "the first view, held before the headset left, is kept";
  EXPECT_FALSE(run.score.contains("hmd_calibration")) << "a failed calibration is not judged";
}

}  // namespace
}  // namespace mrsns::test
