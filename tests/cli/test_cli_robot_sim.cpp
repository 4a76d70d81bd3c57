// `mrsns-cli robot-sim` in the background and `mrsns-cli robot-status` against it over loopback; errors when no
// controller answers; usage errors.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <memory>
#include <nlohmann/json.hpp>
#include <thread>

#include "cli_runner.h"

extern char** environ;

namespace {

using mrsns::test::CliResult;
using mrsns::test::runCli;

// A port offset unlikely to collide with another test process (ports 40004.. 60003).
int portOffset() {
  return 10000 + static_cast<int>(::getpid() % 20000);
}

class Background {
 public:
  explicit Background(std::vector<std::string> args) {
    args.insert(args.begin(), mrsns::test::cliBinary().string());
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    out_ = std::filesystem::temp_directory_path() / ("mrsns-robot-sim-" + std::to_string(::getpid()) + ".json");
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, out_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
    if (posix_spawn(&pid_, argv[0], &actions, nullptr, argv.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&actions);
  }
  ~Background() {
    if (pid_ > 0 && !done_) {
      ::kill(pid_, SIGKILL);
      int status = 0;
      ::waitpid(pid_, &status, 0);
    }
  }
  /// False once the process has exited (e.g. a port of its set was taken).
  bool running() {
    if (pid_ <= 0 || done_) return false;
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == 0) return true;
    done_ = true;
    return false;
  }
  Background(const Background&) = delete;
  Background& operator=(const Background&) = delete;
  /// SIGTERM, then the exit code and stdout.
  std::pair<int, std::string> stop() {
    ::kill(pid_, SIGTERM);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    done_ = true;
    std::ifstream in(out_);
    std::stringstream s;
    s << in.rdbuf();
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, s.str()};
  }

 private:
  pid_t pid_ = -1;
  bool done_ = false;
  std::filesystem::path out_;
};

}  // namespace

TEST(CliRobotSim, StatusOfTheSimulatorOverLoopback) {
  // The simulator's four ports (UR numbers + offset) lie in the kernel's
  // ephemeral range, so another test's connection may hold one: the
  // simulator then exits at once (cannot listen) and the next offset is tried.
  std::unique_ptr<Background> sim;
  int port_offset = 0;
  CliResult status;
  for (int attempt = 0; attempt < 5 && status.exit_code != 0; ++attempt) {
    port_offset = portOffset() + 997 * attempt;
    const auto offset = std::to_string(port_offset);
    sim = std::make_unique<Background>(
        std::vector<std::string>{"robot-sim", "--port-offset", offset, "--duration", "30", "--json"});
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(15);
    do {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      status = runCli({"robot-status", "--port-offset", offset, "--json"});
    } while (status.exit_code != 0 && sim->running() && std::chrono::steady_clock::now() < deadline);
  }
  ASSERT_EQ(status.exit_code, 0) << status.err;
  const auto j = nlohmann::json::parse(status.out);
  EXPECT_EQ(j["robot_mode"], "RUNNING");
  EXPECT_EQ(j["safety_mode"], "NORMAL");
  EXPECT_EQ(j["controller_version"], "5.8.0.0");
  ASSERT_EQ(j["joints_rad"].size(), 6u);
  // SimulatedArm's start pose (0, -pi/2, pi/2, -pi/2, -pi/2, 0) to 4 decimals.
  EXPECT_NEAR(j["joints_rad"][1].get<double>(), -1.5708, 1e-12);
  EXPECT_NEAR(j["joints_deg"][2].get<double>(), 1.5708 * 180 / M_PI, 1e-9);
  EXPECT_EQ(j["tcp_position_mm"].size(), 3u);
  EXPECT_GT(j["rtde_packages"].get<int>(), 0);

  const auto [code, out] = sim->stop();
  EXPECT_EQ(code, 0);
  const auto s = nlohmann::json::parse(out);
  EXPECT_EQ(s["host"], "127.0.0.1");
  EXPECT_EQ(s["ports"]["rtde"].get<int>(), 30004 + port_offset);
  EXPECT_EQ(s["ports"]["dashboard"].get<int>(), 29999 + port_offset);
  EXPECT_GT(s["cycles"].get<int>(), 0);
  EXPECT_GE(s["clients_connected"].get<int>(), 3);  // dashboard, RTDE and script connections of robot-status
  EXPECT_GT(s["dashboard_commands"].get<int>(), 0);
}

TEST(CliRobotSim, NoControllerIsOneLineError) {
  // Nothing listens at this offset (a second process would have to pick the same pid-derived offset).
  const auto r = runCli({"robot-status", "--port-offset", std::to_string(portOffset() + 7), "--timeout", "0.5"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("dashboard"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_TRUE(r.out.empty());
}

TEST(CliRobotSim, UsageErrors) {
  EXPECT_EQ(runCli({"robot-sim", "--port-offset", "-3"}).exit_code, 2);
  EXPECT_EQ(runCli({"robot-status", "--frequency", "1000"}).exit_code, 2);
  const auto bad_host = runCli({"robot-sim", "--host", "not-an-ip", "--duration", "0.1"});
  EXPECT_EQ(bad_host.exit_code, 1);
  EXPECT_NE(bad_host.err.find("not an IP address"), std::string::npos) << bad_host.err;
}
