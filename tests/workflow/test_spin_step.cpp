// The spin-calibration step on recordings with a known shaft (synthetic ground
// truth): it finds the stretch that is a spin after a pivot, gives the shaft
// within what the orientation noise allows, and refuses a tilt about the tip,
// a tip that leaves the divot and too small a turn. Navigation driving a UR
// with a PlusServer's tracking refuses a session without the drill's axis.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>

#include "mrsns/core/error.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/workflow/steps.h"
#include "test_data.h"

namespace mrsns::workflow {
namespace {

constexpr double kSpinDeg = 3.14159265358979323846 / 180.0;
const Eigen::Vector3d kStylusTip(0.0, 0.0, -160.0);
// 2 deg off the line from the marker to the tip, as a marker beside the shaft puts it.
const Eigen::Vector3d kStylusShaft = Eigen::Vector3d(0.03, -0.02, -1.0).normalized();

enum class Motion { Pivot, EaseOut, Spin, OneAxisTilt, SlidingSpin, SmallSpin };

/// A tracked tool: its transform's name, its tip and its shaft in its marker's frame.
struct SpunTool {
  std::string transform = "StylusToTracker";
  Eigen::Vector3d tip = kStylusTip;
  Eigen::Vector3d shaft = kStylusShaft;
};

/// tracker_T_tool at t (s) for a tip resting at (100, 50, -1300) in the tracker.
Eigen::Isometry3d poseAt(Motion m, double t, const SpunTool& tool) {
  const Eigen::Vector3d& kStylusTip = tool.tip;
  const Eigen::Vector3d& kStylusShaft = tool.shaft;
  Eigen::Isometry3d start = Eigen::Isometry3d::Identity();
  start.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 0).normalized()).toRotationMatrix();
  start.translation() = Eigen::Vector3d(100, 50, -1300) - start.linear() * kStylusTip;
  const Eigen::Vector3d tip_tracker = start * kStylusTip;
  Eigen::Matrix3d turn = Eigen::Matrix3d::Identity();
  Eigen::Vector3d slide = Eigen::Vector3d::Zero();
  const double phase = 2.0 * 3.14159265358979323846 * 0.2 * t;
  switch (m) {
    case Motion::Pivot:
      turn = Eigen::AngleAxisd(25 * kSpinDeg * std::sin(phase), start.linear() * Eigen::Vector3d::UnitX()) *
             Eigen::AngleAxisd(25 * kSpinDeg * std::sin(1.5 * phase + 0.7), start.linear() * Eigen::Vector3d::UnitY());
      break;
    case Motion::EaseOut:
      // The end of a pivot that slows down: a 6 deg tilt about the tip easing to nothing over 1 s.
      turn = Eigen::AngleAxisd(6 * kSpinDeg * std::max(0.0, 1.0 - t), start.linear() * Eigen::Vector3d::UnitX());
      break;
    case Motion::Spin: turn = Eigen::AngleAxisd(60 * kSpinDeg * std::sin(phase), start.linear() * kStylusShaft); break;
    case Motion::SmallSpin: turn = Eigen::AngleAxisd(10 * kSpinDeg * std::sin(phase), start.linear() * kStylusShaft); break;
    case Motion::OneAxisTilt:
      turn = Eigen::AngleAxisd(60 * kSpinDeg * std::sin(phase), start.linear() * Eigen::Vector3d::UnitX());
      break;
    case Motion::SlidingSpin:
      turn = Eigen::AngleAxisd(60 * kSpinDeg * std::sin(phase), start.linear() * kStylusShaft);
      slide = Eigen::Vector3d(8.0 * std::sin(phase), 0.0, 0.0);  // the tip slides out of the divot and back
      break;
  }
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = turn * start.linear();
  pose.translation() = tip_tracker + slide - pose.linear() * kStylusTip;
  return pose;
}

/// A tracker buffer at 60 Hz: the stylus (0.05 deg, 0.12 mm RMS noise per sample, a tracker's) and the
/// reference at the identity, through the segments in turn.
std::filesystem::path writeRecording(const std::filesystem::path& file, const std::vector<std::pair<Motion, double>>& plan,
                                     unsigned seed, const SpunTool& tool = {}) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> angle(0.0, 0.05 * kSpinDeg / std::sqrt(3.0)), offset(0.0, 0.12 / std::sqrt(3.0));
  TrackedSequence sequence;
  double t0 = 0.0;
  for (const auto& [motion, duration] : plan) {
    for (double t = 0.0; t < duration; t += 1.0 / 60.0) {
      Eigen::Isometry3d pose = poseAt(motion, t, tool);
      const Eigen::Vector3d w(angle(rng), angle(rng), angle(rng));
      pose.linear() = pose.linear() * Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix();
      pose.translation() += Eigen::Vector3d(offset(rng), offset(rng), offset(rng));
      TrackedFrame frame;
      frame.timestamp = 100.0 + t0 + t;
      frame.transforms[tool.transform] = FrameTransform{pose.matrix(), TransformStatus::Ok};
      frame.transforms["ReferenceToTracker"] = FrameTransform{Eigen::Matrix4d::Identity(), TransformStatus::Ok};
      sequence.frames.push_back(std::move(frame));
    }
    t0 += duration;
  }
  io::writeSequence(file, sequence);
  return file;
}

