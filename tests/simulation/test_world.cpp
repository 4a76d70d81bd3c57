// The world's truth: motion segments, the operator's hand (tremor RMS and
// band), visibility (measurement volume, line of sight, faults), patient
// shifts, image-plane poses, the pointer touching landmarks (the patient's
// or the N-wire phantom's) and tracing the bone.
#include <gtest/gtest.h>

#include <cmath>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/io/device_set.h"
#include "mrsns/registration/phantom_cervical.h"
#include "mrsns/simulation/scenario.h"
#include "mrsns/simulation/world.h"
#include "test_data.h"

namespace mrsns::simulation {
namespace {

Scenario scenarioWith(const std::string& tools, const std::string& extra = "") {
  return parseScenario(R"({"format": "mrsns-scenario/1", "tools": [)" + tools + "]" + extra + "}", ".");
}

const std::string kInVolume = R"("start": {"translation_mm": [0, 0, -1200]})";

TEST(World, MoveEndsAtItsTargetWithZeroSpeed) {
  const auto s = scenarioWith(R"({"name": "StylusToTracker", )" + kInVolume +
                              R"(, "motion": [{"kind": "move", "duration_s": 2,
                                 "pose": {"translation_mm": [100, 0, -1200], "rotation_deg": [0, 30, 0]}}]})");
  const World world(s);
  const auto at = [&](double t) { return world.tools(t, std::nullopt)[0].tracker_T_tool; };
  EXPECT_TRUE(at(0.0).translation().isApprox(Eigen::Vector3d(0, 0, -1200), 1e-9));
  EXPECT_TRUE(at(2.0).translation().isApprox(Eigen::Vector3d(100, 0, -1200), 1e-9));
  EXPECT_NEAR(rotationAngle(at(5.0).linear()), 30.0 * M_PI / 180.0, 1e-9) << "holds the end pose afterwards";
  // Minimum jerk: no speed at the ends, fastest in the middle (1.875 x the mean speed).
  const double end_speed = (at(2.0).translation() - at(1.999).translation()).norm() / 0.001;
  const double mid_speed = (at(1.0005).translation() - at(0.9995).translation()).norm() / 0.001;
  EXPECT_LT(end_speed, 0.01);
  EXPECT_NEAR(mid_speed, 1.875 * 50.0, 0.1);
}

TEST(World, PivotKeepsTheTipInPlaceAndOneAxisPivotsStayInAPlane) {
  for (const bool one_axis : {false, true}) {
    const auto s = scenarioWith(R"({"name": "StylusToTracker", "tip_mm": [0, 0, -160], )" + kInVolume +
                                R"(, "motion": [{"kind": "pivot", "duration_s": 10, "amplitude_deg": 25,
                                   "one_axis": )" +
                                std::string(one_axis ? "true" : "false") + "}]}");
    const World world(s);
    const Eigen::Vector3d tip0 = world.tools(0.0, std::nullopt)[0].tracker_T_tool * Eigen::Vector3d(0, 0, -160);
    double max_tip = 0.0, max_angle = 0.0, max_off_plane = 0.0;
    for (double t = 0.0; t < 10.0; t += 0.05) {
      const auto pose = world.tools(t, std::nullopt)[0].tracker_T_tool;
      max_tip = std::max(max_tip, (pose * Eigen::Vector3d(0, 0, -160) - tip0).norm());
      max_angle = std::max(max_angle, rotationAngle(pose.linear()));
      max_off_plane = std::max(max_off_plane, std::abs(so3Log(pose.linear()).y()));
    }
    EXPECT_LT(max_tip, 1e-9);
    EXPECT_GT(max_angle, 20.0 * M_PI / 180.0);
    if (one_axis) {
      EXPECT_LT(max_off_plane, 1e-12) << "a one-axis pivot turns about x only";
    } else {
      EXPECT_GT(max_off_plane, 0.2);
    }
  }
}

