// The supervisor on the live posterior (paper 001: the robot keeps away from the soft tissue the ultrasound
// shows): the simulated operating room of live_soft_tissue_room.h (its noise model there), a drill path planned
// 10 mm beside the vessel's axis (6.5 mm from its wall) through the vessel's depth, and the simulated arm
// driven along it by the navigation loop once the posterior has seen 40 frames (the surgeon scans before
// drilling). The supervisor keeps the drill's tip and shaft 2 mm + 2 SD of the posterior away from it.
//
// With a push (the vessel moved 5 mm toward the path from t = 4 s, over 3 s, and held): the arm is stopped
// for SoftTissueMargin while advancing, in the cycle the margin is crossed, from the posterior (the loop never
// sees the truth; the test compares the posterior with it afterwards). Without it (the vessel swinging 1 mm): the path is drilled to its end without
// a stop. Three seeds each.
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "live_soft_tissue_room.h"
#include "mrsns/simulation/soft_tissue.h"
#include "navigation_test_log.h"
#include "wait_for.h"

namespace mrsns::workflow {
namespace {

using namespace std::chrono_literals;
using test::describe;
using test::firstStop;
using test::waitFor;

constexpr double kPathOffsetMm = 10.0;  // the path beside the vessel's axis (model x)

NavigationOptions drillingOptions(const test::LiveRoom& r) {
  NavigationOptions o = test::liveLoopOptions(r);
  o.robot.robot = "simulated";
  o.robot.auto_start = false;
  // Stops here must come from the soft tissue: the watchdog and staleness have their own tests, and this
  // shared, non-real-time machine may skip control cycles or starve a thread under load.
  o.robot.max_cycle_time_s = 0.2;
  o.robot.max_missed_cycles = 200;
  o.silence_timeout_s = 1.0;
  // Across the vessel's depth at model z = -15 (mid-sweep), from 15 mm above its axis to 10 mm below.
  o.robot.plan.name = "beside the vessel";
  o.robot.plan.entry = test::kModelInCt + Eigen::Vector3d(kPathOffsetMm, -15.0, -15.0);
  o.robot.plan.target = test::kModelInCt + Eigen::Vector3d(kPathOffsetMm, 10.0, -15.0);
  o.robot.patient_T_plan = r.scenario.patient->reference_T_ct;  // the registration, exact (the test plays it)
  return o;
}

struct Drilling {
  std::vector<NavigationRobotTransition> log;
  NavigationStatus status;
  std::vector<SoftTissueSample> posterior;
  double utc_start = 0.0;
  std::shared_ptr<const simulation::DeformingSoftTissue> truth;  // the room's, rebuilt from its seed
};

Drilling drill(const std::string& name, std::uint64_t seed, const test::VesselMotion& motion) {
  test::LiveRoom r = test::startLiveRoom(name, seed, motion);
  NavigationLoop loop(drillingOptions(r));
  loop.start();
  Drilling d;
  EXPECT_TRUE(waitFor([&] { return loop.status().soft_tissue_updates >= 40; }, 60s, 20ms))
      << loop.status().soft_tissue;
  EXPECT_TRUE(loop.startRobot()) << loop.status().supervisor_state;
  EXPECT_TRUE(waitFor(
      [&] {
        const auto log = loop.robotTransitions();
        return loop.status().robot_stopped || (!log.empty() && log.back().detail == "path finished");
      },
      60s, 20ms))
      << describe(loop.robotTransitions());
  // Stopped: the arm comes to rest (the stop repeated until it does).
  if (loop.status().robot_stopped) {
    EXPECT_TRUE(waitFor([&] { return !std::isnan(loop.status().time_to_stop_s); }, 5s)) << describe(loop.robotTransitions());
  }
  loop.stop();
  r.room->writeTruth(r.dir / "truth.json");
  r.room->stop();
  d.log = loop.robotTransitions();
  d.status = loop.status();
  d.posterior = loop.softTissueSeries();
  std::ifstream in(r.dir / "truth.json");
  d.utc_start = nlohmann::json::parse(in)["utc_start"].get<double>();
  d.truth = std::make_shared<simulation::DeformingSoftTissue>(io::readStatismoModel(r.dir / "vessel.h5"),
                                                             *r.scenario.patient->soft_tissue, seed);
  return d;
}

// "drill shaft (4.5 mm behind the tip) 2.21 mm from the soft tissue (margin 2.27 mm)" -> distance, margin.
std::pair<double, double> distanceAndMargin(const std::string& detail) {
  const auto from = detail.find(" mm from the soft tissue");
  const auto margin = detail.find("(margin ");
  if (from == std::string::npos || margin == std::string::npos) return {NAN, NAN};
  const auto start = detail.rfind(' ', from - 1);
  return {std::stod(detail.substr(start + 1, from - start - 1)), std::stod(detail.substr(margin + 8))};
}

TEST(LiveSoftTissueStop, AVesselPushedTowardThePathStopsTheArmFromThePosteriorOverThreeSeeds) {
  for (const std::uint64_t seed : {1u, 2u, 3u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    test::VesselMotion motion;
    motion.amplitude_sd = 0.2;
    motion.push_sd = 1.0;  // 5 mm toward the path: the wall comes within 1.5 mm of its axis
    motion.push_start_s = 4.0;
    motion.push_ramp_s = 3.0;
    const Drilling d = drill("live-soft-tissue-push-" + std::to_string(seed), seed, motion);
    const auto* stop = firstStop(d.log);
    ASSERT_NE(stop, nullptr) << "no stop" << describe(d.log);
    EXPECT_EQ(stop->reason, "SoftTissueMargin") << describe(d.log);
    EXPECT_EQ(stop->from, "Advancing") << describe(d.log);
    EXPECT_TRUE(d.status.robot_stopped);
    EXPECT_EQ(d.status.motion_commands_after_stop, 0u);
    EXPECT_LE(d.status.time_to_stop_s, d.status.stop_time_limit_s);
    // In the cycle the margin was crossed: the drill advances 0.01 mm per 2 ms cycle and a posterior update
    // moves the surface by at most the vessel's motion in one frame (5 mm pushed over 3 s: < 0.2 mm per 50 ms
    // frame), so a stop that came any later than the crossing would show the drill deeper inside the margin.
    const auto [distance, margin] = distanceAndMargin(stop->detail);
    ASSERT_TRUE(std::isfinite(distance)) << stop->detail;
    // The detail prints both to 0.01 mm: the distance below the margin may print equal to it.
    EXPECT_LE(distance, margin) << stop->detail;
    EXPECT_LT(margin - distance, 0.3) << stop->detail;
    // The margin is 2 mm + 2 SD of a posterior that has seen the vessel: the SD is small.
    EXPECT_LT(margin, 2.0 + 0.25 + 2.0 * 0.5) << stop->detail;

    // The posterior the supervisor acted on followed the truth: at the last update (the push is held, the vessel
    // swings 1 mm) it agrees with the room's vessel to within the loop's lag and segmentation error.
    ASSERT_FALSE(d.posterior.empty());
    const double t = d.posterior.back().timestamp - d.utc_start;
    const double true_shift = test::kVesselSdMm * d.truth->coefficients(t)[0];
    const double estimated_shift = test::kVesselSdMm * d.posterior.back().coefficients[0];
    std::cout << "seed " << seed << ": stopped at cycle " << stop->cycle << ": " << stop->detail
              << "; vessel shift: posterior " << estimated_shift << " mm, truth " << true_shift << " mm\n";
    EXPECT_NEAR(estimated_shift, true_shift, 1.5);
  }
}

TEST(LiveSoftTissueStop, WithoutAPushThePathIsDrilledToItsEndWithoutAStopOverThreeSeeds) {
  for (const std::uint64_t seed : {1u, 2u, 3u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    test::VesselMotion motion;
    motion.amplitude_sd = 0.2;  // the vessel swings 1 mm: its wall stays >= 5.5 mm from the path's axis
    const Drilling d = drill("live-soft-tissue-nopush-" + std::to_string(seed), seed, motion);
    EXPECT_EQ(firstStop(d.log), nullptr) << describe(d.log);
    ASSERT_FALSE(d.log.empty());
    EXPECT_EQ(d.log.back().detail, "path finished") << describe(d.log);
    EXPECT_FALSE(d.status.robot_stopped) << d.status.stop_reason;
    EXPECT_GE(d.status.soft_tissue_updates, 40u);
    std::cout << "seed " << seed << ": path finished, " << d.status.soft_tissue_updates
              << " posterior updates, SD near the path " << d.status.soft_tissue_sd_max_mm << " mm\n";
  }
}

}  // namespace
}  // namespace mrsns::workflow
