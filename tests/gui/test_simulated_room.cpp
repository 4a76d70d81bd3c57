// The Devices menu drives the simulated operating room as a user would: start
// mrsns-sim from the GUI, see the SIMULATED banner, connect to it as to a
// PlusServer, find every tool and the step marked simulated, calibrate the
// stylus, register the patient, register the N-wire phantom and calibrate the
// probe on a sweep over it, calibrate the robot, the drill and the headset live
// from the Workflow menu, stop it.
#include <QAction>
#include <QLabel>
#include <QPushButton>
#include <QTest>
#include <fstream>

#include "sample_window_fixture.h"
#include "simulated_room.h"

namespace {

class SimulatedRoomTest : public mrsns::test::SampleWindowTest {
 protected:
  SimulatedRoomTest() : SampleWindowTest("gui-simroom") {}
};

TEST_F(SimulatedRoomTest, StartConnectAndStopFromTheDevicesMenu) {
  if (!mrsns::test::haveSampleSession()) GTEST_SKIP() << "no bundled sample session";
  MRSNS_REQUIRE_DATA(config, "plus/PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml");
  if (mrsns::gui::SimulatedRoom::findProgram().isEmpty()) GTEST_SKIP() << "mrsns-sim is not built";
  auto window = makeWindow();
  ASSERT_TRUE(window->openSampleSession()) << messages();
  ASSERT_TRUE(window->startSimulatedRoom()) << messages();
  auto* banner = window->findChild<QLabel*>("simulatedBanner");
  ASSERT_NE(banner, nullptr);
  EXPECT_TRUE(banner->isVisible());
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return window->simulatedRoom()->ready(); }, 60000)) << messages();
  EXPECT_TRUE(banner->text().startsWith("SIMULATED OR")) << banner->text().toStdString();
  EXPECT_GT(window->simulatedRoom()->endpoints().plus_port, 0);

  ASSERT_TRUE(window->connectDevices()) << messages();
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return !window->taskRunning(); }, 30000));
  const auto state = window->sessionState();
  const auto& step = state["steps"]["connect-devices"];
  ASSERT_EQ(step.value("status", ""), "ok") << step.dump() << messages();
  EXPECT_TRUE(step["figures"]["simulated"].get<bool>()) << "the device said it is mrsns-sim";
  for (const char* tool : {"ProbeToTracker", "StylusToTracker", "PatientToTracker", "ReferenceToTracker"}) {
    EXPECT_TRUE(step["figures"]["tools"].contains(tool)) << tool;
  }
  auto* status = window->findChild<QLabel*>("status_connect-devices");
  ASSERT_NE(status, nullptr);
  EXPECT_TRUE(status->text().contains("simulated")) << status->text().toStdString();
  const auto png = mrsns::test::guiArtifactDir() / "main_window_simulated_room_connected.png";
  EXPECT_TRUE(window->saveScreenshot(QString::fromStdString(png.string()))) << messages();

  // The stylus's pivot calibration from the Workflow menu, on the PlusServer the session just connected to:
  // the default scenario pivots the stylus 25 deg about two axes from 2 s on; the step ends itself once the
  // swing covers two directions.
  auto* pivot = window->findChild<QAction*>("actionStep_pivot-calibration");
  ASSERT_NE(pivot, nullptr);
  pivot->trigger();
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return !window->taskRunning(); }, 60000));
  const auto after_pivot = window->sessionState();
  const auto& pivot_step = after_pivot["steps"]["pivot-calibration"];
  ASSERT_EQ(pivot_step.value("status", ""), "ok") << pivot_step.dump() << messages();
  EXPECT_TRUE(pivot_step["figures"]["simulated"].get<bool>());
  EXPECT_TRUE(pivot_step["figures"]["recorded"]["complete"].get<bool>());
  EXPECT_NEAR(pivot_step["figures"]["tip_length_mm"].get<double>(), 160.0, 1.0) << "the scenario's stylus";
  auto* pivot_status = window->findChild<QLabel*>("status_pivot-calibration");
  ASSERT_NE(pivot_status, nullptr);
  EXPECT_TRUE(pivot_status->text().contains("simulated")) << pivot_status->text().toStdString();
  EXPECT_TRUE(window->saveScreenshot(
      QString::fromStdString((mrsns::test::guiArtifactDir() / "main_window_simulated_pivot.png").string())));

  // Then the operator turns the stylus about its shaft (12.5-17.5 s): the tip's whole frame.
  EXPECT_TRUE(window->deviceParams("spin-calibration").empty()) << "the step itself defaults to the PlusServer";
  window->findChild<QAction*>("actionStep_spin-calibration")->trigger();
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return !window->taskRunning(); }, 60000));
  const auto after_spin = window->sessionState();
  const auto& spin_step = after_spin["steps"]["spin-calibration"];
  ASSERT_EQ(spin_step.value("status", ""), "ok") << spin_step.dump() << messages();
  EXPECT_TRUE(spin_step["figures"]["simulated"].get<bool>());
  EXPECT_TRUE(spin_step["figures"]["recorded"]["complete"].get<bool>());

  // The patient registration from the Workflow menu, live on the same PlusServer: the scenario's operator
  // touches the phantom's eight fiducial screws from 18 s on, then sweeps the exposed bone (54-74 s); the step
  // prepares the CT while it already records, matches the touches to the fiducials it finds in the CT, and
  // ends itself once the sweep is done.
  auto* registration = window->findChild<QAction*>("actionStep_registration");
  ASSERT_NE(registration, nullptr);
  registration->trigger();
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return !window->taskRunning(); }, 150000));
  const auto after_registration = window->sessionState();
  const auto& reg = after_registration["steps"]["registration"];
  ASSERT_EQ(reg.value("status", ""), "ok") << reg.dump() << messages();
  EXPECT_EQ(reg["figures"]["source"], "plus");
  EXPECT_TRUE(reg["figures"]["simulated"].get<bool>());
  EXPECT_TRUE(reg["figures"]["recorded"]["complete"].get<bool>());
  EXPECT_EQ(reg["figures"]["landmarks"]["matched"], 8);
  EXPECT_FALSE(reg["figures"].contains("simulation_truth"));
  EXPECT_TRUE(window->saveScreenshot(
      QString::fromStdString((mrsns::test::guiArtifactDir() / "main_window_simulated_registration.png").string())));

  // The probe calibrated as in fCal, from the Workflow menu: the scenario's operator touches the N-wire phantom's
  // landmarks from 80 s (the phantom registration), then moves the probe up and down over the bath's floor
  // (the temporal calibration) and sweeps it over the wires from 131 s.
  EXPECT_TRUE(window->deviceParams("us-phantom-registration").empty()) << "the step itself defaults to the PlusServer";
  window->findChild<QAction*>("actionStep_us-phantom-registration")->trigger();
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return !window->taskRunning(); }, 150000));
  const auto after_phantom = window->sessionState();
  const auto& phantom = after_phantom["steps"]["us-phantom-registration"];
  ASSERT_EQ(phantom.value("status", ""), "ok") << phantom.dump() << messages();
  EXPECT_TRUE(phantom["figures"]["simulated"].get<bool>());
  EXPECT_EQ(phantom["figures"]["matched"].get<int>(), 8);
  // The tracker's lag first, as PLUS does: the scenario moves the probe up and down over the bath's flat bottom
  // from 107 s (its video lags the tracking by 40 ms, which only the room's truth knows).
  EXPECT_EQ(window->deviceParams("us-temporal-calibration"), nlohmann::json({{"source", "plus"}}));
  window->findChild<QAction*>("actionStep_us-temporal-calibration")->trigger();
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return !window->taskRunning(); }, 60000));
  const auto after_temporal = window->sessionState();
  const auto& temporal = after_temporal["steps"]["us-temporal-calibration"];
  ASSERT_EQ(temporal.value("status", ""), "ok") << temporal.dump() << messages();
  EXPECT_EQ(temporal["params"].value("source", ""), "plus");
  EXPECT_TRUE(temporal["figures"]["simulated"].get<bool>());
  EXPECT_EQ(window->deviceParams("us-spatial-calibration"), nlohmann::json({{"source", "plus"}}));
  window->findChild<QAction*>("actionStep_us-spatial-calibration")->trigger();
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return !window->taskRunning(); }, 150000));
  const auto after_sweep = window->sessionState();
  const auto& sweep = after_sweep["steps"]["us-spatial-calibration"];
  ASSERT_EQ(sweep.value("status", ""), "ok") << sweep.dump() << messages();
  EXPECT_TRUE(sweep["figures"]["simulated"].get<bool>());
  EXPECT_EQ(sweep["figures"]["phantom_to_reference_source"], "us-phantom-registration");
  EXPECT_EQ(sweep["figures"]["tracker_lag_source"], "us-temporal-calibration");
  EXPECT_TRUE(window->saveScreenshot(
      QString::fromStdString((mrsns::test::guiArtifactDir() / "main_window_simulated_us_calibration.png").string())));

  // The robot calibration drives the room's UR controller (the one its tracker sees) through its stations.
  EXPECT_EQ(window->deviceParams("robot-calibration").value("source", ""), "ur");
  // The placement drives the same arm, navigated on the room's tracking.
  const auto placement_params = window->deviceParams("robot-placement");
  EXPECT_EQ(placement_params.value("robot", ""), "ur");
  EXPECT_EQ(placement_params.value("source", ""), "plus");
  EXPECT_EQ(placement_params.value("ur_rtde_port", 0), window->deviceParams("robot-calibration").value("ur_rtde_port", -1));
  window->findChild<QAction*>("actionStep_robot-calibration")->trigger();
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return !window->taskRunning(); }, 150000));
  const auto after_robot = window->sessionState();
  const auto& robot = after_robot["steps"]["robot-calibration"];
  ASSERT_EQ(robot.value("status", ""), "ok") << robot.dump() << messages();
  EXPECT_EQ(robot["figures"]["source"], "ur");
  EXPECT_TRUE(robot["figures"]["simulated"].get<bool>());
  EXPECT_GE(robot["figures"]["poses"].get<int>(), 6);

  // The drill's tip: the scenario's operator pivots the drill on the flange by hand (freedrive) from 205 s.
  EXPECT_TRUE(window->deviceParams("drill-calibration").empty()) << "the step itself defaults to the PlusServer";
  window->findChild<QAction*>("actionStep_drill-calibration")->trigger();
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return !window->taskRunning(); }, 90000));
  const auto after_drill = window->sessionState();
  const auto& drill = after_drill["steps"]["drill-calibration"];
  ASSERT_EQ(drill.value("status", ""), "ok") << drill.dump() << messages();
  EXPECT_TRUE(drill["figures"]["simulated"].get<bool>());
  EXPECT_NEAR(drill["figures"]["tip_length_mm"].get<double>(), 150.0 - 40.0, 2.0)
      << "the scenario's drill tip, 150 mm along the flange, seen from its marker 40 mm out";
  // And turns the drill about its axis (from 224 s): the drilling direction.
  window->findChild<QAction*>("actionStep_drill-spin-calibration")->trigger();
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return !window->taskRunning(); }, 60000));
  const auto after_drill_spin = window->sessionState();
  const auto& drill_spin = after_drill_spin["steps"]["drill-spin-calibration"];
  ASSERT_EQ(drill_spin.value("status", ""), "ok") << drill_spin.dump() << messages();
  EXPECT_LT(drill_spin["figures"]["shaft_to_tip_line_deg"].get<double>(), 1.0)
      << "the scenario's drill points from its flange through its tip, its marker on that line";

  // The headset: the room's wearer lines the tracked cube up with its hologram in each of four views and
  // confirms on the headset; then the patient's fiducials are shown through the new calibration.
  const auto hmd_params = window->deviceParams("hmd-calibration");
  EXPECT_EQ(hmd_params.value("source", ""), "hmd");
  EXPECT_EQ(hmd_params.value("hmd_port", 0), window->simulatedRoom()->endpoints().hmd_port);
  window->findChild<QAction*>("actionStep_hmd-calibration")->trigger();
  auto* confirm = window->findChild<QPushButton*>("taskConfirm");
  ASSERT_NE(confirm, nullptr);
  EXPECT_TRUE(confirm->isVisible()) << "the operator can confirm from the workstation too";
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return !window->taskRunning(); }, 150000));
  EXPECT_FALSE(confirm->isVisible());
  const auto after_hmd = window->sessionState();
  const auto& hmd = after_hmd["steps"]["hmd-calibration"];
  ASSERT_EQ(hmd.value("status", ""), "ok") << hmd.dump() << messages();
  EXPECT_TRUE(hmd["figures"]["simulated"].get<bool>());
  ASSERT_EQ(hmd["figures"]["views"].size(), 4U);
  for (const auto& v : hmd["figures"]["views"]) EXPECT_EQ(v["confirmed_by"], "headset");
  EXPECT_EQ(hmd["figures"]["acquisition"]["verification_model"], "CTFiducials") << "the registration's fiducials";
  EXPECT_TRUE(window->saveScreenshot(
      QString::fromStdString((mrsns::test::guiArtifactDir() / "main_window_simulated_hmd_calibration.png").string())));

  // Then paper 000's hand-eye calibration of the headset's camera: the board's corners touched with the stylus
  // as the headset asks, then the wearer looks at the board from ten places and the headset sends a photo of each.
  window->findChild<QAction*>("actionStep_checkerboard-digitisation")->trigger();
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return !window->taskRunning(); }, 150000));
  const auto after_board = window->sessionState();
  const auto& board = after_board["steps"]["checkerboard-digitisation"];
  ASSERT_EQ(board.value("status", ""), "ok") << board.dump() << messages();
  EXPECT_EQ(board["figures"]["grid"]["inliers"], 15);
  const auto camera_params = window->deviceParams("hmd-camera-calibration");
  EXPECT_EQ(camera_params.value("hmd_port", 0), window->simulatedRoom()->endpoints().hmd_port);
  window->findChild<QAction*>("actionStep_hmd-camera-calibration")->trigger();
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return !window->taskRunning(); }, 150000));
  const auto after_camera = window->sessionState();
  const auto& camera = after_camera["steps"]["hmd-camera-calibration"];
  ASSERT_EQ(camera.value("status", ""), "ok") << camera.dump() << messages();
  EXPECT_TRUE(camera["figures"]["simulated"].get<bool>());
  EXPECT_EQ(camera["figures"]["photos"], 10);
  EXPECT_EQ(camera["figures"]["board"]["corners_from"], "checkerboard-digitisation");
  EXPECT_TRUE(window->saveScreenshot(
      QString::fromStdString((mrsns::test::guiArtifactDir() / "main_window_simulated_hmd_camera.png").string())));

  EXPECT_TRUE(window->deviceParams("registration").empty()) << "the step itself defaults to the PlusServer";

  // The truth stays outside the session folder.
  const auto truth = window->simulatedRoom()->truthFile().toStdString();
  EXPECT_EQ(truth.find(window->sessionFolder().toStdString()), std::string::npos);
  window->stopSimulatedRoom();
  EXPECT_FALSE(window->simulatedRoom()->running());
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return !banner->isVisible(); }, 5000));
  EXPECT_TRUE(std::filesystem::exists(truth)) << "mrsns-sim wrote its truth when stopped";
}

}  // namespace
