// Scenario files: strict keys with the key path in the message, poses, the
// default scenario of the phantom trial, cross-checks between devices.
#include <gtest/gtest.h>

#include <filesystem>

#include "mrsns/core/error.h"
#include "mrsns/simulation/scenario.h"
#include "test_data.h"

namespace mrsns::simulation {
namespace {

std::string minimal(const std::string& extra_tool_keys = "", const std::string& extra_root = "") {
  return R"({"format": "mrsns-scenario/1", "tools": [{"name": "StylusToTracker")" + extra_tool_keys + "}]" +
         extra_root + "}";
}

std::string messageOf(const std::string& json) {
  try {
    (void)parseScenario(json, ".", "s.json");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Scenario, MinimalScenarioHasTheDocumentedDefaults) {
  const auto s = parseScenario(minimal(), ".");
  ASSERT_EQ(s.tools.size(), 1u);
  EXPECT_EQ(s.tracker.bind_address, "127.0.0.1");
  EXPECT_EQ(s.tracker.port, 18944);
  EXPECT_DOUBLE_EQ(s.tracker.rate_hz, 60.0);
  EXPECT_DOUBLE_EQ(s.tracker.noise.position_rms_mm, 0.12);
  EXPECT_TRUE(s.tracker.send_valid_transforms_only);
  EXPECT_FALSE(s.ultrasound.enabled);
  EXPECT_FALSE(s.robot.enabled);
}

TEST(Scenario, UnknownKeysAreRefusedWithTheirPath) {
  EXPECT_NE(messageOf(minimal(R"(, "tip": [0,0,1])")).find("'tools[0].tip'"), std::string::npos);
  EXPECT_NE(messageOf(minimal("", R"(, "trackr": {})")).find("unknown key 'trackr'"), std::string::npos);
  const auto m = messageOf(minimal(R"(, "motion": [{"kind": "hold", "durration_s": 1}])"));
  EXPECT_NE(m.find("tools[0].motion[0].durration_s"), std::string::npos) << m;
  EXPECT_NE(m.find("duration_s"), std::string::npos) << "the message lists the known keys: " << m;
}

TEST(Scenario, BadValuesAreRefusedWithWhatIsAllowed) {
  EXPECT_NE(messageOf(minimal("", R"(, "tracker": {"rate_hz": 0})")).find("outside"), std::string::npos);
  EXPECT_NE(messageOf(minimal(R"(, "motion": [{"kind": "twirl"}])")).find("use one of"), std::string::npos);
  // A shaft pointing away from the tip would score a perfect spin calibration 180 deg off.
  EXPECT_NE(messageOf(minimal(R"(, "tip_mm": [0, 0, -160], "shaft_axis": [0, 0, 1])")).find("towards the tip"),
            std::string::npos);
  EXPECT_NE(messageOf(R"({"format": "mrsns-scenario/9", "tools": []})").find("mrsns-scenario/1"), std::string::npos);
  EXPECT_NE(messageOf("{not json").find("not valid JSON"), std::string::npos);
  EXPECT_NE(messageOf(R"({"format": "mrsns-scenario/1", "tools": [{"name": "Stylus"}]})").find("PLUS transform"),
            std::string::npos);
  EXPECT_NE(messageOf(minimal(R"(, "start": {"matrix": [1,0,0,0, 0,2,0,0, 0,0,1,0, 0,0,0,1]})")).find("rigid"),
            std::string::npos);
  EXPECT_NE(messageOf(minimal(R"(, "motion": [{"kind": "pivot"}])")).find("without a tip"), std::string::npos);
}

TEST(Scenario, DevicesNeedTheirToolsAndSomethingToImage) {
  const std::string us = R"(, "ultrasound": {"probe_tool": "ProbeToTracker"})";
  EXPECT_NE(messageOf(minimal("", us)).find("ProbeToTracker"), std::string::npos);
  const std::string both = R"({"format": "mrsns-scenario/1", "tools": [{"name": "ProbeToTracker"}],
                               "ultrasound": {}})";
  EXPECT_NE(messageOf(both).find("nothing to image"), std::string::npos);
  const std::string robot_marker = minimal("", R"(, "robot": {"marker_tool": "StylusToTracker"})");
  EXPECT_NE(messageOf(robot_marker).find("moves with the arm"), std::string::npos);
  const std::string fault = minimal("", R"(, "faults": [{"kind": "occlusion", "tool": "DrillToTracker"}])");
  EXPECT_NE(messageOf(fault).find("not one of the scenario's tools"), std::string::npos);
}

TEST(Scenario, TheHeadsetsCameraAndTheBoardsToucherNeedWhatTheyWorkOn) {
  const std::string tools = R"({"format": "mrsns-scenario/1", "tools": [
      {"name": "StylusToTracker", "tip_mm": [0, 0, -160]}, {"name": "BoardToTracker"}, {"name": "HeadsetToTracker"}],
      "hmd": )";
  const auto hmd = [&](const std::string& body) { return messageOf(tools + body + "}"); };
  // A camera needs a tracked headset (its truth is relative to the headset's marker) and a board that exists.
  EXPECT_NE(hmd(R"({"camera": {}})").find("no marker_tool"), std::string::npos);
  EXPECT_NE(hmd(R"({"marker_tool": "HeadsetToTracker", "camera": {"board_tool": "PlateToTracker"}})")
                .find("'hmd.camera.board_tool' 'PlateToTracker' is not one of the scenario's tools"),
            std::string::npos);
  EXPECT_NE(hmd(R"({"marker_tool": "HeadsetToTracker", "camera": {"distortion": [0.1, 0.0]}})")
                .find("'hmd.camera.distortion' must be [k1, k2, p1, p2, k3]"),
            std::string::npos);
  EXPECT_NE(hmd(R"({"marker_tool": "HeadsetToTracker", "camera": {"cx": 5000}})").find("hmd.camera.cx"),
            std::string::npos);
  EXPECT_NE(hmd(R"({"marker_tool": "HeadsetToTracker", "camera": {"distance_mm": [900, 500]}})")
                .find("low <= high"),
            std::string::npos);
  // The toucher touches the camera's board with a tool that has a tip.
  EXPECT_NE(hmd(R"({"board_touch": {}})").find("no camera"), std::string::npos);
  EXPECT_NE(hmd(R"({"marker_tool": "HeadsetToTracker", "camera": {}, "board_touch": {"tool": "BoardToTracker"}})")
                .find("with a tip_mm"),
            std::string::npos);
  const auto s = parseScenario(
      tools + R"({"marker_tool": "HeadsetToTracker", "camera": {"width": 640, "height": 480},
                  "board_touch": {"misplaced": [{"corner": 3, "offset_mm": [40, 0, 0]}]}}})",
      ".");
  EXPECT_TRUE(s.hmd.camera.enabled);
  EXPECT_DOUBLE_EQ(s.hmd.camera.cx, 320.0) << "the principal point defaults to the image's centre";
  EXPECT_EQ(s.hmd.camera.rows * s.hmd.camera.cols, 15);
  ASSERT_EQ(s.hmd.board_touch.misplaced.size(), 1U);
  EXPECT_EQ(s.hmd.board_touch.misplaced[0].corner, 3);
}