TEST(World, HandTremorHasItsRmsInTheEightToTwelveHertzBand) {
  const auto s = scenarioWith(R"({"name": "ProbeToTracker", )" + kInVolume +
                              R"(, "hand": {"tremor_rms_mm": 0.5, "tremor_hz": [8, 12]}})");
  const World world(s);
  double sum2 = 0.0;
  int n = 0, crossings = 0;
  double previous = 0.0;
  const double dt = 0.001, duration = 20.0;
  for (double t = 0.0; t < duration; t += dt, ++n) {
    const Eigen::Vector3d d =
        world.tools(t, std::nullopt)[0].tracker_T_tool.translation() - Eigen::Vector3d(0, 0, -1200);
    sum2 += d.squaredNorm();
    if (n > 0 && (d.x() > 0.0) != (previous > 0.0)) ++crossings;
    previous = d.x();
  }
  EXPECT_NEAR(std::sqrt(sum2 / n), 0.5, 0.03);
  const double hz = crossings / 2.0 / duration;
  EXPECT_GE(hz, 8.0);
  EXPECT_LE(hz, 12.0);
}

TEST(World, TheHandMisjudgesDepthAlongTheToolAndHoldsForVaryingTimes) {
  // 200 touches of alternating targets 20 mm apart, each a move then a hold at the same pose.
  std::string motion;
  const int touches = 200;
  for (int i = 0; i < touches; ++i) {
    const std::string pose = R"({"translation_mm": [)" + std::to_string(i % 2 ? 20 : 0) + R"(, 0, -1200]})";
    motion += std::string(i ? ", " : "") + R"({"kind": "move", "duration_s": 0.5, "pose": )" + pose +
              R"(}, {"kind": "hold", "duration_s": 1.0, "pose": )" + pose + "}";
  }
  const auto s = scenarioWith(R"({"name": "StylusToTracker", )" + kInVolume + R"(,
      "hand": {"depth_misperception_mm": 1.5, "dwell_jitter_s": 0.3}, "motion": [)" +
                              motion + "]}");
  const World world(s);
  // Where each touch ends: just before the next move starts, found by scanning for the motion's pauses.
  double sum2 = 0.0, off_axis = 0.0;
  int holds = 0;
  bool moving = true;
  double t_end = 0.0;
  Eigen::Vector3d last = world.tools(0.0, std::nullopt)[0].tracker_T_tool.translation();
  for (double t = 0.01; t < 400.0; t += 0.01) {
    const Eigen::Vector3d p = world.tools(t, std::nullopt)[0].tracker_T_tool.translation();
    const bool still = (p - last).norm() < 1e-9;
    if (still && moving) {
      // A hold: the tool stands at its target, off by the misperceived depth along z (the tool's axis).
      off_axis = std::max(off_axis, std::min(std::abs(p.x()), std::abs(p.x() - 20.0)) + std::abs(p.y()));
      sum2 += (p.z() + 1200.0) * (p.z() + 1200.0);
      ++holds;
    }
    if (!still) t_end = t;  // the last instant of motion: the end of the last move
    moving = !still;
    last = p;
  }
  ASSERT_GE(holds, touches - 2);
  EXPECT_LT(off_axis, 1e-9) << "the error is along the tool's axis only";
  // RMS of 200 draws of N(0, 1.5): 1.5 mm within ~4 standard errors (1.5 / sqrt(400)).
  EXPECT_NEAR(std::sqrt(sum2 / holds), 1.5, 0.3);
  // The last move ends after 199 holds of 0.3 s jitter each: sqrt(199) * 0.3 = 4.2 s (1 SD) off the script's 299 s.
  EXPECT_GT(std::abs(t_end - 299.0), 0.05) << "the holds did not vary";
  EXPECT_LT(std::abs(t_end - 299.0), 4.0 * 4.3);
}

