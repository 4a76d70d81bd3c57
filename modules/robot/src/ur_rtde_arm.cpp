#include "mrsns/robot/ur_rtde_arm.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <thread>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/robot/dashboard_client.h"
#include "mrsns/robot/rtde_protocol.h"
#include "ur_tcp.h"

namespace mrsns::robot {
namespace {

using Clock = std::chrono::steady_clock;

const std::vector<std::string> kOutputs{"timestamp",        "actual_q",   "actual_qd",  "actual_TCP_pose",
                                        "actual_TCP_speed", "robot_mode", "safety_mode"};

template <typename T>
const T& get(const std::vector<rtde::Value>& values, std::size_t i) {
  return std::get<T>(values[i]);
}

}  // namespace

struct UrRtdeArm::Impl {
  UrRtdeArmOptions options;
  std::unique_ptr<detail::TcpConnection> rtde;
  std::unique_ptr<detail::TcpConnection> script;
  rtde::Recipe recipe;
  rtde::PackageFramer framer;
  std::string version;
  std::thread reader;
  std::atomic<bool> running{false};

  mutable std::mutex state_mutex;
  ArmState latest;
  Clock::time_point last_rx = Clock::now();
  bool rtde_ok = false;
  bool script_ok = false;
  bool latched = false;
  bool have_data = false;

  std::mutex script_mutex;
  std::atomic<std::uint64_t> packages{0}, sent{0}, refused{0};

  double period() const { return 1.0 / options.frequency_hz; }

  // Negotiation: the next package of the expected type; text messages from the controller are logged.
  rtde::Package await(rtde::PackageType expected) {
    const auto deadline = Clock::now() + std::chrono::duration<double>(options.connect_timeout_s);
    std::array<std::uint8_t, 4096> buffer{};
    for (;;) {
      while (auto p = framer.next()) {
        if (p->type == rtde::PackageType::TextMessage) {
          const auto m = rtde::decodeTextMessage(*p);
          logger()->warn("UR controller (RTDE) says [{}]: {}", m.source, m.message);
          if (m.level == rtde::MessageLevel::Error || m.level == rtde::MessageLevel::Exception) {
            throw FormatError("UR RTDE interface at " + rtde->peer() + " refused the setup: " + m.message);
          }
          continue;
        }
        if (p->type == expected) return *p;
        // Data of an earlier session may still arrive before the reply; anything else is out of step.
        if (p->type != rtde::PackageType::DataPackage) {
          throw FormatError(std::string("UR RTDE interface: expected ") + rtde::toString(expected) + ", received " +
                            rtde::toString(p->type));
        }
      }
      const double left = std::chrono::duration<double>(deadline - Clock::now()).count();
      if (left <= 0) {
        throw NetworkError("UR RTDE interface at " + rtde->peer() + ": no " + rtde::toString(expected) +
                           " reply within " + std::to_string(options.connect_timeout_s) + " s");
      }
      const auto n = rtde->readSome(buffer, left);
      framer.push(std::span<const std::uint8_t>(buffer.data(), n));
    }
  }

  void negotiate() {
    rtde->write(rtde::encodeRequestProtocolVersion(), options.connect_timeout_s);
    if (!rtde::decodeAccepted(await(rtde::PackageType::RequestProtocolVersion),
                              rtde::PackageType::RequestProtocolVersion)) {
      throw UnsupportedError("UR RTDE interface at " + rtde->peer() +
                             " refused protocol version 2 (controller older than CB3 3.3 / PolyScope 5?)");
    }
    rtde->write(rtde::encodeGetUrControlVersion(), options.connect_timeout_s);
    const auto v = rtde::decodeUrControlVersion(await(rtde::PackageType::GetUrControlVersion));
    version = std::to_string(v.major) + "." + std::to_string(v.minor) + "." + std::to_string(v.bugfix) + "." +
              std::to_string(v.build);
    rtde->write(rtde::encodeSetupOutputs(options.frequency_hz, kOutputs), options.connect_timeout_s);
    recipe = rtde::recipeFromReply(
        kOutputs, rtde::decodeSetupReply(await(rtde::PackageType::SetupOutputs), rtde::PackageType::SetupOutputs));
    rtde->write(rtde::encodeStart(), options.connect_timeout_s);
    if (!rtde::decodeAccepted(await(rtde::PackageType::Start), rtde::PackageType::Start)) {
      throw FormatError("UR RTDE interface at " + rtde->peer() + " refused to start the output stream");
    }
  }

