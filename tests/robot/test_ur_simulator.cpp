// The UR simulator over real sockets on 127.0.0.1 with ephemeral ports: where it binds, RTDE negotiation and
// data rates, dashboard replies on the wire, script lines moving the arm, the secondary interface's stream.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <fstream>
#include <thread>

#include "mrsns/core/error.h"
#include "mrsns/robot/dashboard_client.h"
#include "mrsns/robot/primary_protocol.h"
#include "mrsns/robot/rtde_protocol.h"
#include "mrsns/robot/ur_simulator.h"
#include "mrsns/robot/urscript.h"
#include "ur_simulator_ports.h"

using namespace mrsns::robot;
using Bytes = std::vector<std::uint8_t>;

namespace {

using ::mrsns::test::ephemeralUrSimulator;

// A plain blocking socket with a receive timeout: a client independent of the code under test.
class RawClient {
 public:
  explicit RawClient(std::uint16_t port) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    timeval tv{2, 0};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    if (::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) throw std::runtime_error("connect failed");
  }
  ~RawClient() { ::close(fd_); }
  void send(const Bytes& b) {
    ASSERT_EQ(::send(fd_, b.data(), b.size(), MSG_NOSIGNAL), static_cast<ssize_t>(b.size()));
  }
  void send(const std::string& s) { send(Bytes(s.begin(), s.end())); }
  Bytes receiveExactly(std::size_t n) {
    Bytes out(n);
    std::size_t got = 0;
    while (got < n) {
      const auto r = ::recv(fd_, out.data() + got, n - got, 0);
      if (r <= 0) throw std::runtime_error("receive failed or timed out");
      got += static_cast<std::size_t>(r);
    }
    return out;
  }
  rtde::Package rtdePackage() {
    auto header = receiveExactly(3);
    const std::size_t size = (std::size_t{header[0]} << 8) | header[1];
    auto body = receiveExactly(size - 3);
    header.insert(header.end(), body.begin(), body.end());
    return rtde::decodePackage(header);
  }
  Bytes primaryMessage() {
    auto header = receiveExactly(5);
    const auto size = primary::messageSize(header);
    auto body = receiveExactly(size - 5);
    header.insert(header.end(), body.begin(), body.end());
    return header;
  }

 private:
  int fd_ = -1;
};

// The listening sockets of this process's port as the kernel reports them: "0100007F" is 127.0.0.1.
std::vector<std::string> listeningAddresses(std::uint16_t port) {
  std::ifstream in("/proc/net/tcp");
  std::vector<std::string> out;
  std::string line;
  char want[8];
  std::snprintf(want, sizeof want, "%04X", port);
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string sl, local, remote, state;
    s >> sl >> local >> remote >> state;
    if (state == "0A" && local.size() > 9 && local.substr(9) == want) out.push_back(local.substr(0, 8));
  }
  return out;
}