TEST(World, VisibilityFollowsTheVolumeTheLineOfSightAndTheFaults) {
  const auto s = scenarioWith(
      R"({"name": "StylusToTracker", )" + kInVolume + R"(},
         {"name": "ProbeToTracker", "start": {"translation_mm": [0, 0, -500]}},
         {"name": "PatientToTracker", "start": {"translation_mm": [0, 0, -1600]}},
         {"name": "HeadsetToTracker", "start": {"translation_mm": [900, 0, -1200]}})",
      R"(, "tracker": {"occluders": [{"center_mm": [0, 0, 0], "radius_mm": 50, "attached_to": "StylusToTracker"}]},
          "faults": [{"kind": "occlusion", "tool": "StylusToTracker", "at_s": 1, "duration_s": 0.5}])");
  const World world(s);
  const auto tools = world.tools(0.0, std::nullopt);
  EXPECT_EQ(tools[0].visibility, Visibility::Visible) << "its own occluder (the hand holding it) does not hide it";
  EXPECT_EQ(tools[1].visibility, Visibility::OutOfVolume) << "closer than the 950 mm near plane";
  EXPECT_EQ(tools[2].visibility, Visibility::LineOfSightBlocked) << "behind the hand holding the stylus";
  EXPECT_EQ(tools[3].visibility, Visibility::OutOfVolume) << "outside the 18 degree half-angle";
  EXPECT_EQ(world.tools(1.2, std::nullopt)[0].visibility, Visibility::OccludedByFault);
  EXPECT_EQ(world.tools(1.6, std::nullopt)[0].visibility, Visibility::Visible);
}

TEST(World, PatientShiftMovesTheAnatomyAndTheReferenceUnlessRelative) {
  const auto s =
      scenarioWith(R"({"name": "PatientToTracker", )" + kInVolume + "}",
                   R"(, "patient": {"generated_phantom": {"spacing_mm": 2.0}, "reference_tool": "PatientToTracker",
                       "ct_to_reference": {"translation_mm": [0, 50, 0]}},
          "faults": [{"kind": "patient_shift", "at_s": 1, "shift": {"translation_mm": [5, 0, 0]}},
                     {"kind": "patient_shift", "at_s": 2, "shift": {"translation_mm": [0, 3, 0]},
                      "relative_to_reference": true}])");
  const World world(s);
  const Eigen::Vector3d ct0 = world.trackerTCt(0.5).translation();
  EXPECT_TRUE(ct0.isApprox(Eigen::Vector3d(0, 50, -1200), 1e-9));
  EXPECT_TRUE(world.trackerTCt(1.5).translation().isApprox(Eigen::Vector3d(5, 50, -1200), 1e-9));
  EXPECT_TRUE(world.trackerTReference(1.5).translation().isApprox(Eigen::Vector3d(5, 0, -1200), 1e-9));
  EXPECT_TRUE(world.trackerTCt(2.5).translation().isApprox(Eigen::Vector3d(5, 53, -1200), 1e-9));
  EXPECT_TRUE(world.trackerTReference(2.5).translation().isApprox(Eigen::Vector3d(5, 0, -1200), 1e-9))
      << "the anatomy slid under a reference that stayed put";
  const auto scene = world.echoScene(0.5);
  ASSERT_TRUE(scene.bone_distance_mm && scene.vessel_distance_mm);
}

