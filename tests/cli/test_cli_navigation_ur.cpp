// mrsns-cli session run DIR navigation --robot ur --robot-host H --robot-ports RTDE,SCRIPT,DASHBOARD: the flags
// reach the navigation step; nobody listening is exit 1 with one line naming host:port; no robot calibration
// is exit 1 saying which step to run; malformed ports are usage errors (exit 2); against `mrsns-cli robot-sim`
// in another process a tracker loss stops the controller's arm through the supervisor.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <nlohmann/json.hpp>
#include <thread>
#include <vector>

#include "cli_runner.h"
#include "loopback_ports.h"
#include "test_data.h"

extern char** environ;

namespace mrsns::test {
namespace {

std::size_t lines(const std::string& text) {
  return static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n'));
}

TEST(CliNavigationUr, NobodyListeningIsExitOneWithOneLineNamingHostAndPort) {
  const auto dir = scratchDirectory("navur_cli") / "s";
  ASSERT_EQ(runCli({"session", "create", dir.string()}).exit_code, 0);
  // Without the robot calibration the step says which step to run first.
  auto r = runCli({"session", "run", dir.string(), "navigation", "--robot", "ur", "--param", "duration_s=1"});
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("robot-calibration"), std::string::npos) << r.err;
  EXPECT_EQ(lines(r.err), 1u) << r.err;