// An accept that fails (here: the process is out of file descriptors while a
// client connects) must not end the listening: once descriptors are free
// again, the next client is served.
TEST(UrSimulator, KeepsAcceptingAfterAFailedAccept) {
  UrSimulator sim(ephemeralUrSimulator());
  const std::uint16_t port = sim.dashboardPort();
  rlimit original{};
  ASSERT_EQ(::getrlimit(RLIMIT_NOFILE, &original), 0);
  // Fill the descriptor table under a lowered limit, then free one slot: the
  // client's socket takes it and the simulator's accept finds none.
  rlimit lowered = original;
  lowered.rlim_cur = std::min<rlim_t>(original.rlim_cur, 256);
  ASSERT_EQ(::setrlimit(RLIMIT_NOFILE, &lowered), 0);
  std::vector<int> filler;
  for (int fd = ::dup(0); fd >= 0; fd = ::dup(0)) filler.push_back(fd);
  ASSERT_FALSE(filler.empty());
  ::close(filler.back());
  filler.pop_back();
  const int client = ::socket(AF_INET, SOCK_STREAM, 0);
  ASSERT_GE(client, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  EXPECT_EQ(::connect(client, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);  // the kernel completes it
  std::this_thread::sleep_for(std::chrono::milliseconds(100));                 // the accept fails meanwhile
  ::close(client);
  for (const int fd : filler) ::close(fd);
  ASSERT_EQ(::setrlimit(RLIMIT_NOFILE, &original), 0);
  DashboardClient dashboard({"127.0.0.1", port, 2.0});
  EXPECT_EQ(dashboard.robotMode(), UrRobotMode::Running);
}

}  // namespace

TEST(UrSimulator, BindsLoopbackOnly) {
  UrSimulator sim(ephemeralUrSimulator());
  for (auto port : {sim.rtdePort(), sim.dashboardPort(), sim.secondaryPort(), sim.realtimePort()}) {
    EXPECT_NE(port, 0);
    EXPECT_EQ(listeningAddresses(port), std::vector<std::string>{"0100007F"}) << "port " << port;
  }
  EXPECT_EQ(sim.host(), "127.0.0.1");
  // A port already taken and a host that is not an address are clear errors.
  auto taken = ephemeralUrSimulator();
  taken.dashboard_port = sim.dashboardPort();
  EXPECT_THROW(UrSimulator{taken}, mrsns::NetworkError);
  auto bad = ephemeralUrSimulator();
  bad.host = "localhost:80";
  EXPECT_THROW(UrSimulator{bad}, mrsns::InvalidArgumentError);
}

TEST(UrSimulator, RtdeNegotiationAndDataRate) {
  UrSimulator sim(ephemeralUrSimulator());
  RawClient c(sim.rtdePort());
  c.send(rtde::encodeRequestProtocolVersion(1));
  EXPECT_FALSE(rtde::decodeAccepted(c.rtdePackage(), rtde::PackageType::RequestProtocolVersion));
  c.send(rtde::encodeRequestProtocolVersion(2));
  EXPECT_TRUE(rtde::decodeAccepted(c.rtdePackage(), rtde::PackageType::RequestProtocolVersion));
  c.send(rtde::encodeGetUrControlVersion());
  EXPECT_EQ(rtde::decodeUrControlVersion(c.rtdePackage()).major, 5u);
  // An unknown variable: NOT_FOUND and recipe id 0.
  c.send(rtde::encodeSetupOutputs(125, {"timestamp", "actual_qq"}));
  const auto refused = rtde::decodeSetupReply(c.rtdePackage(), rtde::PackageType::SetupOutputs);
  EXPECT_EQ(refused.recipe_id, 0);
  EXPECT_EQ(refused.types, (std::vector<std::string>{"DOUBLE", "NOT_FOUND"}));
  const std::vector<std::string> names{"timestamp", "actual_q", "robot_mode", "safety_mode", "runtime_state"};
  c.send(rtde::encodeSetupOutputs(125, names));
  const auto recipe =
      rtde::recipeFromReply(names, rtde::decodeSetupReply(c.rtdePackage(), rtde::PackageType::SetupOutputs));
  c.send(rtde::encodeStart());
  EXPECT_TRUE(rtde::decodeAccepted(c.rtdePackage(), rtde::PackageType::Start));
  // 125 Hz on a 500 Hz controller: every 4th cycle, so consecutive controller timestamps differ by exactly 8 ms.
  std::vector<double> stamps;
  for (int i = 0; i < 10; ++i) {
    auto p = c.rtdePackage();
    if (p.type != rtde::PackageType::DataPackage) continue;
    const auto v = rtde::decodeDataPackage(p, recipe);
    stamps.push_back(std::get<double>(v[0]));
    EXPECT_EQ(std::get<std::int32_t>(v[2]), static_cast<int>(UrRobotMode::Running));
    EXPECT_EQ(std::get<std::int32_t>(v[3]), static_cast<int>(UrSafetyMode::Normal));
  }
  ASSERT_GE(stamps.size(), 5u);
  for (std::size_t i = 1; i < stamps.size(); ++i) EXPECT_NEAR(stamps[i] - stamps[i - 1], 0.008, 1e-9);
  c.send(rtde::encodePause());
  // Data packages already queued may precede the reply.
  for (;;) {
    auto p = c.rtdePackage();
    if (p.type == rtde::PackageType::Pause) {
      EXPECT_TRUE(rtde::decodeAccepted(p, rtde::PackageType::Pause));
      break;
    }
  }
}

// ur_rtde's RTDEReceiveInterface asks for its 57 default outputs at 500 Hz with a trailing comma after the last
// name (seen on the wire from ur_rtde 1.6.5): the controller sets the recipe up and streams it.
TEST(UrSimulator, RtdeSetupWithTrailingCommaAsUrRtdeSendsIt) {
  UrSimulator sim(ephemeralUrSimulator());
  RawClient c(sim.rtdePort());
  c.send(rtde::encodeRequestProtocolVersion(2));
  ASSERT_TRUE(rtde::decodeAccepted(c.rtdePackage(), rtde::PackageType::RequestProtocolVersion));
  const std::string text = "timestamp,actual_q,robot_mode,output_int_register_12,output_double_register_19,";
  std::vector<std::uint8_t> payload(8, 0);
  const double frequency = 500.0;
  std::uint64_t bits = 0;
  std::memcpy(&bits, &frequency, sizeof bits);
  for (int i = 0; i < 8; ++i) payload[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(bits >> (56 - 8 * i));
  payload.insert(payload.end(), text.begin(), text.end());
  c.send(rtde::encodePackage(rtde::PackageType::SetupOutputs, payload));
  const auto reply = rtde::decodeSetupReply(c.rtdePackage(), rtde::PackageType::SetupOutputs);
  EXPECT_NE(reply.recipe_id, 0);
  EXPECT_EQ(reply.types, (std::vector<std::string>{"DOUBLE", "VECTOR6D", "INT32", "INT32", "DOUBLE"}));
  const std::vector<std::string> names{"timestamp", "actual_q", "robot_mode", "output_int_register_12",
                                       "output_double_register_19"};
  const auto recipe = rtde::recipeFromReply(names, reply);
  c.send(rtde::encodeStart());
  ASSERT_TRUE(rtde::decodeAccepted(c.rtdePackage(), rtde::PackageType::Start));
  const auto data = rtde::decodeDataPackage(c.rtdePackage(), recipe);
  EXPECT_EQ(std::get<std::int32_t>(data[2]), static_cast<int>(UrRobotMode::Running));
}

TEST(UrSimulator, RtdeInputsAreExclusivePerClient) {
  UrSimulator sim(ephemeralUrSimulator());
  RawClient a(sim.rtdePort()), b(sim.rtdePort());
  for (auto* c : {&a, &b}) {
    c->send(rtde::encodeRequestProtocolVersion(2));
    (void)c->rtdePackage();
  }
  a.send(rtde::encodeSetupInputs({"input_int_register_0", "input_double_register_1"}));
  const auto ra = rtde::decodeSetupReply(a.rtdePackage(), rtde::PackageType::SetupInputs);
  EXPECT_NE(ra.recipe_id, 0);
  EXPECT_EQ(ra.types, (std::vector<std::string>{"INT32", "DOUBLE"}));
  b.send(rtde::encodeSetupInputs({"input_int_register_0"}));
  EXPECT_EQ(rtde::decodeSetupReply(b.rtdePackage(), rtde::PackageType::SetupInputs).types,
            std::vector<std::string>{"IN_USE"});
  // An output variable is not an input.
  b.send(rtde::encodeSetupInputs({"actual_q"}));
  EXPECT_EQ(rtde::decodeSetupReply(b.rtdePackage(), rtde::PackageType::SetupInputs).types,
            std::vector<std::string>{"NOT_FOUND"});
}

TEST(UrSimulator, DashboardGoldenRepliesOnTheWire) {
  UrSimulator sim(ephemeralUrSimulator());
  RawClient c(sim.dashboardPort());
  auto line = [&c]() {
    std::string s;
    for (;;) {
      const auto b = c.receiveExactly(1)[0];
      if (b == '\n') return s;
      s += static_cast<char>(b);
    }
  };
  EXPECT_EQ(line(), "Connected: Universal Robots Dashboard Server");
  const std::vector<std::pair<std::string, std::string>> dialogue{
      {"robotmode", "Robotmode: RUNNING"},
      {"safetystatus", "Safetystatus: NORMAL"},
      {"power off", "Powering off"},
      {"robotmode", "Robotmode: POWER_OFF"},
      {"play", "Failed to execute: play"},
      {"brake release", "Failed to execute: brake release"},
      {"power on", "Powering on"},
      {"robotmode", "Robotmode: IDLE"},
      {"brake release", "Brake releasing"},
      {"robotmode", "Robotmode: RUNNING"},
      {"play", "Starting program"},
      {"running", "Program running: true"},
      {"stop", "Stopped"},
      {"running", "Program running: false"},
      {"unlock protective stop", "Cannot unlock protective stop, robot is not in protective stop"},
      {"close safety popup", "closing safety popup"},
      {"fly", "could not understand: 'fly'"},
      {"safetymode", "Safetymode: NORMAL"}};
  for (const auto& [command, reply] : dialogue) {
    c.send(command + "\n");
    EXPECT_EQ(line(), reply) << command;
  }
}

// What third-party clients ask of a PolyScope 5.6+ dashboard server (ur_rtde 1.6: isInRemoteControl and
// getSerialNumber parse "URSoftware major.minor.bugfix.build" and throw on three numbers; labs check remote
// control before starting RTDEControlInterface), replied as a real controller does.
TEST(UrSimulator, DashboardQueriesOfClientLibraries) {
  UrSimulatorOptions options = ephemeralUrSimulator();
  options.version = {5, 11, 2, 108};
  options.serial_number = "20235500042";
  UrSimulator sim(options);
  RawClient c(sim.dashboardPort());
  auto line = [&c]() {
    std::string s;
    for (;;) {
      const auto b = c.receiveExactly(1)[0];
      if (b == '\n') return s;
      s += static_cast<char>(b);
    }
  };
  EXPECT_EQ(line(), "Connected: Universal Robots Dashboard Server");
  const std::vector<std::pair<std::string, std::string>> dialogue{
      {"PolyscopeVersion", "URSoftware 5.11.2.108 (MR-SNS UR simulator)"},
      {"is in remote control", "true"},
      {"get robot model", "UR5"},
      {"get serial number", "20235500042"},
      {"get loaded program", "No program loaded"},
      {"programState", "STOPPED <unnamed>"},
      {"play", "Starting program"},
      {"programState", "PLAYING <unnamed>"},
      {"stop", "Stopped"},
      {"programState", "STOPPED <unnamed>"}};
  for (const auto& [command, reply] : dialogue) {
    c.send(command + "\n");
    EXPECT_EQ(line(), reply) << command;
  }
  // Our own client accepts the four-number version line.
  DashboardClient client({"127.0.0.1", sim.dashboardPort(), 2.0});
  EXPECT_EQ(client.polyscopeVersion(), "URSoftware 5.11.2.108 (MR-SNS UR simulator)");
}

TEST(UrSimulator, ScriptLinesMoveTheArmAndSecondaryStreamsState) {
  UrSimulator sim(ephemeralUrSimulator());
  RawClient secondary(sim.secondaryPort());
  const auto version = primary::decodeMessage(secondary.primaryMessage());
  EXPECT_EQ(std::get<primary::VersionMessage>(version.message).project_name, "URControl");

  const Joints q0 = sim.armState().q;
  Joints target = q0;
  target[0] += 0.1;
  target[5] -= 0.1;
  RawClient realtime(sim.realtimePort());
  realtime.send(urscript::servoj(target) + "\n");
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  while ((sim.armState().q - target).cwiseAbs().maxCoeff() > 1e-6 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_LT((sim.armState().q - target).cwiseAbs().maxCoeff(), 1e-6);
  // A malformed line is counted and ignored; the arm keeps its state.
  realtime.send(std::string("servoj([1,2,3])\n"));
  // The primary stream reports the new joints (10 Hz; read until one shows them).
  bool seen = false;
  for (int i = 0; i < 30 && !seen; ++i) {
    const auto d = primary::decodeMessage(secondary.primaryMessage());
    if (const auto* s = std::get_if<primary::RobotState>(&d.message)) {
      ASSERT_TRUE(s->joints && s->kinematics && s->robot_mode);
      EXPECT_NEAR(s->kinematics->dh_a[1], -0.425, 1e-12);
      seen = std::abs(s->joints->q_actual[0] - target[0]) < 1e-6;
    }
  }
  EXPECT_TRUE(seen);
  const auto deadline2 = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  while (sim.stats().script_rejected == 0 && std::chrono::steady_clock::now() < deadline2) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_EQ(sim.stats().script_rejected, 1u);
}

TEST(UrSimulator, DashboardClientAgainstSimulator) {
  UrSimulator sim(ephemeralUrSimulator());
  DashboardClient client({"127.0.0.1", sim.dashboardPort(), 2.0});
  EXPECT_EQ(client.robotMode(), UrRobotMode::Running);
  EXPECT_EQ(client.safetyMode(), UrSafetyMode::Normal);
  EXPECT_TRUE(client.command(dashboard::Command::PowerOff).accepted);
  EXPECT_EQ(client.robotMode(), UrRobotMode::PowerOff);
  EXPECT_FALSE(client.command(dashboard::Command::Play).accepted);
  // The RTDE port does not greet like the dashboard server: FormatError or a timeout, never a hang.
  EXPECT_THROW(DashboardClient({"127.0.0.1", sim.rtdePort(), 0.2}), mrsns::Error);
}
