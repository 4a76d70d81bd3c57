// `mrsns-cli robot-sim` in the background and `mrsns-cli robot-status` against it over loopback; errors when no
// controller answers; usage errors.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "cli_runner.h"
#include "loopback_ports.h"

extern char** environ;

namespace {

using mrsns::test::CliResult;
using mrsns::test::runCli;

class Background {
 public:
  explicit Background(std::vector<std::string> args) {
    args.insert(args.begin(), mrsns::test::cliBinary().string());
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    out_ = std::filesystem::temp_directory_path() / ("mrsns-robot-sim-" + std::to_string(::getpid()) + ".json");
    err_ = std::filesystem::temp_directory_path() / ("mrsns-robot-sim-" + std::to_string(::getpid()) + ".err");
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, out_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&actions, 2, err_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
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
  /// What the process wrote to stderr so far (why it could not start).
  std::string errors() const {
    std::ifstream in(err_);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }
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
  std::filesystem::path out_, err_;
};

}  // namespace

TEST(CliRobotSim, StatusOfTheSimulatorOverLoopback) {
  // The simulator binds 29999, 30002, 30003 and 30004 + offset. The offset
  // comes from a port the kernel just handed out (free, nobody listening),
  // as RTDE's; another process may still take one of the four meanwhile:
  // the simulator then exits at once (saying so on stderr) and new ports are
  // tried. The simulator is asked for its status once its dashboard accepts.
  std::unique_ptr<Background> sim;
  int port_offset = 0;
  CliResult status;
  std::string why;
  for (int attempt = 0; attempt < 8 && status.exit_code != 0; ++attempt) {
    port_offset = mrsns::test::freeUrPortOffset();
    if (port_offset <= 0) continue;
    const auto offset = std::to_string(port_offset);
    sim = std::make_unique<Background>(
        std::vector<std::string>{"robot-sim", "--port-offset", offset, "--duration", "30", "--json"});
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(15);
    while (sim->running() && !mrsns::test::accepts(29999 + port_offset) &&
           std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    if (!sim->running()) {
      why += "attempt " + std::to_string(attempt) + ", offset " + offset + ": " + sim->errors();
      continue;
    }
    status = runCli({"robot-status", "--port-offset", offset, "--json"});
    if (status.exit_code != 0) why += "attempt " + std::to_string(attempt) + ": " + status.err;
  }
  ASSERT_EQ(status.exit_code, 0) << why;
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
  // Nothing listens on the dashboard port: one the kernel just handed out and nobody took.
  const int dashboard = mrsns::test::closedPort();
  ASSERT_GT(dashboard, 29999);
  const auto r = runCli({"robot-status", "--port-offset", std::to_string(dashboard - 29999), "--timeout", "0.5"});
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
