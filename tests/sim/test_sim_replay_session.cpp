// The PLUS fCal recording replayed by mrsns-sim, recorded live by the
// session's ultrasound calibration step (source=plus) and calibrated there:
// every frame arrives, the step's ImageToProbe equals the offline
// `calibrate-us` on the sweep it recorded (same frames, same numbers), and
// agrees with `calibrate-us` on the original file up to the float32 of
// OpenIGTLink's TRANSFORM.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <fstream>

#include "loopback_ports.h"
#include "sim_process.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

using Json = nlohmann::json;

Eigen::Matrix4d matrixOf(const Json& j) {
  Eigen::Matrix4d m;
  for (int i = 0; i < 16; ++i) {
    m(i / 4, i % 4) = j.size() == 16
                          ? j[static_cast<std::size_t>(i)].get<double>()
                          : j[static_cast<std::size_t>(i / 4)][static_cast<std::size_t>(i % 4)].get<double>();
  }
  return m;
}

TEST(SimReplaySession, TheReplayedFcalSweepCalibratesInTheSessionAsOffline) {
  MRSNS_REQUIRE_DATA(config, "plus/PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml");
  MRSNS_REQUIRE_DATA(calibration, "plus/fCal_Test_Calibration_3NWires.igs.mha");
  MRSNS_REQUIRE_DATA(validation, "plus/fCal_Test_Validation_3NWires.igs.mha");
  const auto dir = scratchDirectory("replay-session");
  std::ofstream(dir / "replay.json") << R"({"format": "mrsns-scenario/1", "name": "fCal replay",
      "tracker": {"port": 0}, "replay": {"sequence": ")"
                                     << calibration.string() << R"(", "wait_for_client": true}})";
  SimProcess sim({"run", "--scenario", (dir / "replay.json").string(), "--truth", (dir / "truth.json").string(),
                  "--ready-file", (dir / "ready.json").string(), "--json"});
  const auto ready = sim.waitReady(dir / "ready.json");
  ASSERT_FALSE(ready.is_null()) << sim.wait().err;
  ASSERT_EQ(runCli({"session", "create", (dir / "session").string()}).exit_code, 0);
  const auto step =
      runCli({"session", "run", (dir / "session").string(), "us-spatial-calibration", "--param", "source=plus",
              "--param", "port=" + std::to_string(ready["plus_port"].get<int>()), "--param", "idle_stop_s=1.5",
              "--param", "config=" + config.string(), "--param", "validation=" + validation.string(), "--param",
              "phantom_to_reference=config", "--json"});
  const auto end = sim.wait(60.0);
  ASSERT_EQ(step.exit_code, 0) << step.err;
  ASSERT_EQ(end.exit_code, 0) << end.err;
  const auto figures = Json::parse(step.out)["figures"];
  EXPECT_EQ(figures["recorded"]["frames"].get<int>(), 188) << "every frame of the recording, none missed";
  EXPECT_EQ(figures["recorded"]["frames_refused"].get<int>(), 0);
  EXPECT_TRUE(figures["simulated"].get<bool>()) << "the device said it is mrsns-sim";
  const Eigen::Matrix4d live = matrixOf(figures["transforms"]["ImageToProbe"]);

  // Offline, on the sweep the step recorded into the session: the same numbers.
  const auto recorded = dir / "session" / "us-spatial-calibration" / "calibration_sweep.igs.mha";
  const auto offline = runCli({"calibrate-us", "--config", config.string(), "--calibration", recorded.string(),
                               "--validation", validation.string(), "--json"});
  ASSERT_EQ(offline.exit_code, 0) << offline.err;
  const auto o = Json::parse(offline.out);
  EXPECT_LT((matrixOf(o["image_to_probe"]) - live).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_NEAR(o["validation"]["reprojection_3d_mm"]["mean"].get<double>(),
              figures["validation"]["reprojection_3d_mean_mm"].get<double>(), 1e-9);

  // Against the original file: OpenIGTLink's float32 TRANSFORM moves one of 179 frames (test_operating_room) and
  // the matrix by a few hundredths of a millimetre.
  const auto original = runCli({"calibrate-us", "--config", config.string(), "--calibration", calibration.string(),
                                "--validation", validation.string(), "--json"});
  ASSERT_EQ(original.exit_code, 0) << original.err;
  const auto f = Json::parse(original.out);
  EXPECT_LT((matrixOf(f["image_to_probe"]) - live).cwiseAbs().maxCoeff(), 0.1);
  EXPECT_NEAR(f["validation"]["reprojection_3d_mm"]["mean"].get<double>(),
              figures["validation"]["reprojection_3d_mean_mm"].get<double>(), 0.01);
  std::printf("[ figures ] live %d frames; validation %.4f mm live, %.4f mm from the file; matrix max diff %.4f\n",
              figures["recorded"]["frames"].get<int>(), figures["validation"]["reprojection_3d_mean_mm"].get<double>(),
              f["validation"]["reprojection_3d_mm"]["mean"].get<double>(),
              (matrixOf(f["image_to_probe"]) - live).cwiseAbs().maxCoeff());
}

TEST(SimReplaySession, NoPlusServerIsOneLineNamingWhereItLooked) {
  const auto dir = scratchDirectory("replay-none");
  ASSERT_EQ(runCli({"session", "create", (dir / "session").string()}).exit_code, 0);
  const int port = closedPort();
  const auto r = runCli({"session", "run", (dir / "session").string(), "us-spatial-calibration", "--param",
                         "source=plus", "--param", "port=" + std::to_string(port), "--param", "connect_timeout_s=1",
                         "--param", "phantom_to_reference=config"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("127.0.0.1:" + std::to_string(port)), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

}  // namespace
}  // namespace mrsns::test
