// UrRtdeArm (RTDE state + script commands + dashboard unlock) end to end against the UR simulator on 127.0.0.1
// ephemeral ports: the same RobotArm interface the supervisor drives, over real sockets. Waits poll the state
// with generous deadlines (the machine is shared); no assertion depends on wall-clock speed.
#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <thread>

#include "mrsns/core/error.h"
#include "mrsns/robot/ur_rtde_arm.h"
#include "mrsns/robot/ur_simulator.h"
#include "ur_simulator_ports.h"

using namespace mrsns::robot;

namespace {

using ::mrsns::test::ephemeralUrSimulator;

UrRtdeArmOptions clientOf(const UrSimulator& sim, double frequency_hz = 500) {
  UrRtdeArmOptions o;
  o.rtde_port = sim.rtdePort();
  o.dashboard_port = sim.dashboardPort();
  o.script_port = sim.realtimePort();
  o.frequency_hz = frequency_hz;
  // Tolerate the scheduling of a shared machine in these tests; the default (1.5 periods) is for a real loop.
  o.stale_after_periods = 25;
  return o;
}

// Polls `done` (calling `each` first) every control period until true or the deadline.
bool waitFor(const std::function<bool()>& done, double seconds, const std::function<void()>& each = {}) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < deadline) {
    if (each) each();
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return done();
}

}  // namespace