  ASSERT_EQ(runCli({"session", "run", dir.string(), "robot-calibration"}).exit_code, 0);
  const int port = closedPort();
  const std::string ports = std::to_string(port) + "," + std::to_string(port) + "," + std::to_string(port);
  r = runCli({"session", "run", dir.string(), "navigation", "--robot", "ur", "--robot-host", "127.0.0.1",
              "--robot-ports", ports, "--param", "duration_s=1", "--json"});
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
  EXPECT_EQ(lines(r.err), 1u) << r.err;
  EXPECT_NE(r.err.find("127.0.0.1:" + std::to_string(port)), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("UR controller"), std::string::npos) << r.err;
}

TEST(CliNavigationUr, ASimulatedTrackerNeverDrivesAControllerOnTheNetwork) {
  const auto dir = scratchDirectory("navur_cli") / "net";
  ASSERT_EQ(runCli({"session", "create", dir.string()}).exit_code, 0);
  ASSERT_EQ(runCli({"session", "run", dir.string(), "robot-calibration"}).exit_code, 0);
  // 192.0.2.1 (TEST-NET-1) stands for a real arm on the lab's network: refused before any connection.
  const auto r = runCli({"session", "run", dir.string(), "navigation", "--robot", "ur", "--robot-host", "192.0.2.1",
                         "--param", "duration_s=1"});
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_EQ(lines(r.err), 1u) << r.err;
  EXPECT_NE(r.err.find("a simulated tracker never drives a real controller"), std::string::npos) << r.err;
}

TEST(CliNavigationUr, WithThePlusServersTrackingTheDrillMustBeCalibratedOnThisSession) {
  const auto dir = scratchDirectory("navur_cli") / "drill";
  ASSERT_EQ(runCli({"session", "create", dir.string()}).exit_code, 0);
  // The in-process simulated robot calibration knows where the base is, not where the drill's marker sits.
  ASSERT_EQ(runCli({"session", "run", dir.string(), "robot-calibration"}).exit_code, 0);
  const auto r = runCli({"session", "run", dir.string(), "navigation", "--robot", "ur", "--param", "source=plus",
                         "--param", "port=" + std::to_string(closedPort()), "--param", "duration_s=1"});
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_EQ(lines(r.err), 1u) << r.err;
  EXPECT_NE(r.err.find("MarkerToFlange"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("robot-calibration with source=ur"), std::string::npos) << r.err;
}

// `mrsns-cli robot-sim --port-offset N` in the background, killed (by its pid) when the test ends.
class RobotSimProcess {
 public:
  explicit RobotSimProcess(int offset) {
    std::vector<std::string> args = {cliBinary().string(), "robot-sim", "--port-offset",  std::to_string(offset),
                                     "--duration",         "30",        "--unlock-delay", "0"};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
    if (posix_spawn(&pid_, argv[0], &actions, nullptr, argv.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&actions);
  }
  ~RobotSimProcess() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGKILL);
    int status = 0;
    ::waitpid(pid_, &status, 0);
  }
  RobotSimProcess(const RobotSimProcess&) = delete;
  RobotSimProcess& operator=(const RobotSimProcess&) = delete;
  [[nodiscard]] bool alive() const {
    int status = 0;
    return pid_ > 0 && ::waitpid(pid_, &status, WNOHANG) == 0;
  }

 private:
  pid_t pid_ = -1;
};

TEST(CliNavigationUr, AgainstTheRobotSimulatorATrackerLossStopsTheControllersArm) {
  // robot-sim binds 29999, 30002, 30003, 30004 + offset: four ports free now, below the ephemeral range.
  std::unique_ptr<RobotSimProcess> sim;
  int rtde = 0;
  for (int attempt = 0; attempt < 3 && !sim; ++attempt) {
    const int offset = freeUrPortOffset();
    if (offset <= 0) continue;
    rtde = 30004 + offset;
    sim = std::make_unique<RobotSimProcess>(offset);
    const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (sim->alive() && !accepts(rtde) && std::chrono::steady_clock::now() < end) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    if (!sim->alive() || !accepts(rtde)) sim.reset();  // a port of the four was taken: another offset
  }
  ASSERT_TRUE(sim) << "robot-sim did not start";
  const auto dir = scratchDirectory("navur_cli") / "sim";
  ASSERT_EQ(runCli({"session", "create", dir.string()}).exit_code, 0);
  ASSERT_EQ(runCli({"session", "run", dir.string(), "robot-calibration"}).exit_code, 0);
  const std::string ports = std::to_string(rtde) + "," + std::to_string(rtde - 1) + "," + std::to_string(rtde - 5);
  const auto r = runCli({"session", "run", dir.string(), "navigation", "--robot", "ur", "--robot-host", "127.0.0.1",
                         "--robot-ports", ports, "--tracker-dropout", "PatientToTracker:2.2:1", "--param",
                         "duration_s=3.2", "--param", "deformation_cases=0",
                         // stops must come from tracking, not from this shared machine's scheduling
                         "--param", "max_missed_cycles=200", "--param", "max_cycle_time_s=0.2", "--param", "silence_timeout_s=1", "--param",
                         "ur_silence_s=0.5", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["robot"], "ur");
  EXPECT_TRUE(j["robot_stopped"].get<bool>()) << r.out;
  EXPECT_NE(j["stop_reason"].get<std::string>().find("PatientNotTracked"), std::string::npos) << j["stop_reason"];
  EXPECT_EQ(j["supervisor_state"], "Stopped");
  EXPECT_GE(j["stop_latency_cycles"].get<int>(), 1);
  EXPECT_LE(j["arm_speed_end_rad_s"].get<double>(), 1e-6);
  EXPECT_GT(j["figures"]["robot"]["motion_commands"].get<int>(), 0);
  EXPECT_EQ(j["figures"]["robot"]["motion_commands_after_stop"], 0);
}

TEST(CliNavigationUr, MalformedPortsAreUsageErrorsAndTheFlagsNeedTheUrRobot) {
  const auto dir = scratchDirectory("navur_cli") / "u";
  ASSERT_EQ(runCli({"session", "create", dir.string()}).exit_code, 0);
  for (const char* bad : {"30004", "30004,30003", "30004,30003,29999,1", "a,b,c", "0,1,2", "30004,30003,70000",
                          "30004,,29999", "30004,30003,"}) {
    const auto r = runCli({"session", "run", dir.string(), "navigation", "--robot", "ur", "--robot-ports", bad});
    EXPECT_EQ(r.exit_code, 2) << bad << ": " << r.err;
    EXPECT_NE(r.err.find("RTDE,SCRIPT,DASHBOARD"), std::string::npos) << r.err;
  }
  const auto r = runCli({"session", "run", dir.string(), "navigation", "--robot", "simulated", "--robot-host", "h"});
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("--robot ur"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace mrsns::test