nlohmann::json matrixArray(const Eigen::Matrix4d& m) {
  nlohmann::json j = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) j.push_back(m(r, c));
  }
  return j;
}

Session sessionWithTip(const std::string& name) {
  Session session = Session::create(test::scratchDirectory(name) / "session");
  const Eigen::Matrix4d marker_T_tip = Eigen::Affine3d(Eigen::Translation3d(kStylusTip)).matrix();
  nlohmann::json m = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) m.push_back(marker_T_tip(r, c));
  }
  session.recordStep("pivot-calibration",
                     {{"status", "ok"}, {"figures", {{"transforms", {{"StylusTipToStylus", m}}}}}, {"outputs", {}}});
  return session;
}

StepResult spinFromFile(Session& session, const std::filesystem::path& recording) {
  return runStep(session, "spin-calibration", {{"source", "file"}, {"recording", recording.string()}}, {});
}

Eigen::Vector3d shaftOf(const StepResult& r) {
  const auto& s = r.figures.at("shaft_marker");
  return {s[0].get<double>(), s[1].get<double>(), s[2].get<double>()};
}

TEST(SpinStep, AfterAPivotTheSpinIsFoundAndItsShaftIsWithinTheNoise) {
  for (unsigned seed : {1u, 2u, 3u}) {
    SCOPED_TRACE(seed);
    Session session = sessionWithTip("spin-step-" + std::to_string(seed));
    const auto file = writeRecording(session.resolve("spin.mhd"), {{Motion::Pivot, 6.0}, {Motion::Spin, 6.0}}, seed);
    const auto r = spinFromFile(session, file);
    ASSERT_TRUE(r.ok) << r.summary;
    // The stretch found lies in the spin (its first 6 s at 60 Hz are the pivot).
    EXPECT_GE(r.figures["window"]["first_frame"].get<int>(), 6 * 60 - 1);
    // 0.05 deg per sample over ~180 poses turning up to ~100 deg apart: the axis to a few hundredths of a degree.
    const double error = std::acos(std::min(1.0, shaftOf(r).dot(kStylusShaft))) / kSpinDeg;
    EXPECT_LT(error, 0.1) << "shaft error, deg";
    EXPECT_NEAR(r.figures["shaft_to_tip_line_deg"].get<double>(), std::acos(-kStylusShaft.z()) / kSpinDeg, 0.1);
    // The tip frame: at the tip, z along the shaft, a rotation.
    Eigen::Matrix4d frame;
    const auto& j = r.figures["transforms"]["StylusTipToStylus"];
    for (int i = 0; i < 16; ++i) frame(i / 4, i % 4) = j[static_cast<std::size_t>(i)].get<double>();
    EXPECT_LT((frame.block<3, 1>(0, 3) - kStylusTip).norm(), 1e-9);
    EXPECT_LT((frame.block<3, 1>(0, 2) - shaftOf(r)).norm(), 1e-12);
    const double det = frame.block<3, 3>(0, 0).determinant();
    EXPECT_NEAR(det, 1.0, 1e-12);
    EXPECT_TRUE(std::filesystem::exists(session.resolve("spin-calibration/StylusTipToStylus.tfm")));
  }
}

TEST(SpinStep, APivotEasingIntoTheSpinIsTrimmedNotAveragedIn) {
  for (unsigned seed : {1u, 2u, 3u}) {
    SCOPED_TRACE(seed);
    Session session = sessionWithTip("spin-step-ease-" + std::to_string(seed));
    // The tilt eases out while the spin has not started: a stretch ending early in the spin starts in the tilt.
    const auto file = writeRecording(session.resolve("ease.mhd"),
                                     {{Motion::Pivot, 3.0}, {Motion::EaseOut, 1.0}, {Motion::Spin, 2.6}}, seed);
    const auto r = spinFromFile(session, file);
    ASSERT_TRUE(r.ok) << r.summary;
    // Averaged in, tilts of up to a few degrees bias the shaft by tenths of a degree; trimmed, the noise is left.
    const double error = std::acos(std::min(1.0, shaftOf(r).dot(kStylusShaft))) / kSpinDeg;
    EXPECT_LT(error, 0.1) << "shaft error, deg";
    EXPECT_LT(r.figures["shaft_sway_deg"].get<double>(), 0.5);
  }
}