  void update(const std::vector<rtde::Value>& v) {
    ArmState s;
    s.time_s = get<double>(v, 0);
    s.cycle = static_cast<std::uint64_t>(std::max(0.0, std::round(s.time_s / period())));
    const auto& q = get<std::array<double, 6>>(v, 1);
    const auto& qd = get<std::array<double, 6>>(v, 2);
    s.q = Joints(q.data());
    s.qd = Joints(qd.data());
    s.base_T_flange = urscript::fromUrPose(get<std::array<double, 6>>(v, 3));
    const auto& speed = get<std::array<double, 6>>(v, 4);
    s.flange_twist << speed[0] * 1000, speed[1] * 1000, speed[2] * 1000, speed[3], speed[4], speed[5];
    const auto mode = urRobotModeFromInt(get<std::int32_t>(v, 5));
    const auto safety = urSafetyModeFromInt(get<std::int32_t>(v, 6));
    s.mode = mode ? toRobotMode(*mode) : RobotMode::Disconnected;
    s.safety = safety ? toSafetyMode(*safety) : SafetyMode::Fault;
    s.connected = true;
    std::lock_guard lock(state_mutex);
    latest = s;
    last_rx = Clock::now();
    have_data = true;
  }

  void readLoop() {
    std::array<std::uint8_t, 8192> buffer{};
    while (running.load()) {
      try {
        const auto n = rtde->readSome(buffer, 0.05);
        framer.push(std::span<const std::uint8_t>(buffer.data(), n));
        while (auto p = framer.next()) {
          if (p->type == rtde::PackageType::DataPackage) {
            update(rtde::decodeDataPackage(*p, recipe));
            packages.fetch_add(1);
          } else if (p->type == rtde::PackageType::TextMessage) {
            const auto m = rtde::decodeTextMessage(*p);
            logger()->warn("UR controller (RTDE) says [{}]: {}", m.source, m.message);
          }
        }
      } catch (const Error& e) {
        logger()->error("UR RTDE connection lost: {}", e.what());
        std::lock_guard lock(state_mutex);
        rtde_ok = false;
        return;
      }
    }
  }

  bool connectedNow() const {
    if (!have_data) return false;  // no state yet: nothing the loop may act on
    const double age = std::chrono::duration<double>(Clock::now() - last_rx).count();
    return rtde_ok && script_ok && age <= options.stale_after_periods * period();
  }

  bool send(const std::string& line, bool motion) {
    {
      std::lock_guard lock(state_mutex);
      const bool safe = latest.safety == SafetyMode::Normal || latest.safety == SafetyMode::Reduced;
      if (!connectedNow() || (motion && (latched || !safe))) {
        refused.fetch_add(1);
        return false;
      }
    }
    std::lock_guard lock(script_mutex);
    try {
      script->write(line + "\n", std::max(0.05, 5 * period()));
    } catch (const Error& e) {
      logger()->error("UR script interface lost: {}", e.what());
      std::lock_guard state_lock(state_mutex);
      script_ok = false;
      refused.fetch_add(1);
      return false;
    }
    sent.fetch_add(1);
    return true;
  }

