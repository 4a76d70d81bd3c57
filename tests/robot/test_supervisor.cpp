// Fault injection for every stop condition of the safety supervisor, through the whole control loop and
// the simulated UR5: the fault is injected at a known cycle, the stop command goes out in that same cycle
// (before any motion command), the arm's speed reaches zero within the stopping-time limit, nothing moves
// the arm until acknowledge(), and acknowledge() is refused while the arm moves or the robot still
// reports a safety stop.
#include <gtest/gtest.h>

#include <functional>
#include <string>

#include "mrsns/core/mesh_locator.h"
#include "robot_test_scene.h"

namespace mrsns::robot {
namespace {

using test::Scene;

struct FaultCase {
  const char* name;
  StopReason expected;
  SupervisorState phase;                  // inject while aligning or advancing
  std::function<void(Scene&)> configure;  // before build()
  std::function<void(Scene&)> inject;     // right before the detection tick
  std::function<void(Scene&)> clear;      // remove the cause before acknowledging
  bool arm_can_take_stop = true;          // false when the link to the robot is down
};

void noop(Scene&) {}

std::vector<FaultCase> cases() {
  return {
      {"ToolNotTracked", StopReason::ToolNotTracked, SupervisorState::Aligning, noop,
       [](Scene& s) { s.drill_visible = false; }, [](Scene& s) { s.drill_visible = true; }},
      {"PatientNotTracked", StopReason::PatientNotTracked, SupervisorState::Advancing, noop,
       [](Scene& s) { s.patient_visible = false; }, [](Scene& s) { s.patient_visible = true; }},
      {"ToolStale", StopReason::ToolStale, SupervisorState::Aligning, noop, [](Scene& s) { s.drill_delay_s = 0.15; },
       [](Scene& s) { s.drill_delay_s = 0; }},
      {"PatientStale", StopReason::PatientStale, SupervisorState::Advancing, noop,
       [](Scene& s) { s.patient_delay_s = 0.15; }, [](Scene& s) { s.patient_delay_s = 0; }},
      {"TrackerDisconnected", StopReason::TrackerDisconnected, SupervisorState::Advancing, noop,
       [](Scene& s) { s.tracker_connected = false; }, [](Scene& s) { s.tracker_connected = true; }},
      // The patient shifts 2.5 mm across the drill (limit 1.5 mm).
      {"OffAxisDistance", StopReason::OffAxisDistance, SupervisorState::Advancing, noop,
       [](Scene& s) {
         const Eigen::Vector3d d = s.setup.plan.direction();
         s.base_T_patient.translation() += 2.5 * d.unitOrthogonal();
       },
       [](Scene& s) { s.base_T_patient = Eigen::Isometry3d::Identity(); }},
      // The patient turns 3 deg about the drill tip (limit 2 deg): the tip stays on the axis, the axis tilts.
      {"OffAxisAngle", StopReason::OffAxisAngle, SupervisorState::Advancing, noop,
       [](Scene& s) {
         const Eigen::Vector3d c = s.tip().translation();
         const Eigen::Vector3d d = s.setup.plan.direction();
         Eigen::Isometry3d R = Eigen::Isometry3d::Identity();
         R.linear() = Eigen::AngleAxisd(3.0 * M_PI / 180, d.unitOrthogonal()).toRotationMatrix();
         R.translation() = c - R.linear() * c;
         s.base_T_patient = R;
       },
       [](Scene& s) { s.base_T_patient = Eigen::Isometry3d::Identity(); }},
      // The soft tissue (posterior shape) moves to 1 mm from the drill tip (margin 2 mm).
      {"SoftTissueMargin", StopReason::SoftTissueMargin, SupervisorState::Advancing, noop,
       [](Scene& s) {
         const Eigen::Vector3d c = s.tip().translation() + 3.0 * s.setup.plan.direction().unitOrthogonal();
         s.loop->setSoftTissue(std::make_shared<MeshLocator>(test::boxMesh(c, 2.0)));
       },
       [](Scene& s) {
         const Eigen::Vector3d c = s.tip().translation() + 40.0 * s.setup.plan.direction().unitOrthogonal();
         s.loop->setSoftTissue(std::make_shared<MeshLocator>(test::boxMesh(c, 2.0)));
       }},
      {"WatchdogOverrun", StopReason::WatchdogOverrun, SupervisorState::Aligning, noop,
       [](Scene& s) { s.cycle_time_s = 0.0031; }, [](Scene& s) { s.cycle_time_s = 0; }},
      {"MissedCycles", StopReason::MissedCycles, SupervisorState::Advancing, noop, [](Scene& s) { s.missed = 3; },
       [](Scene& s) { s.missed = 0; }},
      {"RobotProtectiveStop", StopReason::RobotProtectiveStop, SupervisorState::Aligning, noop,
       [](Scene& s) {
         s.arm->injectFault(Fault::ProtectiveStop, s.arm->state().cycle + 1);
         s.arm->step();
       },
       noop},
      {"RobotEmergencyStop", StopReason::RobotEmergencyStop, SupervisorState::Advancing, noop,
       [](Scene& s) {
         s.arm->injectFault(Fault::EmergencyStop, s.arm->state().cycle + 1);
         s.arm->step();
       },
       [](Scene& s) { EXPECT_TRUE(s.arm->resetEmergencyStop()); }},
      {"RobotFault", StopReason::RobotFault, SupervisorState::Aligning, noop,
       [](Scene& s) {
         s.arm->injectFault(Fault::JointFault, s.arm->state().cycle + 1);
         s.arm->step();
       },
       [](Scene& s) { EXPECT_TRUE(s.arm->resetEmergencyStop()); }},
      {"RobotDisconnected", StopReason::RobotDisconnected, SupervisorState::Advancing, noop,
       [](Scene& s) {
         s.arm->injectFault(Fault::Disconnect, s.arm->state().cycle + 1);
         s.arm->step();
       },
       [](Scene& s) {
         s.arm->injectFault(Fault::Reconnect, s.arm->state().cycle + 1);
         s.arm->step();
       },
       false},
  };
}

class StopCondition : public ::testing::TestWithParam<FaultCase> {};

TEST_P(StopCondition, StopsInTheDetectionCycleAndNeedsAcknowledge) {
  const FaultCase& fc = GetParam();
  Scene s;
  fc.configure(s);
  s.build();
  ASSERT_TRUE(s.loop->enable());
  ASSERT_TRUE(s.loop->startPlacement());
  // Reach the phase, and move a little inside it so the arm is moving when the fault comes.
  ASSERT_TRUE(s.runUntil(fc.phase, 3000)) << toString(s.loop->supervisor().state());
  for (int k = 0; k < 200 && s.loop->supervisor().state() == fc.phase; ++k) s.tickAndStep();
  ASSERT_EQ(s.loop->supervisor().state(), fc.phase);
  ASSERT_GT(s.arm->state().qd.cwiseAbs().maxCoeff(), 1e-4) << "the arm should be moving when the fault comes";

  fc.inject(s);
  const std::uint64_t fault_cycle = s.loop->cycle() + 1;
  const CycleReport r = s.loop->tick(s.sense(), s.cycle_time_s, s.missed);
  EXPECT_EQ(r.cycle, fault_cycle);
  EXPECT_EQ(r.decision.reason, fc.expected) << toString(r.decision.reason);
  EXPECT_NE(r.stop_sent, StopCommand::None);
  EXPECT_EQ(r.stop_accepted, fc.arm_can_take_stop);
  EXPECT_FALSE(r.motion_sent);  // the stop is the only command of that cycle
  const auto& log = s.loop->supervisor().transitions();
  ASSERT_FALSE(log.empty());
  EXPECT_EQ(log.back().cycle, fault_cycle);
  EXPECT_EQ(log.back().reason, fc.expected);
  EXPECT_EQ(log.back().from, fc.phase);
  EXPECT_FALSE(log.back().detail.empty());
  const SupervisorState stopped = s.loop->supervisor().state();
  EXPECT_TRUE(stopped == SupervisorState::Stopped || stopped == SupervisorState::Fault);

  // The arm comes to rest within the stopping-time limit; no motion command goes out meanwhile, and the
  // operator cannot acknowledge while it moves.
  s.arm->step();
  int cycles = 1;
  for (; cycles < 1000 && !s.arm->state().qd.isZero(0.0); ++cycles) {
    const CycleReport rr = s.tickAndStep();
    EXPECT_FALSE(rr.motion_sent);
    if (cycles == 1) {
      EXPECT_FALSE(s.loop->acknowledge());
    }
  }
  EXPECT_LE(cycles * s.arm->controlPeriodS(), s.arm->options().stop_time_limit_s)
      << "stop took " << cycles << " cycles";
  EXPECT_FALSE(s.loop->startPlacement());
  for (int k = 0; k < 50; ++k) EXPECT_FALSE(s.tickAndStep().motion_sent);
  EXPECT_EQ(s.loop->supervisor().state(), stopped);

  // Recovery: clear the cause, acknowledge, and the placement can start again.
  fc.clear(s);
  ASSERT_TRUE(s.loop->acknowledge()) << "acknowledge refused after " << fc.name;
  EXPECT_EQ(s.loop->supervisor().state(), SupervisorState::Ready);
  EXPECT_EQ(s.loop->supervisor().transitions().back().to, SupervisorState::Ready);
  s.tickAndStep();
  EXPECT_EQ(s.loop->supervisor().state(), SupervisorState::Ready);
  ASSERT_TRUE(s.loop->startPlacement());
  bool moved = false;
  for (int k = 0; k < 20; ++k) moved = s.tickAndStep().motion_sent || moved;
  EXPECT_TRUE(moved);
}

INSTANTIATE_TEST_SUITE_P(EveryStopCondition, StopCondition, ::testing::ValuesIn(cases()),
                         [](const ::testing::TestParamInfo<FaultCase>& param_info) { return param_info.param.name; });

// The controller loses the first stop (a dropped packet, a script interface that was not listening): the
// supervisor sends the stop again every cycle until the arm is at rest, so the arm still stops, one cycle later
// than it would have. One condition per stop command: StopJ (the drill not tracked) and ProtectiveStop (the soft
// tissue within the margin).
class LostStop : public ::testing::TestWithParam<FaultCase> {};

TEST_P(LostStop, TheStopIsRepeatedEveryCycleUntilTheArmIsAtRest) {
  const FaultCase& fc = GetParam();
  Scene s;
  SimulatedArmOptions lossy;
  lossy.stops_lost = 1;
  s.arm = std::make_shared<SimulatedArm>(lossy);
  fc.configure(s);
  s.build();
  ASSERT_TRUE(s.loop->enable());
  ASSERT_TRUE(s.loop->startPlacement());
  ASSERT_TRUE(s.runUntil(fc.phase, 3000)) << toString(s.loop->supervisor().state());
  for (int k = 0; k < 200 && s.loop->supervisor().state() == fc.phase; ++k) s.tickAndStep();
  ASSERT_EQ(s.loop->supervisor().state(), fc.phase);
  const double speed_before = s.arm->state().qd.cwiseAbs().maxCoeff();
  ASSERT_GT(speed_before, 1e-4) << "the arm should be moving when the fault comes";

  fc.inject(s);
  const CycleReport first = s.loop->tick(s.sense(), s.cycle_time_s, s.missed);
  s.arm->step();
  ASSERT_NE(first.stop_sent, StopCommand::None);
  EXPECT_FALSE(first.decision.stop_repeated);
  EXPECT_EQ(s.arm->lostStops(), 1U) << "the controller lost that stop";
  EXPECT_GT(s.arm->state().qd.cwiseAbs().maxCoeff(), 0.5 * speed_before) << "so the arm still moves";

  const CycleReport second = s.tickAndStep();
  EXPECT_EQ(second.stop_sent, first.stop_sent) << "the same stop, in the very next cycle";
  EXPECT_TRUE(second.decision.stop_repeated);
  EXPECT_EQ(second.decision.reason, fc.expected);
  EXPECT_FALSE(second.motion_sent);
  int cycles = 2;
  const double at_rest = s.options.limits.at_rest_joint_speed_rad_s;
  for (; cycles < 1000 && s.arm->state().qd.cwiseAbs().maxCoeff() > at_rest; ++cycles) {
    const CycleReport r = s.tickAndStep();
    EXPECT_NE(r.stop_sent, StopCommand::None) << "repeated while the arm moves, cycle " << cycles;
    EXPECT_FALSE(r.motion_sent);
  }
  // Within the stopping-time limit counted from the stop that arrived: one cycle later than without the loss.
  EXPECT_LE((cycles - 1) * s.arm->controlPeriodS(), s.arm->options().stop_time_limit_s)
      << "stop took " << cycles << " cycles";
  // At rest: no more stops go out (the controller is not flooded), and nothing moves the arm.
  for (int k = 0; k < 20; ++k) {
    const CycleReport r = s.tickAndStep();
    EXPECT_EQ(r.stop_sent, StopCommand::None);
    EXPECT_FALSE(r.motion_sent);
  }
}

// Both while aligning, where the arm moves fastest: a slow advance would come to rest at its last servo target
// within a cycle whether the stop arrived or not.
INSTANTIATE_TEST_SUITE_P(StopJAndProtectiveStop, LostStop, ::testing::ValuesIn([] {
                           std::vector<FaultCase> chosen;
                           for (auto c : cases()) {
                             const std::string name = c.name;
                             if (name != "ToolNotTracked" && name != "SoftTissueMargin") continue;
                             c.phase = SupervisorState::Aligning;
                             chosen.push_back(c);
                           }
                           return chosen;
                         }()),
                         [](const ::testing::TestParamInfo<FaultCase>& param_info) { return param_info.param.name; });

// Conditions that come from the motion itself: the stop must go out in the first cycle whose state
// shows the violation.
TEST(StopCondition, OverSpeedStopsInTheFirstCycleAboveTheLimit) {
  Scene s;
  s.options.limits.max_tcp_speed_mm_s = 25.0;  // the approach runs at 40 mm/s
  s.build();
  ASSERT_TRUE(s.loop->enable());
  ASSERT_TRUE(s.loop->startPlacement());
  for (int k = 0; k < 2000; ++k) {
    const ArmState a = s.arm->state();
    const Eigen::Vector3d lever = s.tip().translation() - a.base_T_flange.translation();
    const double speed = (a.flange_twist.head<3>() + a.flange_twist.tail<3>().cross(lever)).norm();
    const CycleReport r = s.tickAndStep();
    if (speed > 25.0) {
      EXPECT_EQ(r.decision.reason, StopReason::OverSpeed);
      EXPECT_EQ(r.stop_sent, StopCommand::ProtectiveStop);
      break;
    }
    ASSERT_EQ(r.stop_sent, StopCommand::None) << "stopped below the limit at " << speed;
  }
  EXPECT_EQ(s.loop->supervisor().state(), SupervisorState::Stopped);
  int cycles = 0;
  for (; cycles < 1000 && !s.arm->state().qd.isZero(0.0); ++cycles) s.tickAndStep();
  EXPECT_LE(cycles * 0.002, s.arm->options().stop_time_limit_s);
  EXPECT_FALSE(s.loop->startPlacement());
  EXPECT_TRUE(s.loop->acknowledge());  // unlocks the protective stop, then acknowledges
}

TEST(StopCondition, OutsideWorkspaceStopsInTheFirstCycleOutside) {
  Scene s;
  const Eigen::Vector3d tip0 = s.tip().translation();
  const Eigen::Vector3d goal = s.setup.plan.entry - 20.0 * s.setup.plan.direction();
  // A workspace wall halfway along the approach, across its largest component.
  Eigen::Index axis = 0;
  (goal - tip0).cwiseAbs().maxCoeff(&axis);
  const double wall = 0.5 * (tip0[axis] + goal[axis]);
  if (goal[axis] > tip0[axis]) {
    s.options.limits.workspace_max_mm[axis] = wall;
  } else {
    s.options.limits.workspace_min_mm[axis] = wall;
  }
  s.build();
  ASSERT_TRUE(s.loop->enable());
  ASSERT_TRUE(s.loop->startPlacement());
  bool stopped = false;
  for (int k = 0; k < 3000 && !stopped; ++k) {
    const double x = s.tip().translation()[axis];
    const bool outside = goal[axis] > tip0[axis] ? x > wall : x < wall;
    const CycleReport r = s.tickAndStep();
    EXPECT_EQ(r.stop_sent != StopCommand::None, outside) << "cycle " << r.cycle;
    stopped = r.stop_sent != StopCommand::None;
    if (stopped) {
      EXPECT_EQ(r.decision.reason, StopReason::OutsideWorkspace);
    }
  }
  ASSERT_TRUE(stopped);
  int cycles = 0;
  for (; cycles < 1000 && !s.arm->state().qd.isZero(0.0); ++cycles) s.tickAndStep();
  EXPECT_LE(cycles * 0.002, s.arm->options().stop_time_limit_s);
}

TEST(StopCondition, StalledControllerIsDetectedAfterTheStallLimit) {
  // A hung controller no longer advances its cycle counter; its speed cannot be observed, so the check
  // is the stop command within max_stalled_cycles ticks.
  Scene s;
  s.build();
  ASSERT_TRUE(s.loop->enable());
  ASSERT_TRUE(s.loop->startPlacement());
  for (int k = 0; k < 100; ++k) s.tickAndStep();
  s.arm->injectFault(Fault::Freeze, s.arm->state().cycle + 1);
  s.arm->step();
  std::uint64_t frozen_at = s.loop->cycle();
  CycleReport r;
  for (int k = 0; k < 10 && r.stop_sent == StopCommand::None; ++k) r = s.tickAndStep();
  EXPECT_EQ(r.decision.reason, StopReason::RobotStalled);
  EXPECT_LE(r.cycle - frozen_at, s.options.limits.max_stalled_cycles + 1);
}

TEST(SafetySupervisor, RequestsFollowTheStateMachine) {
  SafetySupervisor sup;
  ArmState arm;
  arm.connected = true;
  EXPECT_FALSE(sup.startAligning(1, 0));  // Disabled
  EXPECT_TRUE(sup.enable(1, 0));
  EXPECT_FALSE(sup.startAligning(2, 0));  // no planned axis
  sup.setPlannedAxis({Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), true});
  EXPECT_TRUE(sup.startAligning(3, 0));
  EXPECT_TRUE(sup.pause(4, 0));
  EXPECT_EQ(sup.state(), SupervisorState::Paused);
  EXPECT_TRUE(sup.resume(5, 0));
  EXPECT_EQ(sup.state(), SupervisorState::Aligning);
  EXPECT_TRUE(sup.aligned(6, 0));
  EXPECT_EQ(sup.state(), SupervisorState::Advancing);
  EXPECT_FALSE(sup.acknowledge(arm, 7, 0));  // nothing to acknowledge
  EXPECT_TRUE(sup.finished(8, 0));
  EXPECT_EQ(sup.state(), SupervisorState::Ready);
  EXPECT_TRUE(sup.disable(9, 0));
  EXPECT_EQ(sup.transitions().size(), 7u);
  for (std::size_t i = 1; i < sup.transitions().size(); ++i) {
    EXPECT_EQ(sup.transitions()[i].from, sup.transitions()[i - 1].to);
  }
  // Disabled: no checks run, nothing is stopped.
  SupervisorInputs in;
  in.arm = arm;
  in.tool_tracked = false;
  EXPECT_EQ(sup.tick(in).stop, StopCommand::None);
}

}  // namespace
}  // namespace mrsns::robot