TEST(SpinStep, ADrillsMarkerBesideItsAxisIsJudgedFromTheFlangeOnceTheRobotCalibrationPlacedIt) {
  // The drill's marker on a bracket 150 mm beside the axis: from the marker, the tip's line is 56 deg off the axis.
  const SpunTool drill{"FlangeToTracker", Eigen::Vector3d(150.0, 0.0, 100.0), Eigen::Vector3d::UnitZ()};
  Session session = Session::create(test::scratchDirectory("spin-step-drill") / "session");
  Eigen::Matrix4d marker_T_tip = Eigen::Matrix4d::Identity();
  marker_T_tip.block<3, 1>(0, 3) = drill.tip;
  session.recordStep("drill-calibration",
                     {{"status", "ok"},
                      {"figures", {{"tool", "Flange"}, {"transforms", {{"FlangeTipToFlange", matrixArray(marker_T_tip)}}}}},
                      {"outputs", nlohmann::json::array()}});
  const auto file = writeRecording(session.resolve("drill.mhd"), {{Motion::Spin, 6.0}}, 11, drill);
  const nlohmann::json params = {{"source", "file"}, {"recording", file.string()}};
  const auto judged_from_marker = runStep(session, "drill-spin-calibration", params, {});
  EXPECT_FALSE(judged_from_marker.ok);
  EXPECT_NE(judged_from_marker.summary.find("max_shaft_to_tip_line_deg"), std::string::npos)
      << judged_from_marker.summary;
  // The robot calibration says where the flange is: the marker 150 mm beside the flange's axis, 40 mm up it.
  Eigen::Matrix4d flange_T_marker = Eigen::Matrix4d::Identity();
  flange_T_marker.block<3, 1>(0, 3) = Eigen::Vector3d(-150.0, 0.0, 40.0);
  session.recordStep("robot-calibration",
                     {{"status", "ok"},
                      {"figures", {{"transforms", {{"MarkerToFlange", matrixArray(flange_T_marker)}}}}},
                      {"outputs", nlohmann::json::array()}});
  const auto r = runStep(session, "drill-spin-calibration", params, {});
  ASSERT_TRUE(r.ok) << r.summary;
  EXPECT_EQ(r.figures["shaft_line_from"], "the flange's origin");
  EXPECT_LT(std::acos(std::min(1.0, shaftOf(r).z())) / kSpinDeg, 0.1) << "the axis, pointing towards the tip";
  EXPECT_NE(r.figures["offline_command"].get<std::string>().find("--line-start 150 0 -40"), std::string::npos)
      << r.figures["offline_command"];
}

TEST(SpinStep, ATiltAboutTheTipALeavingTipAndASmallTurnAreRefusedSayingWhy) {
  Session session = sessionWithTip("spin-step-refusals");
  const auto tilt = spinFromFile(session, writeRecording(session.resolve("tilt.mhd"), {{Motion::OneAxisTilt, 8}}, 4));
  EXPECT_FALSE(tilt.ok);
  EXPECT_NE(tilt.summary.find("tilts the shaft"), std::string::npos) << tilt.summary;
  const auto slide =
      spinFromFile(session, writeRecording(session.resolve("slide.mhd"), {{Motion::SlidingSpin, 8}}, 5));
  EXPECT_FALSE(slide.ok);
  EXPECT_NE(slide.summary.find("keep it in the divot"), std::string::npos) << slide.summary;
  const auto small = spinFromFile(session, writeRecording(session.resolve("small.mhd"), {{Motion::SmallSpin, 8}}, 6));
  EXPECT_FALSE(small.ok);
  EXPECT_NE(small.summary.find("turned only"), std::string::npos) << small.summary;
  const auto pivot = spinFromFile(session, writeRecording(session.resolve("pivot.mhd"), {{Motion::Pivot, 8}}, 7));
  EXPECT_FALSE(pivot.ok);
  EXPECT_NE(pivot.summary.find("is a spin"), std::string::npos) << pivot.summary;
  // Every refusal is recorded in the session, and the recording it read is untouched.
  EXPECT_EQ(session.step("spin-calibration")["status"], "failed");
  EXPECT_TRUE(std::filesystem::exists(session.resolve("pivot.mhd")));
}