TEST(Scenario, MissingFilesAreNamed) {
  const std::string labels = R"({"format": "mrsns-scenario/1", "tools": [{"name": "ReferenceToTracker"}],
                                 "patient": {"labels": "no/such/ct_labels.nii.gz"}})";
  try {
    (void)parseScenario(labels, "/nonexistent-base", "s.json");
    FAIL() << "a missing label map must be refused";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("ct_labels.nii.gz does not exist"), std::string::npos) << e.what();
  }
}

TEST(Scenario, PosesFromRotationVectorOrMatrixAgree) {
  const auto a = parseScenario(minimal(R"(, "start": {"translation_mm": [1,2,3], "rotation_deg": [0,0,90]})"), ".");
  const auto b = parseScenario(minimal(R"(, "start": {"matrix": [0,-1,0,1, 1,0,0,2, 0,0,1,3, 0,0,0,1]})"), ".");
  EXPECT_TRUE(a.tools[0].start.matrix().isApprox(b.tools[0].start.matrix(), 1e-12));
}

TEST(Scenario, TheDefaultScenarioOfThePhantomTrialReads) {
  // It places the fCal phantom of the shared data (data:plus/...).
  MRSNS_REQUIRE_DATA(config, "plus/PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml");
  const auto path = std::filesystem::path(MRSNS_TEST_SOURCE_DIR) / ".." / "resources" / "scenarios" / "default.json";
  const auto s = readScenario(path);
  EXPECT_EQ(s.name, "default phantom trial");
  EXPECT_TRUE(s.ultrasound.enabled);
  EXPECT_TRUE(s.robot.enabled);
  ASSERT_TRUE(s.patient.has_value());
  EXPECT_TRUE(s.patient->generated);
  ASSERT_TRUE(s.nwire_phantom.has_value());
  EXPECT_GE(s.tools.size(), 4u);
  EXPECT_FALSE(s.faults.empty());
}

}  // namespace
}  // namespace mrsns::simulation
