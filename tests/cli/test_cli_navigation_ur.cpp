// mrsns-cli session run DIR navigation --robot ur --robot-host H --robot-ports RTDE,SCRIPT,DASHBOARD: the flags
// reach the navigation step; nobody listening is exit 1 with one line naming host:port; no robot calibration
// is exit 1 saying which step to run; malformed ports are usage errors (exit 2).
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <nlohmann/json.hpp>

#include "cli_runner.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

// A loopback port that was free a moment ago and has no listener now.
int closedPort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = 0;
  EXPECT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  socklen_t len = sizeof a;
  EXPECT_EQ(::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len), 0);
  ::close(fd);
  return ntohs(a.sin_port);
}

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
