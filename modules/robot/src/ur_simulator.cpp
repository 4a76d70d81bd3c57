#include "mrsns/robot/ur_simulator.h"

#include <asio.hpp>
#include <atomic>
#include <chrono>
#include <deque>
#include <list>
#include <thread>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/robot/primary_protocol.h"
#include "mrsns/robot/urscript.h"
#include "ur_sim_controller.h"

namespace mrsns::robot {
namespace {

enum class Kind { Rtde, Dashboard, Secondary, Realtime };

const char* kindName(Kind k) {
  switch (k) {
    case Kind::Rtde: return "RTDE";
    case Kind::Dashboard: return "dashboard";
    case Kind::Secondary: return "secondary";
    case Kind::Realtime: return "real-time";
  }
  return "?";
}

using Bytes = std::shared_ptr<const std::vector<std::uint8_t>>;
constexpr std::size_t kMaxQueued = 256;  // a client this far behind loses data packages, never memory

primary::RobotState robotState(const detail::SimSnapshot& s, const SimulatedArm& arm) {
  primary::RobotState st;
  primary::RobotModeData m;
  m.timestamp = static_cast<std::uint64_t>(s.arm.time_s * 1e6);
  m.real_robot_enabled = true;
  m.robot_power_on = s.mode != UrRobotMode::PowerOff;
  m.emergency_stopped = s.arm.safety == SafetyMode::EmergencyStop;
  m.protective_stopped = s.arm.safety == SafetyMode::ProtectiveStop;
  m.program_running = s.program_running;
  m.robot_mode = static_cast<std::int8_t>(s.mode);
  m.target_speed_fraction = m.speed_scaling = m.target_speed_fraction_limit = 1.0;
  st.robot_mode = m;
  primary::JointData j;
  for (int i = 0; i < 6; ++i) {
    j.q_actual[i] = j.q_target[i] = s.arm.q[i];
    j.qd_actual[i] = s.arm.qd[i];
    j.motor_temperature[i] = j.micro_temperature[i] = 30.f;
    j.voltage[i] = 48.f;
    j.joint_mode[i] = 253;  // JOINT_RUNNING_MODE
  }
  st.joints = j;
  primary::CartesianInfo c;
  c.tcp_pose = urscript::toUrPose(s.arm.base_T_flange);
  st.cartesian = c;
  primary::KinematicsInfo k;
  k.checksum.fill(0xFFFFFFFFu);
  const auto& dh = arm.options().dh;
  for (int i = 0; i < 6; ++i) {
    k.dh_a[i] = dh.a[i] / 1000.0;
    k.dh_d[i] = dh.d[i] / 1000.0;
    k.dh_alpha[i] = dh.alpha[i];
  }
  st.kinematics = k;
  return st;
}

}  // namespace

struct UrSimulator::Impl {
  struct Conn : std::enable_shared_from_this<Conn> {
    Conn(Impl& o, asio::ip::tcp::socket s, Kind k, int conn_id) : owner(o), socket(std::move(s)), kind(k), id(conn_id) {
      if (kind == Kind::Rtde) rtde = std::make_unique<detail::RtdeSession>(owner.controller, id);
    }
    Impl& owner;
    asio::ip::tcp::socket socket;
    Kind kind;
    int id;
    std::array<std::uint8_t, 4096> buffer{};
    rtde::PackageFramer framer;
    std::string lines;
    std::mutex session_mutex;  // guards rtde (io thread handles packages, stepping thread sends data)
    std::unique_ptr<detail::RtdeSession> rtde;
    std::mutex queue_mutex;
    std::deque<Bytes> queue;
    bool writing = false;
    bool closed = false;
    bool close_after_write = false;

    void start() {
      if (kind == Kind::Dashboard) send(std::string(dashboard::kWelcome) + "\n");
      if (kind == Kind::Secondary) {
        primary::VersionMessage v;
        v.header.source = -2;
        v.project_name = "URControl";
        v.major = static_cast<std::uint8_t>(owner.options.version.major);
        v.minor = static_cast<std::uint8_t>(owner.options.version.minor);
        v.bugfix = static_cast<std::int32_t>(owner.options.version.bugfix);
        v.build = static_cast<std::int32_t>(owner.options.version.build);
        v.build_date = "MR-SNS UR simulator";
        send(primary::encodeVersionMessage(v));
      }
      read();
    }

