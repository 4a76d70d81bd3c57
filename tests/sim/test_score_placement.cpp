// mrsns-sim score on the robot's placement (synthetic ground truth): a room whose drill tip, seen through a
// patient reference that is itself rotated and moving, advances exactly along the planned path scores zero;
// a tip offset sideways by d scores an entry error of d; a drilled line tilted about the entry by a scores an
// angle of a and no entry error; after a stop the tip's further travel and its time to rest, and from the
// room's fault that caused it, are what the truth shows. A placement not driven in the room, or a truth without a
// robot, is listed as not scored.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>

#include "matrix_json.h"
#include "mrsns/simulation/score.h"
#include "test_data.h"

namespace mrsns::simulation {
namespace {

using Json = nlohmann::json;

const Eigen::Vector3d kEntry(19.8, 11.1, 0.0), kTarget(3.0, -5.7, 0.0);
constexpr double kUtc0 = 1.8e9, kRate = 60.0;
const Eigen::Vector3d kTipMarker(0.0, 0.0, 190.0);  // the drill tip in its marker's frame

Eigen::Isometry3d placementPose(const Eigen::Vector3d& axis, double deg, const Eigen::Vector3d& t) {
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.linear() = Eigen::AngleAxisd(deg * M_PI / 180.0, axis.normalized()).toRotationMatrix();
  p.translation() = t;
  return p;
}

Json compactPose(const Eigen::Isometry3d& p) {
  const Eigen::Quaterniond q(p.linear());
  return {p.translation().x(), p.translation().y(), p.translation().z(), q.w(), q.x(), q.y(), q.z()};
}

// The true tip in the CT at time t (s from kUtc0): where the drill goes.
using TipPath = std::function<Eigen::Vector3d(double)>;

struct PlacementCase {
  std::filesystem::path session, truth;
};

/// A room whose patient reference drifts 2 mm/s along x (patient motion the scorer must follow) and whose drill
/// marker is placed so the tip is at tip(t) in the CT, sampled at 60 Hz over [0, duration]; the session's
/// placement step with one path and the given times (s from kUtc0).
PlacementCase makePlacementCase(const std::string& name, const TipPath& tip, double duration, const Json& times,
                                bool from_room = true, bool truth_has_robot = true,
                                const Json& events = Json::array()) {
  PlacementCase c;
  const auto dir = test::scratchDirectory(name);
  c.session = dir / "session";
  std::filesystem::create_directories(c.session);
  const Eigen::Isometry3d reference_T_ct = placementPose({1, 0, 0}, 90.0, {0.0, 90.0, -30.0});
  Json samples = Json::array();
  for (int k = 0; k <= static_cast<int>(duration * kRate); ++k) {
    const double t = k / kRate;
    const Eigen::Isometry3d tracker_T_reference = placementPose({0, 0, 1}, 10.0, {2.0 * t, 0.0, -1400.0});
    const Eigen::Vector3d tip_tracker = tracker_T_reference * (reference_T_ct * tip(t));
    // The marker's orientation is arbitrary (it does not change where its tip is): turn it with time.
    Eigen::Isometry3d tracker_T_marker = placementPose({0.3, 1, 0.2}, 20.0 + 5.0 * t, Eigen::Vector3d::Zero());
    tracker_T_marker.translation() = tip_tracker - tracker_T_marker.linear() * kTipMarker;
    samples.push_back(
        {{"t", t}, {"utc", kUtc0 + t}, {"poses", {compactPose(tracker_T_reference), compactPose(tracker_T_marker)}}});
  }
  Json st = {{"seed", 1},
             {"scenario", "synthetic"},
             {"CTToReference", test::rowMajorJson(reference_T_ct.matrix())},
             {"patient_reference_tool", "PatientToTracker"}};
  if (truth_has_robot) {
    st["robot_marker_tool"] = "FlangeToTracker";
    st["tool_tips_mm"] = {{"FlangeToTracker", {kTipMarker.x(), kTipMarker.y(), kTipMarker.z()}}};
  }
  c.truth = dir / "truth.json";
  std::ofstream(c.truth) << Json{{"format", "mrsns-truth/1"},  {"static", st},
                                 {"utc_start", kUtc0},         {"tools", {"PatientToTracker", "FlangeToTracker"}},
                                 {"tracker_samples", samples}, {"events", events}}
                                .dump();
  Json path = {{"name", "C5 left"},
               {"entry_ct", {kEntry.x(), kEntry.y(), kEntry.z()}},
               {"target_ct", {kTarget.x(), kTarget.y(), kTarget.z()}}};
  for (const auto& [key, value] : times.items()) {
    path[key] = value.is_number() ? Json(kUtc0 + value.get<double>()) : value;
  }
  std::ofstream(c.session / "session.json")
      << Json{{"steps",
               {{"robot-placement",
                 {{"status", "ok"},
                  {"figures", {{"simulated", from_room}, {"device_identity", "mrsns-sim"}, {"paths", {path}}}}}}}}}
             .dump();
  return c;
}

const Eigen::Vector3d kAxis = (kTarget - kEntry).normalized();
const double kDepth = (kTarget - kEntry).norm();

// Approach from aside (0-2 s), then from 20 mm before the entry to the target at 5 mm/s, then back out.
Eigen::Vector3d drilled(double t, const Eigen::Vector3d& offset, const Eigen::Matrix3d& tilt) {
  const Eigen::Vector3d standoff = kEntry - 20.0 * kAxis;
  if (t < 2.0) return standoff + Eigen::Vector3d(40.0, 60.0, 10.0) * (2.0 - t) / 2.0 + offset;
  const double advance_end = 2.0 + (20.0 + kDepth) / 5.0;
  const double depth = t < advance_end ? -20.0 + 5.0 * (t - 2.0) : std::max(-20.0, kDepth - 20.0 * (t - advance_end));
  return kEntry + tilt * (depth * kAxis) + offset;
}

Json placedTimes() {
  const double advance_end = 2.0 + (20.0 + kDepth) / 5.0;
  return {{"outcome", "placed"},
          {"utc_start", 0.0},
          {"utc_aligned", 2.0},
          {"utc_path_finished", advance_end + 2.3},
          {"utc_end", advance_end + 2.4}};
}

Json placementScored(const PlacementCase& c) {
  return Json::parse(scoreSession(c.session, c.truth))["scored"];
}

TEST(ScorePlacement, ADrillAlongThePlanScoresZeroThroughAMovingRotatedReference) {
  const auto c = makePlacementCase(
      "placement-exact",
      [](double t) {
        return drilled(t, {0, 0, 0}, Eigen::Matrix3d::Identity());
      },
      14.0, placedTimes());
  const auto s = placementScored(c);
  ASSERT_TRUE(s.contains("robot_placement")) << s.dump();
  const auto& p = s["robot_placement"]["paths"][0];
  EXPECT_NEAR(p["entry_error_mm"].get<double>(), 0.0, 1e-6);
  // The deepest tip is the last 60 Hz sample before the target: within one sample's 5/60 mm.
  EXPECT_LT(p["target_error_mm"].get<double>(), 5.0 / kRate);
  EXPECT_NEAR(p["angle_error_deg"].get<double>(), 0.0, 1e-6);
  EXPECT_EQ(s["robot_placement"]["placed"], 1);
}

TEST(ScorePlacement, ASidewaysOffsetIsTheEntryErrorAndADeeperHoleAddsToTheTarget) {
  // 0.7 mm across the axis (perpendicular to it) and 0.5 mm further along it.
  const Eigen::Vector3d across = kAxis.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d offset = 0.7 * across + 0.5 * kAxis;
  const auto c = makePlacementCase(
      "placement-offset", [&](double t) { return drilled(t, offset, Eigen::Matrix3d::Identity()); }, 14.0,
      placedTimes());
  const auto s = placementScored(c);
  const auto& p = s["robot_placement"]["paths"][0];
  EXPECT_NEAR(p["entry_error_mm"].get<double>(), 0.7, 1e-6);
  EXPECT_NEAR(p["target_error_mm"].get<double>(), std::hypot(0.7, 0.5), 5.0 / kRate);
  EXPECT_NEAR(p["depth_error_mm"].get<double>(), 0.5, 5.0 / kRate);
  EXPECT_NEAR(p["angle_error_deg"].get<double>(), 0.0, 1e-6);
}

TEST(ScorePlacement, ALineTiltedAboutTheEntryIsTheAngleWithoutAnEntryError) {
  const Eigen::Matrix3d tilt = Eigen::AngleAxisd(2.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const auto c = makePlacementCase(
      "placement-tilt",
      [&](double t) {
        return drilled(t, {0, 0, 0}, tilt);
      },
      14.0, placedTimes());
  const auto s = placementScored(c);
  const auto& p = s["robot_placement"]["paths"][0];
  EXPECT_NEAR(p["angle_error_deg"].get<double>(), 2.0, 1e-6);
  EXPECT_NEAR(p["entry_error_mm"].get<double>(), 0.0, 1e-6);
  // The hole's end swings 2 deg about the entry: kDepth * 2 sin(1 deg) sideways.
  EXPECT_NEAR(p["target_error_mm"].get<double>(), kDepth * 2.0 * std::sin(M_PI / 180.0), 5.0 / kRate);
}

TEST(ScorePlacement, AfterAStopTheTipsTravelAndTimeToRestComeFromTheTruth) {
  // Stopped 4 s in (advancing at 5 mm/s), the tip decelerates uniformly to rest over 0.3 s: 0.75 mm more.
  const auto tip = [](double t) {
    const Eigen::Vector3d at_stop = drilled(4.0, {0, 0, 0}, Eigen::Matrix3d::Identity());
    if (t <= 4.0) return drilled(t, {0, 0, 0}, Eigen::Matrix3d::Identity());
    const double u = std::min(t - 4.0, 0.3);
    return Eigen::Vector3d(at_stop + (5.0 * u - 0.5 * (5.0 / 0.3) * u * u) * kAxis);
  };
  // The room's fault began 0.2 s before the stop command (the workstation saw it late); an earlier fault's end
  // and the headset's prompts are not it.
  const Json events = {{{"t", 1.0}, {"utc", kUtc0 + 1.0}, {"event", "hmd prompt: line up the cube"}},
                       {{"t", 3.0}, {"utc", kUtc0 + 3.0}, {"event", "occlusion end StylusToTracker"}},
                       {{"t", 3.8}, {"utc", kUtc0 + 3.8}, {"event", "occlusion start PatientToTracker"}},
                       {{"t", 4.5}, {"utc", kUtc0 + 4.5}, {"event", "robot_protective_stop"}}};
  const auto c = makePlacementCase("placement-stop", tip, 6.0,
                                   {{"outcome", "stopped"},
                                    {"utc_start", 0.0},
                                    {"utc_aligned", 2.0},
                                    {"utc_stop", 4.0},
                                    {"utc_end", 6.0},
                                    {"stop_reason", "SoftTissueMargin"}},
                                   true, true, events);
  const auto s = placementScored(c)["robot_placement"];
  ASSERT_EQ(s["stops"].size(), 1u) << s.dump();
  const auto& stop = s["stops"][0];
  EXPECT_EQ(stop["reason"], "SoftTissueMargin");
  EXPECT_NEAR(stop["tip_displacement_after_stop_mm"].get<double>(), 0.75, 1e-3);
  EXPECT_NEAR(stop["tip_path_after_stop_mm"].get<double>(), 0.75, 1e-3);
  // Slower than 1 mm/s from 0.3 - 1/(5/0.3) s = 0.24 s on, sampled at 60 Hz.
  EXPECT_NEAR(stop["time_to_rest_s"].get<double>(), 0.24, 1.0 / kRate + 1e-9);
  EXPECT_EQ(stop["fault"], "occlusion start PatientToTracker");
  EXPECT_NEAR(stop["fault_to_stop_command_ms"].get<double>(), 200.0, 1e-3);
  // 0.2 s at 5 mm/s before the stop, then the 0.75 mm to rest.
  EXPECT_NEAR(stop["tip_path_after_fault_mm"].get<double>(), 1.75, 1e-3);
  EXPECT_NEAR(stop["fault_to_rest_s"].get<double>(), 0.44, 1.0 / kRate + 1e-9);
  EXPECT_EQ(s["placed"], 0) << "a stopped path has no drilled line to score";
}

TEST(ScorePlacement, APlacementNotInTheRoomOrARoomWithoutARobotIsNotScored) {
  const auto exact = [](double t) { return drilled(t, {0, 0, 0}, Eigen::Matrix3d::Identity()); };
  for (const auto& [name, from_room, robot] :
       {std::tuple{"placement-not-room", false, true}, std::tuple{"placement-no-robot", true, false}}) {
    SCOPED_TRACE(name);
    const auto c = makePlacementCase(name, exact, 14.0, placedTimes(), from_room, robot);
    const auto out = Json::parse(scoreSession(c.session, c.truth));
    EXPECT_FALSE(out["scored"].contains("robot_placement"));
    bool listed = false;
    for (const auto& n : out["not_scored"]) listed = listed || n.get<std::string>().rfind("robot-placement", 0) == 0;
    EXPECT_TRUE(listed) << out["not_scored"].dump();
  }
}

}  // namespace
}  // namespace mrsns::simulation