  void shutdown() {
    if (running.exchange(false) && reader.joinable()) reader.join();
    if (reader.joinable()) reader.join();
    std::lock_guard lock(script_mutex);
    if (rtde) rtde->close();
    if (script) script->close();
    std::lock_guard state_lock(state_mutex);
    rtde_ok = script_ok = false;
  }
};

UrRtdeArm::UrRtdeArm(const UrRtdeArmOptions& options) : impl_(std::make_unique<Impl>()) {
  if (!(options.frequency_hz > 0 && options.frequency_hz <= 500)) {
    throw InvalidArgumentError("UrRtdeArm: frequency_hz " + std::to_string(options.frequency_hz) +
                               " must be in (0, 500]: 500 for e-series, 125 for CB3");
  }
  if (!(options.stale_after_periods >= 1) || !(options.connect_timeout_s > 0)) {
    throw InvalidArgumentError("UrRtdeArm: stale_after_periods must be >= 1 and connect_timeout_s > 0");
  }
  impl_->options = options;
  impl_->rtde = std::make_unique<detail::TcpConnection>(options.host, options.rtde_port, options.connect_timeout_s,
                                                        "UR RTDE interface");
  impl_->negotiate();
  impl_->script = std::make_unique<detail::TcpConnection>(options.host, options.script_port, options.connect_timeout_s,
                                                          "UR script interface");
  {
    std::lock_guard lock(impl_->state_mutex);
    impl_->rtde_ok = impl_->script_ok = true;
  }
  impl_->running = true;
  impl_->reader = std::thread([impl = impl_.get()] { impl->readLoop(); });
  logger()->info("UR controller {} at {} (RTDE {} Hz)", impl_->version, options.host, options.frequency_hz);
}

UrRtdeArm::~UrRtdeArm() {
  impl_->shutdown();
}

ArmState UrRtdeArm::state() const {
  std::lock_guard lock(impl_->state_mutex);
  ArmState s = impl_->latest;
  s.connected = impl_->connectedNow();
  if (!s.connected) s.mode = RobotMode::Disconnected;
  return s;
}

bool UrRtdeArm::servoJ(const Joints& q_target) {
  if (!q_target.allFinite()) {
    impl_->refused.fetch_add(1);
    return false;
  }
  auto servo = impl_->options.servo;
  servo.time_s = impl_->period();
  return impl_->send(urscript::servoj(q_target, servo), true);
}

bool UrRtdeArm::speedL(const Twist& twist, double acceleration_mm_s2) {
  if (!twist.allFinite() || !(acceleration_mm_s2 > 0) || !std::isfinite(acceleration_mm_s2)) {
    impl_->refused.fetch_add(1);
    return false;
  }
  return impl_->send(urscript::speedl(twist, acceleration_mm_s2, impl_->options.speedl_time_s), true);
}

bool UrRtdeArm::stopJ(double deceleration_rad_s2) {
  if (!(deceleration_rad_s2 > 0) || !std::isfinite(deceleration_rad_s2)) {
    impl_->refused.fetch_add(1);
    return false;
  }
  return impl_->send(urscript::stopj(deceleration_rad_s2), false);
}

bool UrRtdeArm::protectiveStop() {
  {
    std::lock_guard lock(impl_->state_mutex);
    impl_->latched = true;
  }
  return impl_->send(urscript::protectiveStop(), false);
}

bool UrRtdeArm::unlockProtectiveStop() {
  try {
    DashboardClient dashboard({impl_->options.host, impl_->options.dashboard_port, impl_->options.connect_timeout_s});
    if (!dashboard.command(dashboard::Command::UnlockProtectiveStop).accepted) return false;
    (void)dashboard.command(dashboard::Command::CloseSafetyPopup);
  } catch (const Error& e) {
    logger()->warn("UR dashboard: unlock protective stop failed: {}", e.what());
    return false;
  }
  std::lock_guard lock(impl_->state_mutex);
  impl_->latched = false;
  return true;
}

double UrRtdeArm::controlPeriodS() const {
  return impl_->period();
}

UrRtdeArmStats UrRtdeArm::stats() const {
  UrRtdeArmStats s;
  s.packages = impl_->packages.load();
  s.commands_sent = impl_->sent.load();
  s.commands_refused = impl_->refused.load();
  std::lock_guard lock(impl_->state_mutex);
  s.last_package_age_s = std::chrono::duration<double>(Clock::now() - impl_->last_rx).count();
  return s;
}

std::string UrRtdeArm::controllerVersion() const {
  return impl_->version;
}

void UrRtdeArm::disconnect() {
  impl_->shutdown();
}

}  // namespace mrsns::robot