    void read() {
      auto self = shared_from_this();
      socket.async_read_some(asio::buffer(buffer), [self](const asio::error_code& ec, std::size_t n) {
        if (ec) {
          self->close();
          return;
        }
        self->consume(n);
        if (!self->isClosed()) self->read();
      });
    }

    void consume(std::size_t n) {
      if (kind == Kind::Rtde) {
        try {
          framer.push(std::span<const std::uint8_t>(buffer.data(), n));
          while (auto p = framer.next()) {
            std::vector<std::uint8_t> reply;
            {
              std::lock_guard lock(session_mutex);
              reply = rtde->handle(*p);
            }
            if (p->type == rtde::PackageType::DataPackage) owner.stats_inputs.fetch_add(1);
            if (!reply.empty()) send(std::move(reply));
          }
        } catch (const Error& e) {
          owner.stats_protocol_errors.fetch_add(1);
          logger()->warn("UR simulator: RTDE client {}: closing: {}", id, e.what());
          close();
        }
        return;
      }
      lines.append(reinterpret_cast<const char*>(buffer.data()), n);
      for (auto nl = lines.find('\n'); nl != std::string::npos; nl = lines.find('\n')) {
        const std::string line = lines.substr(0, nl);
        lines.erase(0, nl + 1);
        handleLine(line);
      }
      if (lines.size() > 65536) {
        owner.stats_protocol_errors.fetch_add(1);
        close();
      }
    }

    void handleLine(const std::string& raw) {
      std::string_view line(raw);
      while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.remove_suffix(1);
      while (!line.empty() && (line.front() == ' ' || line.front() == '\t')) line.remove_prefix(1);
      if (kind == Kind::Dashboard) {
        owner.stats_dashboard.fetch_add(1);
        bool quit = false;
        send(owner.controller.dashboard(line, quit) + "\n");
        if (quit) {
          std::lock_guard lock(queue_mutex);
          close_after_write = true;
        }
        return;
      }
      // Script interfaces: a program wrapper (def/end), blank lines and comments carry no command.
      if (line.empty() || line.starts_with('#') || line.starts_with("def ") || line == "end") return;
      std::string error;
      owner.stats_script.fetch_add(1);
      if (!owner.controller.script(line, error)) {
        owner.stats_script_rejected.fetch_add(1);
        logger()->debug("UR simulator: {} script line refused: {}", kindName(kind), error);
      }
    }

    void send(std::string text) { send(std::vector<std::uint8_t>(text.begin(), text.end())); }
    void send(std::vector<std::uint8_t> bytes) {
      send(std::make_shared<const std::vector<std::uint8_t>>(std::move(bytes)));
    }
    // Any thread.
    void send(const Bytes& bytes) {
      {
        std::lock_guard lock(queue_mutex);
        if (closed || queue.size() >= kMaxQueued) return;
        queue.push_back(bytes);
        if (writing) return;
        writing = true;
      }
      asio::post(socket.get_executor(), [self = shared_from_this()] { self->writeNext(); });
    }

    void writeNext() {
      Bytes bytes;
      {
        std::lock_guard lock(queue_mutex);
        if (closed || queue.empty()) {
          writing = false;
          if (close_after_write && !closed)
            asio::post(socket.get_executor(), [self = shared_from_this()] { self->close(); });
          return;
        }
        bytes = queue.front();
        queue.pop_front();
      }
      auto self = shared_from_this();
      asio::async_write(socket, asio::buffer(*bytes), [self, bytes](const asio::error_code& ec, std::size_t) {
        if (ec) {
          self->close();
          return;
        }
        self->writeNext();
      });
    }

    bool isClosed() {
      std::lock_guard lock(queue_mutex);
      return closed;
    }

    // I/O thread.
    void close() {
      {
        std::lock_guard lock(queue_mutex);
        if (closed) return;
        closed = true;
        queue.clear();
      }
      asio::error_code ignored;
      socket.shutdown(asio::ip::tcp::socket::shutdown_both, ignored);
      socket.close(ignored);
    }
  };

