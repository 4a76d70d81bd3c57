// mrsns-sim from outside: scenario checks and refusals (exit 1, one line),
// usage errors (exit 2), the workstation's connect-devices step against a
// running simulated operating room, the truth file and the scorer.
#include <gtest/gtest.h>

#include <fstream>

#include "sim_process.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

using Json = nlohmann::json;

std::filesystem::path writeFile(const std::filesystem::path& dir, const std::string& name, const std::string& text) {
  std::ofstream(dir / name) << text;
  return dir / name;
}

void expectOneLineError(const CliResult& r, const std::string& contains) {
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line: " << r.err;
  EXPECT_NE(r.err.find(contains), std::string::npos) << r.err;
}

TEST(SimCli, TheDefaultScenarioChecksOut) {
  MRSNS_REQUIRE_DATA(config, "plus/PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml");
  const auto r = runSim({"check", defaultScenario().string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = Json::parse(r.out);
  EXPECT_TRUE(j["ok"].get<bool>());
  EXPECT_TRUE(j["ultrasound"].get<bool>());
  EXPECT_TRUE(j["robot"].get<bool>());
  EXPECT_EQ(j["patient"], "generated phantom");
}

TEST(SimCli, BadScenariosAreRefusedWithOneLine) {
  const auto dir = scratchDirectory("bad");
  expectOneLineError(runSim({"check", writeFile(dir, "typo.json", R"({"format": "mrsns-scenario/1",
      "tools": [{"name": "StylusToTracker", "colour": "red"}]})")
                                          .string()}),
                     "unknown key 'tools[0].colour'");
  expectOneLineError(runSim({"check", writeFile(dir, "ct.json", R"({"format": "mrsns-scenario/1",
      "tools": [{"name": "ReferenceToTracker"}], "patient": {"labels": "missing_labels.nii.gz"}})")
                                          .string()}),
                     "missing_labels.nii.gz does not exist");
  expectOneLineError(runSim({"check", writeFile(dir, "reach.json", R"({"format": "mrsns-scenario/1",
      "tools": [{"name": "ReferenceToTracker", "start": {"translation_mm": [0, 0, -1400]}}],
      "patient": {"generated_phantom": {"spacing_mm": 2.0}, "reference_tool": "ReferenceToTracker"},
      "robot": {"base_to_tracker": {"translation_mm": [0, 1200, -1400]}}})")
                                          .string()}),
                     "850 mm reach");
  expectOneLineError(
      runSim({"run", "--scenario", writeFile(dir, "json.json", "{").string(), "--truth", (dir / "t.json").string()}),
      "not valid JSON");
}

TEST(SimCli, TheRealCtsLabelMapIsAPatient) {
  MRSNS_REQUIRE_DATA(labels, "ct/totalsegmentator/spine_report/example_ct_report/totalseg.nii.gz");
  const auto dir = scratchDirectory("realct");
  const auto scenario = writeFile(dir, "ct.json", R"({"format": "mrsns-scenario/1",
      "tools": [{"name": "ReferenceToTracker", "start": {"translation_mm": [0, 0, -1400]}},
                {"name": "ProbeToTracker", "start": {"translation_mm": [0, 60, -1400]}}],
      "patient": {"labels": ")" + labels.string() + R"(", "reference_tool": "ReferenceToTracker"},
      "ultrasound": {"width": 128, "height": 96}})");
  const auto r = runSim({"check", scenario.string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(Json::parse(r.out)["patient"].get<std::string>().find("totalseg.nii.gz"), std::string::npos);
}

TEST(SimCli, UsageErrorsExitTwo) {
  EXPECT_EQ(runSim({"run", "--scenario", defaultScenario().string()}).exit_code, 2) << "--truth is required";
  EXPECT_EQ(runSim({"frobnicate"}).exit_code, 2);
  EXPECT_EQ(runSim({"run", "--scenario", "/no/such/scenario.json", "--truth", "t.json"}).exit_code, 2);
}

TEST(SimCli, APortInUseIsRefusedWithOneLine) {
  const auto dir = scratchDirectory("port");
  const auto scenario = writeFile(dir, "s.json", R"({"format": "mrsns-scenario/1", "tracker": {"port": 0},
      "tools": [{"name": "StylusToTracker", "start": {"translation_mm": [0, 0, -1300]}}]})");
  SimProcess first({"run", "--scenario", scenario.string(), "--truth", (dir / "t1.json").string(), "--ready-file",
                    (dir / "ready1.json").string()});
  const auto ready = first.waitReady(dir / "ready1.json");
  ASSERT_FALSE(ready.is_null()) << first.wait().err;
  const int port = ready["plus_port"].get<int>();
  const auto clash = writeFile(dir, "clash.json",
                               R"({"format": "mrsns-scenario/1", "tracker": {"port": )" + std::to_string(port) + R"(},
      "tools": [{"name": "StylusToTracker", "start": {"translation_mm": [0, 0, -1300]}}]})");
  expectOneLineError(runSim({"run", "--scenario", clash.string(), "--truth", (dir / "t2.json").string()}),
                     "tracker.port");
  first.terminate();
  EXPECT_EQ(first.wait().exit_code, 0);
}