TEST(World, ImagePosesPlaceTheImagePlaneThroughTheTrueCalibration) {
  const auto s = scenarioWith(
      R"({"name": "ProbeToTracker", "motion": [{"kind": "hold", "pose_of": "image",
          "pose": {"translation_mm": [10, 20, -1300], "rotation_deg": [0, 0, 45]}}]},
         {"name": "ReferenceToTracker", )" +
          kInVolume + "}",
      R"(, "patient": {"generated_phantom": {"spacing_mm": 2.0}, "reference_tool": "ReferenceToTracker"},
          "ultrasound": {"image_to_probe": {"translation_mm": [11, 46, -7], "rotation_deg": [5, -80, 3]}})");
  const World world(s);
  const Eigen::Isometry3d image = world.trackerTImage(0.5);
  EXPECT_TRUE(image.translation().isApprox(Eigen::Vector3d(10, 20, -1300), 1e-9));
  EXPECT_NEAR(rotationAngle(image.linear()), M_PI / 4.0, 1e-9);
  const Eigen::Isometry3d probe = world.tools(0.5, std::nullopt)[0].tracker_T_tool;
  EXPECT_TRUE((probe * s.ultrasound.probe_T_image).matrix().isApprox(image.matrix(), 1e-9));
}


const std::string kPatient = R"(, "patient": {"generated_phantom": {"spacing_mm": 2.0}, "reference_tool": "PatientToTracker",
    "ct_to_reference": {"translation_mm": [0, 90, -30], "rotation_deg": [90, 0, 0]}})";

TEST(World, TouchLandmarksHoldsTheTipOnEachLandmarkInTurnFollowingThePatient) {
  const auto s = scenarioWith(
      R"({"name": "PatientToTracker", "start": {"translation_mm": [0, 0, -1400]}},
         {"name": "StylusToTracker", "tip_mm": [0, 0, -160], "start": {"translation_mm": [150, 0, -1200]},
          "motion": [{"kind": "touch_landmarks", "travel_s": 1, "dwell_s": 2, "approach_mm": 20,
                      "points_ct_mm": [[10, 5, 0], [-20, 8, 30]],
                      "misplaced": [{"landmark": 2, "offset_mm": [3, 0, 0]}]}]})",
      kPatient + R"(, "faults": [{"kind": "patient_shift", "at_s": 5, "shift": {"translation_mm": [4, 0, 0]}}])");
  const World world(s);
  const auto tip = [&](double t) { return Eigen::Vector3d(world.tools(t, std::nullopt)[1].tracker_T_tool * Eigen::Vector3d(0, 0, -160)); };
  // Landmark 1 is held from 1.5 s to 3.5 s; landmark 2 (touched 3 mm beside it) from 5.5 s, after the patient moved.
  for (double t : {1.6, 2.5, 3.4}) {
    EXPECT_TRUE(tip(t).isApprox(world.trackerTCt(t) * Eigen::Vector3d(10, 5, 0), 1e-9)) << t;
  }
  for (double t : {5.6, 6.5, 7.4}) {
    EXPECT_TRUE(tip(t).isApprox(world.trackerTCt(t) * Eigen::Vector3d(-17, 8, 30), 1e-9)) << t;
  }
  // Between touches the tip is lifted along the shaft: 20 mm above the landmark at the end of the lift.
  EXPECT_NEAR((tip(4.0) - world.trackerTCt(4.0) * Eigen::Vector3d(10, 5, 0)).norm(), 20.0, 1e-6);
  // The pointer keeps the orientation it started with.
  EXPECT_TRUE(world.tools(6.0, std::nullopt)[1].tracker_T_tool.linear().isApprox(Eigen::Matrix3d::Identity(), 1e-9));
}