  explicit Impl(const UrSimulatorOptions& o) : options(o), controller(o) {}

  UrSimulatorOptions options;
  detail::SimController controller;
  asio::io_context io;
  std::vector<std::unique_ptr<asio::ip::tcp::acceptor>> acceptors;  // rtde, dashboard, secondary, realtime
  std::array<std::uint16_t, 4> ports{};
  std::mutex conns_mutex;
  std::list<std::shared_ptr<Conn>> conns;
  int next_id = 1;
  std::thread io_thread, step_thread;
  std::atomic<bool> running{false};
  std::atomic<std::uint64_t> stats_cycles{0}, stats_sent{0}, stats_inputs{0}, stats_script{0}, stats_script_rejected{0},
      stats_dashboard{0}, stats_clients{0}, stats_protocol_errors{0};

  void listen(Kind kind, std::uint16_t port, const asio::ip::address& address) {
    auto acceptor = std::make_unique<asio::ip::tcp::acceptor>(io);
    asio::error_code ec;
    const asio::ip::tcp::endpoint endpoint(address, port);
    acceptor->open(endpoint.protocol(), ec);
    if (!ec) acceptor->set_option(asio::ip::tcp::acceptor::reuse_address(true), ec);
    if (!ec) acceptor->bind(endpoint, ec);
    if (!ec) acceptor->listen(asio::socket_base::max_listen_connections, ec);
    if (ec) {
      throw NetworkError("UR simulator: cannot listen for " + std::string(kindName(kind)) + " clients on " +
                         address.to_string() + ":" + std::to_string(port) + ": " + ec.message() +
                         " (is another simulator or a UR controller bridge running? use other ports)");
    }
    ports[static_cast<std::size_t>(kind)] = acceptor->local_endpoint().port();
    acceptors.push_back(std::move(acceptor));
    accept(kind, *acceptors.back());
  }

  void accept(Kind kind, asio::ip::tcp::acceptor& acceptor) {
    acceptor.async_accept([this, kind, &acceptor](const asio::error_code& ec, asio::ip::tcp::socket socket) {
      if (ec) {
        if (ec == asio::error::operation_aborted || !acceptor.is_open()) return;  // stopped
        // A client that resets before its connection is taken (or a process
        // out of descriptors) fails one accept: keep listening, after a
        // pause so a persistent error cannot spin the I/O thread.
        auto pause = std::make_shared<asio::steady_timer>(acceptor.get_executor(), std::chrono::milliseconds(20));
        pause->async_wait([this, kind, &acceptor, pause](const asio::error_code& wait_ec) {
          if (!wait_ec && acceptor.is_open()) accept(kind, acceptor);
        });
        return;
      }
      asio::error_code ignored;
      socket.set_option(asio::ip::tcp::no_delay(true), ignored);
      std::shared_ptr<Conn> conn;
      {
        std::lock_guard lock(conns_mutex);
        std::erase_if(conns, [](const auto& c) { return c->isClosed(); });
        conn = std::make_shared<Conn>(*this, std::move(socket), kind, next_id++);
        conns.push_back(conn);
      }
      stats_clients.fetch_add(1);
      conn->start();
      accept(kind, acceptor);
    });
  }

  std::vector<std::shared_ptr<Conn>> snapshotConns() {
    std::lock_guard lock(conns_mutex);
    return {conns.begin(), conns.end()};
  }

  void stepLoop() {
    using Clock = std::chrono::steady_clock;
    const double period = controller.arm().controlPeriodS();
    const auto dt = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(period));
    const auto primary_every = std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::llround(0.1 / period)));
    auto next = Clock::now();
    while (running.load()) {
      next += dt;
      controller.step();
      stats_cycles.fetch_add(1);
      const auto snap = controller.snapshot();
      if (snap.link_up) {
        Bytes primary_state;
        for (const auto& c : snapshotConns()) {
          if (c->kind == Kind::Rtde) {
            std::vector<std::uint8_t> data;
            {
              std::lock_guard lock(c->session_mutex);
              if (c->rtde->dataDue(snap.arm.cycle)) data = c->rtde->dataPackage(snap);
            }
            if (!data.empty()) {
              c->send(std::move(data));
              stats_sent.fetch_add(1);
            }
          } else if (c->kind == Kind::Secondary && snap.arm.cycle % primary_every == 0) {
            if (!primary_state) {
              primary_state = std::make_shared<const std::vector<std::uint8_t>>(
                  primary::encodeRobotState(robotState(snap, controller.arm())));
            }
            c->send(primary_state);
          }
        }
      }
      std::this_thread::sleep_until(next);
      // After a long stall (debugger, overloaded machine) resume at the current time, no burst of catch-up cycles.
      if (Clock::now() - next > 20 * dt) next = Clock::now();
    }
  }

  void closeAll() {
    for (const auto& c : snapshotConns()) asio::post(io, [c] { c->close(); });
  }
};

