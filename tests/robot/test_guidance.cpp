// Guidance: the hand-guiding twist keeps only its component along the axis; the robot-driven placement
// (exact tracking) approaches, aligns, advances to the planned length on the axis and retracts; the
// hand-guided advance follows the surgeon's push along the axis and ignores sideways pushes.
#include <gtest/gtest.h>

#include "mrsns/core/error.h"
#include "robot_test_scene.h"

namespace mrsns::robot {
namespace {

using test::Scene;

double distanceFromAxis(const Eigen::Vector3d& p, const registration::ScrewPath& plan) {
  const Eigen::Vector3d rel = p - plan.entry;
  const Eigen::Vector3d d = plan.direction();
  return (rel - rel.dot(d) * d).norm();
}

TEST(Guidance, ConstrainToAxisKeepsOnlyTheAxialPush) {
  const Eigen::Vector3d d = Eigen::Vector3d(1, 2, 2).normalized();
  Twist hand;
  hand << 3, -4, 5, 0.3, -0.2, 0.1;
  const Twist t = constrainToAxis(hand, 3.0 * d);  // direction need not be unit
  EXPECT_NEAR(t.head<3>().cross(d).norm(), 0.0, 1e-12);
  EXPECT_NEAR(t.head<3>().dot(d), hand.head<3>().dot(d), 1e-12);
  EXPECT_TRUE(t.tail<3>().isZero());
  // Projection: applying it twice changes nothing.
  EXPECT_TRUE(constrainToAxis(t, d).isApprox(t));
  EXPECT_TRUE(constrainToAxis(hand, Eigen::Vector3d::Zero()).isZero());
}

TEST(Guidance, RobotDrivenPlacementFollowsTheAxisAndRetracts) {
  Scene s;
  s.build();
  ASSERT_TRUE(s.loop->enable());
  ASSERT_TRUE(s.loop->startPlacement());
  double max_off_axis = 0, deepest = -1e9;
  bool done = false;
  for (int k = 0; k < 20000 && !done; ++k) {
    const CycleReport r = s.tickAndStep();
    ASSERT_EQ(r.stop_sent, StopCommand::None) << toString(r.decision.reason);
    if (r.guidance.phase == GuidancePhase::Advance && r.guidance.depth_mm >= 0) {
      const Eigen::Vector3d tip = s.tip().translation();
      max_off_axis = std::max(max_off_axis, distanceFromAxis(tip, s.setup.plan));
      deepest = std::max(deepest, (tip - s.setup.plan.entry).dot(s.setup.plan.direction()));
    }
    done = s.loop->guidance().phase() == GuidancePhase::Done;
  }
  ASSERT_TRUE(done);
  EXPECT_EQ(s.loop->supervisor().state(), SupervisorState::Ready);
  // Exact tracking and calibration: only the servo's tracking lag remains (advance at 5 mm/s).
  EXPECT_LT(max_off_axis, 0.05);
  EXPECT_NEAR(deepest, s.setup.plan.effectiveLength(), 0.1);
  // Retracted to the stand-off point.
  const Eigen::Vector3d standoff = s.setup.plan.entry - 20.0 * s.setup.plan.direction();
  for (int k = 0; k < 200; ++k) s.tickAndStep();
  EXPECT_LT((s.tip().translation() - standoff).norm(), 0.1);
}

TEST(Guidance, HandGuidedAdvanceMovesOnlyAlongTheAxis) {
  Scene s;
  s.options.guidance.mode = AdvanceMode::HandGuided;
  s.build();
  ASSERT_TRUE(s.loop->enable());
  ASSERT_TRUE(s.loop->startPlacement());
  ASSERT_TRUE(s.runUntil(SupervisorState::Advancing, 5000));
  const Eigen::Vector3d d = s.setup.plan.direction();
  // A sideways push only: the drill must not move.
  Twist hand = Twist::Zero();
  hand.head<3>() = 10.0 * d.unitOrthogonal();
  s.loop->setHandTwist(hand);
  const Eigen::Vector3d before = s.tip().translation();
  for (int k = 0; k < 500; ++k) ASSERT_EQ(s.tickAndStep().stop_sent, StopCommand::None);
  EXPECT_LT((s.tip().translation() - before).norm(), 0.02);
  // Push in at 3 mm/s plus sideways: 1 s advances 3 mm along the axis, staying on it.
  hand.head<3>() += 3.0 * d;
  s.loop->setHandTwist(hand);
  for (int k = 0; k < 500; ++k) ASSERT_EQ(s.tickAndStep().stop_sent, StopCommand::None);
  s.loop->setHandTwist(Twist::Zero());
  for (int k = 0; k < 100; ++k) s.tickAndStep();
  const Eigen::Vector3d moved = s.tip().translation() - before;
  EXPECT_NEAR(moved.dot(d), 3.0, 0.05);
  EXPECT_LT(distanceFromAxis(s.tip().translation(), s.setup.plan), 0.05);
  // Faster than the hand-guiding limit (5 mm/s) is clamped.
  hand.head<3>() = 50.0 * d;
  s.loop->setHandTwist(hand);
  const double depth0 = s.loop->guidance().depth();
  for (int k = 0; k < 100; ++k) s.tickAndStep();
  EXPECT_NEAR(s.loop->guidance().depth() - depth0, 5.0 * 0.2, 1e-6);
}

TEST(Guidance, PauseHoldsAndResumeContinues) {
  Scene s;
  s.build();
  ASSERT_TRUE(s.loop->enable());
  ASSERT_TRUE(s.loop->startPlacement());
  ASSERT_TRUE(s.runUntil(SupervisorState::Advancing, 5000));
  for (int k = 0; k < 200; ++k) s.tickAndStep();
  ASSERT_TRUE(s.loop->pause());
  for (int k = 0; k < 100; ++k) EXPECT_FALSE(s.tickAndStep().motion_sent);
  EXPECT_TRUE(s.arm->state().qd.isZero(0.0));
  ASSERT_TRUE(s.loop->resume());
  EXPECT_EQ(s.loop->supervisor().state(), SupervisorState::Advancing);
  EXPECT_TRUE(s.tickAndStep().motion_sent);
}

TEST(Guidance, RejectsBadOptions) {
  const Ur5Kinematics kin;
  GuidanceOptions o;
  o.advance_speed_mm_s = 0;
  EXPECT_THROW(Guidance(kin, Eigen::Isometry3d::Identity(), o), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::robot
