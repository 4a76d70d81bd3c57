// The pivot-calibration step acquired live from mrsns-sim, from outside:
// the stylus is pivoted in its divot (a Lissajous swing of 25 deg about two
// axes) while the tracker streams it over OpenIGTLink. The step records the
// stream into the session, stops once the swing covers two directions, and
// finds the tip; `mrsns-sim score` judges the tip against the scenario's,
// which the workstation never sees.
//
// Noise model (stated with every figure): tracker 0.12 mm RMS position and
// 0.05 deg RMS orientation per sample; hand tremor 0.3 mm RMS at 8-12 Hz,
// drift 0.2 mm at 0.05 Hz; the stylus is occluded for 0.5 s every 3 s (from 3 s after the room starts), so
// a six-second capture holds at least one occlusion however late a loaded machine connects.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <fstream>

#include "loopback_ports.h"
#include "mrsns/io/sequence_file.h"
#include "sim_process.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

using Json = nlohmann::json;

std::filesystem::path writeScenario(const std::filesystem::path& dir, int seed, bool one_axis) {
  const auto file = dir / "pivot.json";
  std::ofstream(file) << R"({"format": "mrsns-scenario/1", "name": "pivot in a divot", "seed": )" << seed << R"(,
    "tracker": {"port": 0, "noise": {"position_rms_mm": 0.12, "orientation_rms_deg": 0.05}},
    "tools": [
      {"name": "ReferenceToTracker", "marker_radius_mm": 40, "start": {"translation_mm": [-260, -40, -1450]}},
      {"name": "StylusToTracker", "tip_mm": [0, 0, -160], "marker_radius_mm": 30,
       "start": {"translation_mm": [150, -60, -1200]},
       "hand": {"tremor_rms_mm": 0.3, "tremor_hz": [8, 12], "drift_mm": 0.2, "drift_hz": 0.05},
       "motion": [{"kind": "hold", "duration_s": 0.5},
                  {"kind": "pivot", "amplitude_deg": 25, "frequency_hz": 0.2, "duration_s": 60, "one_axis": )"
                      << (one_axis ? "true" : "false") << R"(}]}],
    "faults": [{"kind": "occlusion", "tool": "StylusToTracker", "at_s": 3.0, "duration_s": 0.5},
               {"kind": "occlusion", "tool": "StylusToTracker", "at_s": 6.0, "duration_s": 0.5},
               {"kind": "occlusion", "tool": "StylusToTracker", "at_s": 9.0, "duration_s": 0.5},
               {"kind": "occlusion", "tool": "StylusToTracker", "at_s": 12.0, "duration_s": 0.5}]})";
  return file;
}

struct PivotRun {
  CliResult step;
  Json figures;
  std::filesystem::path session;
  std::filesystem::path truth;
};

PivotRun runPivot(const std::string& name, int seed, bool one_axis, const std::vector<std::string>& extra = {}) {
  const auto dir = scratchDirectory(name);
  PivotRun run;
  run.session = dir / "session";
  run.truth = dir / "truth.json";
  SimProcess sim({"run", "--scenario", writeScenario(dir, seed, one_axis).string(), "--truth", run.truth.string(),
                  "--ready-file", (dir / "ready.json").string(), "--any-ports", "--json"});
  const auto ready = sim.waitReady(dir / "ready.json");
  EXPECT_FALSE(ready.is_null()) << sim.wait().err;
  if (ready.is_null()) return run;
  EXPECT_EQ(runCli({"session", "create", run.session.string()}).exit_code, 0);
  std::vector<std::string> args = {"session", "run",  run.session.string(), "pivot-calibration", "--param",
                                   "port=" + std::to_string(ready["plus_port"].get<int>()),   "--json"};
  args.insert(args.end(), extra.begin(), extra.end());
  run.step = runCli(args);
  sim.terminate();
  EXPECT_EQ(sim.wait(30.0).exit_code, 0);
  if (run.step.exit_code == 0) run.figures = Json::parse(run.step.out)["figures"];
  return run;
}

TEST(SimPivot, TheLivePivotFindsTheTipOverSeedsAndTheOfflineVerbAgrees) {
  for (int seed : {1, 2, 3}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    // 360 poses (six seconds): at least one of the occlusions falls inside the capture.
    const auto run = runPivot("sim-pivot-" + std::to_string(seed), seed, false, {"--param", "min_poses=360"});
    ASSERT_EQ(run.step.exit_code, 0) << run.step.err;
    const auto out = Json::parse(run.step.out);
    ASSERT_TRUE(out["ok"].get<bool>()) << out["summary"];
    const auto& f = run.figures;
    EXPECT_TRUE(f["simulated"].get<bool>());
    EXPECT_TRUE(f["recorded"]["complete"].get<bool>()) << "the swing reached 30 x 30 deg and the step ended itself";
    // The 0.5 s occlusion: its frames are left out and counted, never used.
    EXPECT_GE(f["recorded"]["skipped_missing"].get<int>() + f["recorded"]["skipped_invalid"].get<int>(), 20);
    EXPECT_NE(out["summary"].get<std::string>().find("left out"), std::string::npos) << out["summary"];

    // Scored from outside against the scenario's tip. With ~360 poses the tip is found well inside the per-pose
    // scatter (tremor and tracker noise: the fit's own residual RMS, ~0.45 mm).
    const auto score = runSim({"score", run.session.string(), run.truth.string(), "--json"});
    ASSERT_EQ(score.exit_code, 0) << score.err;
    const auto s = Json::parse(score.out)["scored"]["pivot_calibration"];
    const double error = s["tip_error_mm"].get<double>();
    EXPECT_LT(error, f["rms_mm"].get<double>()) << "tip error against the truth";
    EXPECT_LT(error, 0.5);
    std::printf("[ figures ] seed %d: tip error %.3f mm (residual RMS %.3f mm, %d poses, swing %.0f x %.0f deg, "
                "%.1f s)\n",
                seed, error, f["rms_mm"].get<double>(), f["recorded"]["poses"].get<int>(),
                f["swing_deg"][0].get<double>(), f["swing_deg"][1].get<double>(),
                f["recorded"]["seconds"].get<double>());

    // The recording in the session holds what the step used; the offline verb on it gives the same tip.
    const auto recording = run.session / f["recorded"]["file"].get<std::string>();
    EXPECT_EQ(io::readSequenceHeader(recording).frames.size(), f["recorded"]["frames"].get<std::size_t>());
    const auto offline = runCli({"calibrate-pivot", "--sequence", recording.string(), "--transform",
                                 "StylusToReference", "--robust", "--inlier-threshold", "1", "--min-rotation-deg",
                                 "20", "--json"});
    ASSERT_EQ(offline.exit_code, 0) << offline.err;
    const auto o = Json::parse(offline.out);
    for (std::size_t i = 0; i < 3; ++i) {
      EXPECT_NEAR(o["tip_marker_mm"][i].get<double>(), f["tip_marker_mm"][i].get<double>(), 1e-9);
    }
    EXPECT_NEAR(o["rms_mm"].get<double>(), f["rms_mm"].get<double>(), 1e-9);
    // The truth stays outside: nothing in the session names the scenario's tip or its truth file.
    const auto session_json = slurpFile(run.session / "session.json");
    EXPECT_EQ(session_json.find("tip_mm"), std::string::npos);
    EXPECT_EQ(session_json.find("truth"), std::string::npos);
  }
}

TEST(SimPivot, APivotAboutOneAxisIsRefusedAndItsRecordingKept) {
  const auto run = runPivot("sim-pivot-one-axis", 4, true, {"--param", "duration_s=5"});
  ASSERT_EQ(run.step.exit_code, 1) << run.step.out;
  EXPECT_NE(run.step.err.find("one direction only"), std::string::npos) << run.step.err;
  EXPECT_NE(run.step.err.find("two directions"), std::string::npos) << run.step.err;
  const auto info = runCli({"session", "info", run.session.string(), "--json"});
  ASSERT_EQ(info.exit_code, 0) << info.err;
  const auto step = Json::parse(slurpFile(run.session / "session.json"))["steps"]["pivot-calibration"];
  EXPECT_EQ(step["status"], "failed");
  const auto kept = run.session / step["figures"]["recorded"]["file"].get<std::string>();
  EXPECT_GT(io::readSequenceHeader(kept).frames.size(), 200u) << "five seconds of tracking at 60 Hz, kept";
  EXPECT_LT(step["figures"]["swing_deg"][1].get<double>(), 20.0);
}

TEST(SimPivot, NoTrackerListeningIsAClearErrorNamingTheAddress) {
  const auto dir = scratchDirectory("sim-pivot-none");
  ASSERT_EQ(runCli({"session", "create", (dir / "s").string()}).exit_code, 0);
  const int port = closedPort();
  const auto r = runCli({"session", "run", (dir / "s").string(), "pivot-calibration", "--param",
                         "port=" + std::to_string(port), "--param", "connect_timeout_s=1", "--json"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("127.0.0.1:" + std::to_string(port)), std::string::npos) << r.err;
  const auto bad = runCli({"session", "run", (dir / "s").string(), "pivot-calibration", "--param", "source=file"});
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("recording"), std::string::npos) << bad.err;
}

}  // namespace
}  // namespace mrsns::test