TEST(SpinStep, ATipIsNeededAndBadParametersAreRefused) {
  Session session = Session::create(test::scratchDirectory("spin-step-params") / "session");
  EXPECT_THROW(runStep(session, "spin-calibration", {{"source", "file"}, {"recording", "x.mhd"}}, {}),
               InvalidArgumentError);
  Session with_tip = sessionWithTip("spin-step-params2");
  EXPECT_THROW(runStep(with_tip, "spin-calibration", {{"window_s", 0.1}}, {}), InvalidArgumentError);
  EXPECT_THROW(runStep(with_tip, "spin-calibration", {{"max_shaft_to_tip_line_deg", 120}}, {}), InvalidArgumentError);
  EXPECT_THROW(runStep(with_tip, "spin-calibration", {{"source", "usb"}}, {}), InvalidArgumentError);
  EXPECT_THROW(runStep(with_tip, "spin-calibration", {{"tip_mm", "1,2"}}, {}), InvalidArgumentError);
  EXPECT_THROW(runStep(with_tip, "spin-calibration", {{"tip_mm", "1,2,3,4"}}, {}), InvalidArgumentError);
  // A tip at the marker's origin cannot say which way the shaft points.
  try {
    runStep(with_tip, "spin-calibration", {{"tip_mm", "0,0,0.5"}}, {});
    ADD_FAILURE() << "a tip 0.5 mm from the marker's origin was accepted";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("marker's origin"), std::string::npos) << e.what();
  }
  // A pivot calibration that failed since: its tip is gone, and the spin's own copy of it does not stand in.
  with_tip.recordStep("spin-calibration", with_tip.step("pivot-calibration"));
  with_tip.recordStep("pivot-calibration", {{"status", "failed"}, {"figures", nlohmann::json::object()}});
  try {
    runStep(with_tip, "spin-calibration", {{"source", "file"}, {"recording", "x.mhd"}}, {});
    ADD_FAILURE() << "the failed pivot's tip was taken from elsewhere";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("from pivot-calibration"), std::string::npos) << e.what();
  }
  // The drill's spin asks for the drill's pivot.
  try {
    runStep(with_tip, "drill-spin-calibration", {{"source", "file"}, {"recording", "x.mhd"}}, {});
    ADD_FAILURE() << "no FlangeTipToFlange in the session";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("drill-calibration"), std::string::npos) << e.what();
  }
}


TEST(SpinStep, NavigationDrivingAUrWithAPlusServerRefusesASessionWithoutTheDrillsAxis) {
  Session session = Session::create(test::scratchDirectory("spin-step-navigation") / "session");
  const Eigen::Matrix4d identity = Eigen::Matrix4d::Identity();
  Eigen::Matrix4d tip = identity;
  tip(2, 3) = 110.0;
  session.recordStep("robot-calibration",
                     {{"status", "ok"},
                      {"params", {{"source", "ur"}, {"marker", "FlangeToTracker"}}},
                      {"figures",
                       {{"simulated", false},
                        {"transforms",
                         {{"RobotBaseToTracker", matrixArray(identity)}, {"MarkerToFlange", matrixArray(identity)}}}}},
                      {"outputs", nlohmann::json::array()}});
  session.recordStep("drill-calibration",
                     {{"status", "ok"},
                      {"figures", {{"tool", "Flange"}, {"transforms", {{"FlangeTipToFlange", matrixArray(tip)}}}}},
                      {"outputs", nlohmann::json::array()}});
  const nlohmann::json navigation = {
      {"robot", "ur"}, {"source", "plus"}, {"port", 1}, {"ur_host", "127.0.0.1"}, {"duration_s", 1}};
  try {
    runStep(session, "navigation", navigation, {});
    ADD_FAILURE() << "navigation ran without the drill's axis";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("drill-spin-calibration"), std::string::npos) << e.what();
  }
  // An axis spun about another tip (the drill re-clamped and pivoted again since): refused too.
  session.recordStep("drill-spin-calibration", {{"status", "ok"},
                                                {"figures",
                                                 {{"tool", "Flange"},
                                                  {"shaft_marker", {0.0, 0.0, 1.0}},
                                                  {"tip_marker_mm", {0.0, 0.0, 118.0}}}},
                                                {"outputs", nlohmann::json::array()}});
  try {
    runStep(session, "navigation", navigation, {});
    ADD_FAILURE() << "navigation ran with an axis calibrated for another tip";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("run drill-spin-calibration again"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace mrsns::workflow