UrSimulator::UrSimulator(const UrSimulatorOptions& options) : impl_(std::make_shared<Impl>(options)) {
  asio::error_code ec;
  const auto address = asio::ip::make_address(options.host, ec);
  if (ec) {
    throw InvalidArgumentError("UR simulator: host '" + options.host +
                               "' is not an IP address (use 127.0.0.1, the default, to stay on this machine)");
  }
  impl_->listen(Kind::Rtde, options.rtde_port, address);
  impl_->listen(Kind::Dashboard, options.dashboard_port, address);
  impl_->listen(Kind::Secondary, options.secondary_port, address);
  impl_->listen(Kind::Realtime, options.realtime_port, address);
  impl_->running = true;
  impl_->io_thread = std::thread([impl = impl_.get()] {
    auto guard = asio::make_work_guard(impl->io);
    impl->io.run();
  });
  impl_->step_thread = std::thread([impl = impl_.get()] { impl->stepLoop(); });
  logger()->info("UR simulator on {}: RTDE {}, dashboard {}, secondary {}, real-time {}", options.host, rtdePort(),
                 dashboardPort(), secondaryPort(), realtimePort());
}

UrSimulator::~UrSimulator() {
  stop();
}

void UrSimulator::stop() {
  if (!impl_->running.exchange(false)) return;
  if (impl_->step_thread.joinable()) impl_->step_thread.join();
  asio::post(impl_->io, [impl = impl_.get()] {
    for (auto& a : impl->acceptors) {
      asio::error_code ignored;
      a->close(ignored);
    }
    for (const auto& c : impl->snapshotConns()) c->close();
    impl->io.stop();
  });
  if (impl_->io_thread.joinable()) impl_->io_thread.join();
  std::lock_guard lock(impl_->conns_mutex);
  impl_->conns.clear();
}

std::uint16_t UrSimulator::rtdePort() const {
  return impl_->ports[0];
}
std::uint16_t UrSimulator::dashboardPort() const {
  return impl_->ports[1];
}
std::uint16_t UrSimulator::secondaryPort() const {
  return impl_->ports[2];
}
std::uint16_t UrSimulator::realtimePort() const {
  return impl_->ports[3];
}
std::string UrSimulator::host() const {
  return impl_->options.host;
}

SimulatedArm& UrSimulator::arm() {
  return impl_->controller.arm();
}
ArmState UrSimulator::armState() const {
  return impl_->controller.snapshot().arm;
}
UrRobotMode UrSimulator::robotMode() const {
  return impl_->controller.snapshot().mode;
}
UrSafetyMode UrSimulator::safetyMode() const {
  return impl_->controller.snapshot().safety;
}

UrSimulatorStats UrSimulator::stats() const {
  UrSimulatorStats s;
  s.cycles = impl_->stats_cycles.load();
  s.rtde_packages_sent = impl_->stats_sent.load();
  s.rtde_inputs_received = impl_->stats_inputs.load();
  s.script_commands = impl_->stats_script.load();
  s.script_rejected = impl_->stats_script_rejected.load();
  s.dashboard_commands = impl_->stats_dashboard.load();
  s.clients_connected = impl_->stats_clients.load();
  s.protocol_errors = impl_->stats_protocol_errors.load();
  return s;
}

void UrSimulator::dropClients() {
  impl_->closeAll();
}
void UrSimulator::setFrozen(bool frozen) {
  impl_->controller.setFrozen(frozen);
}

}  // namespace mrsns::robot