TEST(SimCli, ConnectDevicesSeesEveryToolOfTheDefaultScenarioAtItsRate) {
  MRSNS_REQUIRE_DATA(config, "plus/PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml");
  const auto dir = scratchDirectory("connect");
  SimProcess sim({"run", "--scenario", defaultScenario().string(), "--any-ports", "--duration", "0", "--truth",
                  (dir / "truth.json").string(), "--ready-file", (dir / "ready.json").string(), "--json"});
  const auto ready = sim.waitReady(dir / "ready.json", 60.0);
  ASSERT_FALSE(ready.is_null()) << sim.wait().err;
  ASSERT_EQ(runCli({"session", "create", (dir / "session").string()}).exit_code, 0);
  const auto r =
      runCli({"session", "run", (dir / "session").string(), "connect-devices", "--param", "source=plus", "--param",
              "port=" + std::to_string(ready["plus_port"].get<int>()), "--param", "duration_s=2", "--json"});
  sim.terminate();
  const auto end = sim.wait();
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto figures = Json::parse(r.out)["figures"];
  for (const char* name :
       {"PatientToTracker", "ReferenceToTracker", "StylusToTracker", "ProbeToTracker", "FlangeToTracker"}) {
    ASSERT_TRUE(figures["tools"].contains(name)) << name << " missing from " << figures.dump();
    EXPECT_NEAR(figures["tools"][name]["rate_hz"].get<double>(), 60.0, 3.0) << name;
  }
  ASSERT_EQ(end.exit_code, 0) << end.err;
  const auto summary = Json::parse(end.out);
  EXPECT_EQ(summary["stopped_by"], "signal");
  EXPECT_GT(summary["messages"]["IMAGE"].get<int>(), 0) << "the B-mode video reached the workstation too";
  EXPECT_TRUE(std::filesystem::exists(dir / "truth.json"));
}

TEST(SimCli, ScoreComparesASessionWithTheTruth) {
  const auto dir = scratchDirectory("score");
  const auto scenario = writeFile(dir, "s.json", R"({"format": "mrsns-scenario/1", "tracker": {"port": 0},
      "tools": [{"name": "ReferenceToTracker", "start": {"translation_mm": [0, 0, -1300]}},
                {"name": "ProbeToTracker", "start": {"translation_mm": [0, 50, -1300]}}],
      "patient": {"generated_phantom": {"spacing_mm": 2.0}, "reference_tool": "ReferenceToTracker"},
      "ultrasound": {"width": 100, "height": 80, "spacing_mm": [0.2, 0.1], "rate_hz": 10,
                     "image_to_probe": {"translation_mm": [1, 2, 3]}},
      "duration_s": 0.5})");
  const auto run = runSim({"run", "--scenario", scenario.string(), "--truth", (dir / "truth.json").string(), "--json"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(Json::parse(run.out)["stopped_by"], "duration");
  // A session whose spatial calibration is the truth shifted by 1 mm along x: 1 mm at every corner.
  std::filesystem::create_directories(dir / "session");
  const Json session{
      {"version", 1},
      {"steps",
       {{"us-spatial-calibration",
         {{"status", "ok"},
          {"figures",
           {{"simulated", true},
            {"transforms", {{"ImageToProbe", {0.2, 0, 0, 2, 0, 0.1, 0, 2, 0, 0, 1, 3, 0, 0, 0, 1}}}}}}}}}},
      {"log", Json::array()}};
  std::ofstream(dir / "session" / "session.json") << session.dump();
  const auto score = runSim({"score", (dir / "session").string(), (dir / "truth.json").string(), "--json"});
  ASSERT_EQ(score.exit_code, 0) << score.err;
  const auto j = Json::parse(score.out);
  EXPECT_NEAR(j["scored"]["us_spatial_calibration"]["error"]["mean_mm"].get<double>(), 1.0, 1e-9);
  EXPECT_NEAR(j["scored"]["us_spatial_calibration"]["error"]["max_mm"].get<double>(), 1.0, 1e-9);
  EXPECT_FALSE(j["not_scored"].empty()) << "the steps that did not run are listed";
  expectOneLineError(runSim({"score", (dir / "session").string(), scenario.string()}), "not an mrsns-sim truth file");

  // The same result computed from other data (a recording of a real probe, an in-process simulation) is
  // not judged by this room's truth.
  for (const Json& figures :
       {Json{{"simulated", false}, {"transforms", {{"ImageToProbe", Json(session["steps"]["us-spatial-calibration"]
                                                                          ["figures"]["transforms"]["ImageToProbe"])}}}},
        Json{{"simulated", true},
             {"simulation_truth", Json::object()},
             {"transforms", {{"ImageToProbe", Json::array({1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1})}}}}}) {
    Json other = session;
    other["steps"]["us-spatial-calibration"]["figures"] = figures;
    std::ofstream(dir / "session" / "session.json") << other.dump();
    const auto r = runSim({"score", (dir / "session").string(), (dir / "truth.json").string(), "--json"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto k = Json::parse(r.out);
    EXPECT_FALSE(k["scored"].contains("us_spatial_calibration")) << figures.dump();
    EXPECT_NE(k["not_scored"].dump().find("not acquired from mrsns-sim"), std::string::npos) << k.dump();
  }
}

}  // namespace
}  // namespace mrsns::test
