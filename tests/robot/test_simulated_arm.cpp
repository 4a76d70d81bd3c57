// SimulatedArm: servoJ reaches its target within the joint speed/acceleration limits, speedL moves the
// TCP along the commanded direction, every stop ends inside the stopping-time limit, faults appear on
// the injected cycle, and commands are refused in safety states.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "mrsns/core/error.h"
#include "mrsns/robot/simulated_arm.h"

namespace mrsns::robot {
namespace {

// Cycles until every joint speed is zero, at most `max_cycles`.
int cyclesToStandstill(SimulatedArm& arm, int max_cycles) {
  for (int k = 0; k < max_cycles; ++k) {
    if (arm.state().qd.isZero(0.0)) return k;
    arm.step();
  }
  return max_cycles;
}

TEST(SimulatedArm, ServoJReachesTargetWithinLimits) {
  SimulatedArm arm;
  const auto limits = arm.options().limits;
  Joints target = arm.state().q;
  target[0] += 1.0;
  target[3] -= 0.5;
  double max_speed = 0, max_acc = 0;
  Joints prev = Joints::Zero();
  for (int k = 0; k < 1500; ++k) {
    ASSERT_TRUE(arm.servoJ(target));
    arm.step();
    const auto s = arm.state();
    max_speed = std::max(max_speed, (s.qd.cwiseAbs().array() / limits.max_qd.array()).maxCoeff());
    max_acc = std::max(max_acc, ((s.qd - prev).cwiseAbs().array() / 0.002 / limits.max_qdd.array()).maxCoeff());
    prev = s.qd;
  }
  EXPECT_LT((arm.state().q - target).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_TRUE(arm.state().qd.isZero(1e-9));
  EXPECT_LE(max_speed, 1.0 + 1e-12);
  EXPECT_LE(max_acc, 1.0 + 1e-9);
  // A 1 rad move at 15 rad/s^2 cannot take less than 2 sqrt(1/15) = 0.516 s: the speed limit was not hit,
  // and the motion used the full acceleration (so it reached ~pi/... of the limit).
  EXPECT_GT(max_speed, 0.5 * std::sqrt(15.0) / std::numbers::pi);
}

TEST(SimulatedArm, SpeedLMovesTcpAlongCommandedDirection) {
  SimulatedArm arm;
  const Eigen::Vector3d start = arm.state().base_T_flange.translation();
  Twist t = Twist::Zero();
  t[2] = 20.0;  // 20 mm/s up
  ASSERT_TRUE(arm.speedL(t, 500.0));
  for (int k = 0; k < 500; ++k) arm.step();  // 1 s
  const auto s = arm.state();
  const Eigen::Vector3d moved = s.base_T_flange.translation() - start;
  // Ramp of 20 / 500 = 0.04 s costs 0.4 mm of the 20 mm.
  EXPECT_NEAR(moved.z(), 20.0 - 0.4, 0.05);
  EXPECT_LT(moved.head<2>().norm(), 0.05);
  EXPECT_NEAR(s.flange_twist[2], 20.0, 1e-3);
  // Too fast for the controller: refused.
  t[2] = 5000.0;
  EXPECT_FALSE(arm.speedL(t, 500.0));
}

TEST(SimulatedArm, ProtectiveStopEndsWithinStoppingLimitAndNeedsUnlock) {
  SimulatedArm arm;
  Joints target = arm.state().q;
  target[0] += 2.5;
  for (int k = 0; k < 150; ++k) {  // 0.3 s: the base is near its top speed
    arm.servoJ(target);
    arm.step();
  }
  ASSERT_GT(arm.state().qd.cwiseAbs().maxCoeff(), 2.0);
  arm.injectFault(Fault::ProtectiveStop, arm.state().cycle + 1);
  arm.step();
  EXPECT_EQ(arm.state().safety, SafetyMode::ProtectiveStop);
  EXPECT_FALSE(arm.servoJ(target));
  const int cycles = cyclesToStandstill(arm, 1000);
  EXPECT_LE(cycles * arm.controlPeriodS(), arm.options().stop_time_limit_s);
  // Decelerating at 15 rad/s^2 from ~pi rad/s takes at least 0.2 s: the stop is a ramp, not a jump.
  EXPECT_GE(cycles * arm.controlPeriodS(), 0.1);
  EXPECT_TRUE(arm.unlockProtectiveStop());
  EXPECT_EQ(arm.state().safety, SafetyMode::Normal);
  EXPECT_TRUE(arm.servoJ(target));
}

TEST(SimulatedArm, EmergencyStopPowersOffAndNeedsReset) {
  SimulatedArm arm;
  Twist t = Twist::Zero();
  t[0] = 100;
  arm.speedL(t, 1000);
  for (int k = 0; k < 100; ++k) arm.step();
  arm.injectFault(Fault::EmergencyStop, 120);
  while (arm.state().cycle < 120) arm.step();
  EXPECT_EQ(arm.state().safety, SafetyMode::EmergencyStop);
  const int cycles = cyclesToStandstill(arm, 1000);
  EXPECT_LE(cycles * arm.controlPeriodS(), arm.options().stop_time_limit_s);
  arm.step();
  EXPECT_EQ(arm.state().mode, RobotMode::PowerOff);
  EXPECT_FALSE(arm.unlockProtectiveStop());
  EXPECT_FALSE(arm.speedL(t, 1000));
  EXPECT_TRUE(arm.resetEmergencyStop());
  EXPECT_TRUE(arm.speedL(t, 1000));
}

TEST(SimulatedArm, DisconnectRefusesCommandsAndStopsTheArm) {
  SimulatedArm arm;
  Twist t = Twist::Zero();
  t[1] = 50;
  arm.speedL(t, 1000);
  arm.injectFault(Fault::Disconnect, 50);
  for (int k = 0; k < 50; ++k) arm.step();
  EXPECT_FALSE(arm.state().connected);
  EXPECT_EQ(arm.state().mode, RobotMode::Disconnected);
  EXPECT_FALSE(arm.speedL(t, 1000));
  EXPECT_LE(cyclesToStandstill(arm, 1000) * arm.controlPeriodS(), arm.options().stop_time_limit_s);
  EXPECT_GE(arm.refusedCommands(), 1u);
}

TEST(SimulatedArm, StopJDeceleratesAndJointLimitsHold) {
  SimulatedArm arm;
  Joints target = arm.state().q;
  target[5] += 3.0;
  for (int k = 0; k < 200; ++k) {
    arm.servoJ(target);
    arm.step();
  }
  ASSERT_TRUE(arm.stopJ(2.0));  // slower than the safety deceleration: raised to it
  EXPECT_LE(cyclesToStandstill(arm, 1000) * arm.controlPeriodS(), arm.options().stop_time_limit_s);
  EXPECT_EQ(arm.state().safety, SafetyMode::Normal);
  // Targets outside the joint limits are refused.
  Joints bad = arm.state().q;
  bad[2] = 3.5;
  EXPECT_FALSE(arm.servoJ(bad));
  bad[2] = std::nan("");
  EXPECT_FALSE(arm.servoJ(bad));
}

TEST(SimulatedArm, RejectsBadOptions) {
  SimulatedArmOptions o;
  o.control_period_s = 0;
  EXPECT_THROW(SimulatedArm{o}, InvalidArgumentError);
  o = {};
  o.q0[2] = 4.0;
  EXPECT_THROW(SimulatedArm{o}, InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::robot