TEST(UrRtdeArm, StateMirrorsTheSimulator) {
  UrSimulator sim(ephemeralUrSimulator());
  UrRtdeArm arm(clientOf(sim, 125));
  EXPECT_EQ(arm.controllerVersion(), "5.8.0.0");
  EXPECT_DOUBLE_EQ(arm.controlPeriodS(), 0.008);
  ASSERT_TRUE(waitFor([&] { return arm.state().connected; }, 3));
  const auto s = arm.state();
  EXPECT_EQ(s.safety, SafetyMode::Normal);
  EXPECT_EQ(s.mode, RobotMode::Running);
  // The arm is at rest: the joints are the simulator's, exactly (doubles travel unchanged).
  EXPECT_EQ(s.q, sim.armState().q);
  // The TCP pose went through UR units (m, rotation vector) and back.
  EXPECT_LT((s.base_T_flange.matrix() - sim.armState().base_T_flange.matrix()).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(UrRtdeArm, ServoJMovesTheSimulatedArm) {
  UrSimulator sim(ephemeralUrSimulator());
  UrRtdeArm arm(clientOf(sim));
  ASSERT_TRUE(waitFor([&] { return arm.state().connected; }, 3));
  Joints target = arm.state().q;
  target[0] += 0.2;
  target[2] -= 0.1;
  // The control loop renews the target every cycle, as a real servoj stream does.
  // Both the controller and the state the client reads must settle there: the
  // client's state is one RTDE period old, so it can show the arm passing the
  // target while the controller is still closing in.
  const auto settled = [&] {
    return (arm.state().q - target).cwiseAbs().maxCoeff() < 1e-6 &&
           (sim.armState().q - target).cwiseAbs().maxCoeff() < 1e-6;
  };
  EXPECT_TRUE(waitFor(settled, 3, [&] { EXPECT_TRUE(arm.servoJ(target)); }));
  EXPECT_LT((sim.armState().q - target).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_GT(arm.stats().commands_sent, 0u);
  Joints bad = target;
  bad[1] = std::nan("");
  EXPECT_FALSE(arm.servoJ(bad));
}

TEST(UrRtdeArm, StopJBringsTheArmToRest) {
  UrSimulator sim(ephemeralUrSimulator());
  UrRtdeArm arm(clientOf(sim));
  ASSERT_TRUE(waitFor([&] { return arm.state().connected; }, 3));
  Twist v = Twist::Zero();
  v[2] = 50;  // 50 mm/s up
  ASSERT_TRUE(arm.speedL(v, 500));
  ASSERT_TRUE(waitFor([&] { return arm.state().flange_twist.head<3>().norm() > 20; }, 3));
  ASSERT_TRUE(arm.stopJ(10));
  EXPECT_TRUE(waitFor([&] { return arm.state().qd.cwiseAbs().maxCoeff() == 0.0; }, 3));
  EXPECT_EQ(sim.armState().qd.cwiseAbs().maxCoeff(), 0.0);
}

TEST(UrRtdeArm, ProtectiveStopNeedsDashboardUnlock) {
  UrSimulator sim(ephemeralUrSimulator());
  UrRtdeArm arm(clientOf(sim));
  ASSERT_TRUE(waitFor([&] { return arm.state().connected; }, 3));
  ASSERT_TRUE(arm.protectiveStop());
  ASSERT_TRUE(waitFor([&] { return arm.state().safety == SafetyMode::ProtectiveStop; }, 3));
  EXPECT_EQ(sim.safetyMode(), UrSafetyMode::ProtectiveStop);
  const Joints here = arm.state().q;
  EXPECT_FALSE(arm.servoJ(here));  // latched until unlocked
  ASSERT_TRUE(waitFor([&] { return arm.unlockProtectiveStop(); }, 3));
  ASSERT_TRUE(waitFor([&] { return arm.state().safety == SafetyMode::Normal; }, 3));
  EXPECT_TRUE(arm.servoJ(here));
}

TEST(UrRtdeArm, UnlockRefusedWithinFiveSecondsOfTheStop) {
  UrSimulator sim(ephemeralUrSimulator(5.0));
  UrRtdeArm arm(clientOf(sim));
  ASSERT_TRUE(waitFor([&] { return arm.state().connected; }, 3));
  ASSERT_TRUE(arm.protectiveStop());
  ASSERT_TRUE(waitFor([&] { return arm.state().safety == SafetyMode::ProtectiveStop; }, 3));
  EXPECT_FALSE(arm.unlockProtectiveStop());
  EXPECT_EQ(sim.safetyMode(), UrSafetyMode::ProtectiveStop);
}

TEST(UrRtdeArm, DroppedConnectionIsDetectedWithoutThrowing) {
  UrSimulator sim(ephemeralUrSimulator());
  UrRtdeArm arm(clientOf(sim));
  ASSERT_TRUE(waitFor([&] { return arm.state().connected; }, 3));
  sim.dropClients();
  EXPECT_TRUE(waitFor([&] { return !arm.state().connected; }, 3));
  EXPECT_EQ(arm.state().mode, RobotMode::Disconnected);
  EXPECT_FALSE(arm.servoJ(arm.state().q));
  EXPECT_FALSE(arm.stopJ(10));
}

TEST(UrRtdeArm, SilentControllerIsDetectedFromStaleness) {
  UrSimulator sim(ephemeralUrSimulator());
  auto options = clientOf(sim);
  options.stale_after_periods = 1.5;  // the default: one missing package (plus half a period) is a loss
  UrRtdeArm arm(options);
  ASSERT_TRUE(waitFor([&] { return arm.state().connected; }, 3));
  sim.setFrozen(true);  // sockets stay open, nothing arrives
  ASSERT_TRUE(waitFor([&] { return !arm.state().connected; }, 3));
  // Staleness is judged when state() is called: once the newest package is older than 1.5 periods, every call
  // reports the loss, however late the control loop asks.
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_FALSE(arm.state().connected);
  EXPECT_GT(arm.stats().last_package_age_s, 1.5 * arm.controlPeriodS());
  EXPECT_FALSE(arm.speedL(Twist::Zero(), 100));
}

TEST(UrRtdeArm, SimulatorShutdownIsDetected) {
  auto sim = std::make_unique<UrSimulator>(ephemeralUrSimulator());
  UrRtdeArm arm(clientOf(*sim));
  ASSERT_TRUE(waitFor([&] { return arm.state().connected; }, 3));
  sim.reset();
  EXPECT_TRUE(waitFor([&] { return !arm.state().connected; }, 3));
  EXPECT_FALSE(arm.unlockProtectiveStop());  // dashboard unreachable: false, no throw
}

TEST(UrRtdeArm, NoControllerIsAClearNetworkError) {
  std::uint16_t port = 0;
  {
    UrSimulator sim(ephemeralUrSimulator());
    port = sim.rtdePort();
  }
  UrRtdeArmOptions o;
  o.rtde_port = port;
  o.connect_timeout_s = 0.5;
  EXPECT_THROW(UrRtdeArm{o}, mrsns::NetworkError);
  o.frequency_hz = 1000;
  EXPECT_THROW(UrRtdeArm{o}, mrsns::InvalidArgumentError);
}

TEST(UrRtdeArm, InjectedFaultsReachTheClient) {
  UrSimulator sim(ephemeralUrSimulator());
  UrRtdeArm arm(clientOf(sim));
  ASSERT_TRUE(waitFor([&] { return arm.state().connected; }, 3));
  // A protective stop raised by the controller itself at a known cycle: the client sees it, stamped no earlier.
  const auto at = sim.armState().cycle + 25;
  sim.arm().injectFault(Fault::ProtectiveStop, at);
  ASSERT_TRUE(waitFor([&] { return arm.state().safety == SafetyMode::ProtectiveStop; }, 3));
  EXPECT_GE(arm.state().cycle, at);
  EXPECT_FALSE(arm.speedL(Twist::Zero(), 100));  // motion refused in a protective stop
  // The controller's link drops (its side): the stream stops and the client reports the loss.
  sim.arm().injectFault(Fault::Disconnect, sim.armState().cycle + 5);
  EXPECT_TRUE(waitFor([&] { return !arm.state().connected; }, 3));
}