TEST(World, TouchLandmarksOnTheNWirePhantomTouchesItsDefinitionsLandmarksByDefault) {
  MRSNS_REQUIRE_DATA(config, "plus/PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml");
  const std::string phantom = R"(, "nwire_phantom": {"config": ")" + config.string() +
                              R"(", "reference_tool": "ReferenceToTracker",
      "phantom_to_reference": {"translation_mm": [30, 20, -40], "rotation_deg": [0, 0, 15]}})";
  const auto s = scenarioWith(
      R"({"name": "ReferenceToTracker", "start": {"translation_mm": [-260, -40, -1450]}},
         {"name": "StylusToTracker", "tip_mm": [0, 0, -160], "start": {"translation_mm": [150, 0, -1200]},
          "motion": [{"kind": "touch_landmarks", "frame": "Phantom", "travel_s": 1, "dwell_s": 2, "approach_mm": 20}]})",
      phantom);
  const World world(s);
  const auto landmarks = io::readDeviceSet(config).requirePhantom().landmarks;
  ASSERT_EQ(landmarks.size(), 8U);
  for (std::size_t k = 0; k < landmarks.size(); ++k) {
    // Landmark k is held from 1.5 + 4k s to 3.5 + 4k s, where the phantom's definition puts it.
    const double t = 2.5 + 4.0 * static_cast<double>(k);
    const Eigen::Vector3d tip = world.tools(t, std::nullopt)[1].tracker_T_tool * Eigen::Vector3d(0, 0, -160);
    EXPECT_LT((tip - world.trackerTPhantom(t) * landmarks[k].position_phantom).norm(), 1e-9) << landmarks[k].name;
  }
  // The patient's frame and names are refused on the phantom, and other frames are refused.
  EXPECT_THROW(scenarioWith(R"({"name": "StylusToTracker", "tip_mm": [0, 0, -160],
      "motion": [{"kind": "touch_landmarks", "frame": "Phantom", "points_ct_mm": [[0, 0, 0]]}]})"),
               FormatError);
  EXPECT_THROW(scenarioWith(R"({"name": "StylusToTracker", "tip_mm": [0, 0, -160],
      "motion": [{"kind": "touch_landmarks", "frame": "Tracker"}]})"),
               FormatError);
  // Without a phantom in the room there is nothing to touch.
  EXPECT_THROW(World(scenarioWith(R"({"name": "StylusToTracker", "tip_mm": [0, 0, -160],
      "motion": [{"kind": "touch_landmarks", "frame": "Phantom"}]})")),
               InvalidArgumentError);
}

TEST(World, TraceBoneMovesTheTipOverTheExposedPosteriorSurface) {
  const auto s = scenarioWith(
      R"({"name": "PatientToTracker", "start": {"translation_mm": [0, 0, -1400]}},
         {"name": "StylusToTracker", "tip_mm": [0, 0, -160], "start": {"translation_mm": [150, 0, -1200]},
          "motion": [{"kind": "trace_bone", "points": 40, "duration_s": 10}]})",
      kPatient);
  const World world(s);
  registration::PhantomOptions options;
  options.spacing_mm = 2.0;
  const auto phantom = registration::generateCervicalPhantom(options);
  // The visited points (the end of each move: 1.5 s of approach and descent, then 0.2 s steps) lie on the bone.
  int on_bone = 0, visited = 0;
  for (double t = 1.5; t < 9.4; t += 0.01) {
    const Eigen::Vector3d tip_ct =
        world.trackerTCt(t).inverse() * (world.tools(t, std::nullopt)[1].tracker_T_tool * Eigen::Vector3d(0, 0, -160));
    const double d = std::abs(registration::phantomBoneDistance(phantom, tip_ct));
    ++visited;
    on_bone += d < 1.0 ? 1 : 0;
  }
  EXPECT_GT(on_bone, visited / 2) << "most of the sweep stays within 1 mm of the bone (chords cross gaps)";
}

TEST(World, RegistrationMotionsNeedATipAndAPatient) {
  EXPECT_THROW(scenarioWith(R"({"name": "StylusToTracker", "motion": [{"kind": "touch_landmarks"}]})"), FormatError);
  EXPECT_THROW(World(scenarioWith(
                   R"({"name": "StylusToTracker", "tip_mm": [0, 0, -160], "motion": [{"kind": "trace_bone"}]})")),
               InvalidArgumentError);
  EXPECT_THROW(scenarioWith(R"({"name": "StylusToTracker", "tip_mm": [0, 0, -160],
                               "motion": [{"kind": "touch_landmarks", "dwell": 2}]})"),
               FormatError)
      << "unknown keys are refused";
}

}  // namespace
}  // namespace mrsns::simulation
