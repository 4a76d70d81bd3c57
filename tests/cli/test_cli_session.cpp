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

namespace mrsns::test {
namespace {

/// The preparation from the CLI alone, as a user types it: the real CT and its TotalSegmentator labels
/// into a new session, L1-L4 and the vessels meshed, bilateral pedicle screws at two levels named from the
/// anatomy (no name= given), their figures in `session info --json`, the plan exported as Slicer markups. Each
/// verb is its own process, so every step reads what the one before saved.
TEST(CliSession, RealCtPreparedAndPlannedFromTheCommandLine) {
  MRSNS_REQUIRE_DATA(ct, "ct/totalsegmentator/example_ct.nii.gz");
  MRSNS_REQUIRE_DATA(vertebrae, "ct/totalsegmentator/spine_report/example_ct_report/totalseg.nii.gz");
  MRSNS_REQUIRE_DATA(organs, "ct/totalsegmentator/example_seg.nii.gz");
  const auto dir = scratchDirectory("session-prep") / "patient";
  const auto run = [&](std::vector<std::string> args) {
    args.insert(args.begin(), {"session", "run", dir.string()});
    args.push_back("--json");
    const auto r = runCli(args);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return r.exit_code == 0 ? nlohmann::json::parse(r.out) : nlohmann::json();
  };
  ASSERT_EQ(runCli({"session", "create", dir.string()}).exit_code, 0);
  ASSERT_TRUE(run({"import-ct", "--param", "path=" + ct.string()})["ok"].get<bool>());
  run({"import-label-map", "--param", "path=" + vertebrae.string()});
  run({"import-label-map", "--param", "path=" + organs.string(), "--param", "align_to=labels"});
  const auto models = run({"make-models", "--param", "label_map=labels", "--param", "labels=L1,L2,L3,L4"});
  ASSERT_TRUE(models.is_object());
  run({"make-models", "--param", "label_map=labels-2", "--param", "labels=aorta,inferior_vena_cava,spinal_cord"});
  // Entry and target only: each screw named after the vertebra it lies in and the side it enters from.
  const std::vector<std::pair<std::string, std::string>> ends = {{"25.5,-84,382", "5.5,-134,382"},
                                                                 {"-18.5,-84,382", "1.5,-134,382"},
                                                                 {"24,-92,350", "10,-142,356"},
                                                                 {"-17,-93,355", "-5,-143,358"}};
  for (const auto& [entry, target] : ends) {
    run({"plan-screw", "--param", "entry=" + entry, "--param", "target=" + target, "--param", "diameter_mm=6",
         "--param", "length_mm=45"});
  }
  const auto info = runCli({"session", "info", dir.string(), "--json"});
  ASSERT_EQ(info.exit_code, 0) << info.err;
  const auto j = nlohmann::json::parse(info.out);
  EXPECT_EQ(j["version"], 2);
  EXPECT_EQ(j["ct"]["size_px"], nlohmann::json::array({122, 101, 112}));
  ASSERT_EQ(j["plans"].size(), 4u);
  std::vector<std::string> names;
  for (const auto& screw : j["plans"]) {
    names.push_back(screw["name"]);
    SCOPED_TRACE(names.back());
    EXPECT_EQ(screw["provenance"]["source"], "user");
    EXPECT_FALSE(screw["provenance"]["simulated"].get<bool>());
    const auto& clearance = screw["figures"]["clearance"];
    ASSERT_TRUE(clearance["vessel"].is_object()) << screw.dump();
    EXPECT_GT(clearance["vessel"]["min_clearance_mm"].get<double>(), 5.0);
    ASSERT_TRUE(clearance["neural"].is_object());
    EXPECT_EQ(clearance["neural"]["name"], "spinal_cord");
    EXPECT_LT(screw["figures"]["breach"]["max_breach_mm"].get<double>(), 2.0);
  }
  EXPECT_EQ(names, (std::vector<std::string>{"L1 left", "L1 right", "L2 left", "L2 right"}));
  // L1-L4 closed, their mesh volume within the voxel-size tolerance of their voxels.
  int bone_models = 0;
  for (const auto& m : j["models"]) {
    if (m["role"] != "bone") continue;
    ++bone_models;
    EXPECT_NEAR(m["volume_ml"].get<double>(), m["voxel_volume_ml"].get<double>(), m["volume_tolerance_ml"].get<double>())
        << m["id"];
  }
  EXPECT_EQ(bone_models, 4);

  // A second screw at the same place is named "Screw 5", never a duplicate of "L1 left".
  const auto again = run({"plan-screw", "--param", "entry=25.5,-84,382", "--param", "target=5.5,-134,382"});
  EXPECT_EQ(again["figures"]["screw"]["name"], "Screw 5");
  const auto removed = run({"plan-screw", "--param", "name=Screw 5", "--param", "remove=true"});
  EXPECT_TRUE(removed["ok"].get<bool>());

  const auto exported = dir.parent_path() / "plan.mrk.json";
  run({"export-plan", "--param", "path=" + exported.string()});
  const auto markups = runCli({"info", exported.string(), "--json"});
  ASSERT_EQ(markups.exit_code, 0) << markups.err;
  EXPECT_EQ(nlohmann::json::parse(markups.out)["markup_type"], "Line");
  const std::string text = slurpFile(exported);
  for (const char* name : {"\"L1 left\"", "\"L1 right\"", "\"L2 left\"", "\"L2 right\""}) {
    EXPECT_NE(text.find(name), std::string::npos) << name;
  }
  EXPECT_EQ(text.find("Screw 5"), std::string::npos) << "the removed screw is not exported";
}

}  // namespace
}  // namespace mrsns::test
