#include "ur_sim_controller.h"

#include <cmath>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/robot/urscript.h"

namespace mrsns::robot::detail {
namespace {

using rtde::FieldType;
using rtde::Value;

std::array<double, 6> toArray(const Eigen::Matrix<double, 6, 1>& v, double scale_first3 = 1.0) {
  return {v[0] * scale_first3, v[1] * scale_first3, v[2] * scale_first3, v[3], v[4], v[5]};
}

// RTDE robot_status_bits: power on, program running, teach button, power button.
std::uint32_t robotStatusBits(const SimSnapshot& s) {
  std::uint32_t bits = 0;
  if (s.mode == UrRobotMode::Running || s.mode == UrRobotMode::Idle) bits |= 1u;
  if (s.program_running) bits |= 2u;
  return bits;
}

// RTDE safety_status_bits: 0 normal, 1 reduced, 2 protective, 3 recovery, 4 safeguard, 5 system e-stop,
// 6 robot e-stop, 7 e-stopped, 8 violation, 9 fault, 10 stopped due to safety.
std::uint32_t safetyStatusBits(UrSafetyMode m) {
  switch (m) {
    case UrSafetyMode::Normal: return 1u << 0;
    case UrSafetyMode::Reduced: return 1u << 1;
    case UrSafetyMode::ProtectiveStop: return (1u << 2) | (1u << 10);
    case UrSafetyMode::Recovery: return 1u << 3;
    case UrSafetyMode::SafeguardStop: return (1u << 4) | (1u << 10);
    case UrSafetyMode::SystemEmergencyStop: return (1u << 5) | (1u << 7) | (1u << 10);
    case UrSafetyMode::RobotEmergencyStop: return (1u << 6) | (1u << 7) | (1u << 10);
    case UrSafetyMode::Violation: return (1u << 8) | (1u << 10);
    case UrSafetyMode::Fault: return (1u << 9) | (1u << 10);
    default: return 1u << 10;
  }
}

}  // namespace

bool isRtdeInput(std::string_view name) {
  for (std::string_view prefix : {"input_", "speed_slider_", "standard_digital_output", "configurable_digital_output",
                                  "tool_digital_output", "standard_analog_output_", "external_force_torque"}) {
    if (name.starts_with(prefix)) return rtde::variableType(name).has_value();
  }
  return false;
}

SimController::SimController(const UrSimulatorOptions& options) : options_(options), arm_(options.arm) {
  powered_ = brakes_released_ = options.start_ready;
}

void SimController::step() {
  {
    std::lock_guard lock(mutex_);
    if (frozen_) return;
  }
  arm_.step();
  const auto s = arm_.state();
  std::lock_guard lock(mutex_);
  const bool protective = s.safety == SafetyMode::ProtectiveStop;
  if (protective && !was_protective_) protective_since_s_ = s.time_s;
  if (s.safety == SafetyMode::EmergencyStop) {
    // The e-stop powers the arm off; the operator powers on again from the dashboard.
    powered_ = brakes_released_ = program_running_ = false;
  }
  was_protective_ = protective;
}

void SimController::setFrozen(bool frozen) {
  std::lock_guard lock(mutex_);
  frozen_ = frozen;
}

SimSnapshot SimController::snapshot() const {
  SimSnapshot s;
  s.arm = arm_.state();
  std::lock_guard lock(mutex_);
  s.link_up = s.arm.connected && !frozen_;
  s.mode = !powered_ ? UrRobotMode::PowerOff : (brakes_released_ ? UrRobotMode::Running : UrRobotMode::Idle);
  s.safety = toUrSafetyMode(s.arm.safety);
  s.program_running = program_running_;
  s.arm.mode = toRobotMode(s.mode);
  return s;
}

bool SimController::readyToMove() const {
  return powered_ && brakes_released_ && !frozen_;
}

std::string SimController::dashboard(std::string_view line, bool& close) {
  using dashboard::Command;
  close = false;
  const auto command = dashboard::parseCommand(line);
  if (!command) return dashboard::notUnderstoodReply(line);
  const auto state = arm_.state();
  std::lock_guard lock(mutex_);
  switch (*command) {
    case Command::PowerOn:
      if (state.safety == SafetyMode::EmergencyStop) (void)arm_.resetEmergencyStop();
      powered_ = true;
      return dashboard::successReply(*command);
    case Command::PowerOff:
      (void)arm_.stopJ(options_.arm.stop_deceleration_rad_s2);
      powered_ = brakes_released_ = program_running_ = false;
      return dashboard::successReply(*command);
    case Command::BrakeRelease:
      if (!powered_) return dashboard::failureReply(*command);
      brakes_released_ = true;
      return dashboard::successReply(*command);
    case Command::Play:
      if (!readyToMove() || (state.safety != SafetyMode::Normal && state.safety != SafetyMode::Reduced)) {
        return dashboard::failureReply(*command);
      }
      program_running_ = true;
      return dashboard::successReply(*command);
    case Command::Stop:
    case Command::Pause:
      if (!program_running_) return dashboard::failureReply(*command);
      program_running_ = false;
      (void)arm_.stopJ(options_.arm.stop_deceleration_rad_s2);
      return dashboard::successReply(*command);
    case Command::RobotMode:
      return dashboard::robotModeReply(!powered_ ? UrRobotMode::PowerOff
                                                 : (brakes_released_ ? UrRobotMode::Running : UrRobotMode::Idle));
    case Command::SafetyMode: return dashboard::safetyModeReply(toUrSafetyMode(state.safety), false);
    case Command::SafetyStatus: return dashboard::safetyModeReply(toUrSafetyMode(state.safety), true);
    case Command::UnlockProtectiveStop:
      if (state.safety != SafetyMode::ProtectiveStop) return dashboard::failureReply(*command);
      if (state.time_s - protective_since_s_ < options_.unlock_delay_s || !arm_.unlockProtectiveStop()) {
        return dashboard::unlockTooEarlyReply();
      }
      return dashboard::successReply(*command);
    case Command::CloseSafetyPopup: return dashboard::successReply(*command);
    case Command::PolyscopeVersion:
      return dashboard::polyscopeVersionReply(options_.version.major, options_.version.minor, options_.version.bugfix,
                                              options_.version.build);
    case Command::Running: return dashboard::runningReply(program_running_);
    case Command::Quit: close = true; return dashboard::successReply(*command);
    // The simulator takes commands from the network whatever the pendant would say: always in remote control.
    case Command::IsInRemoteControl: return dashboard::remoteControlReply(true);
    case Command::GetRobotModel: return "UR5";
    case Command::GetSerialNumber: return options_.serial_number;
    case Command::ProgramState: return dashboard::programStateReply(program_running_);
    // Script lines run directly; no .urp program is ever loaded.
    case Command::GetLoadedProgram: return "No program loaded";
  }
  return dashboard::notUnderstoodReply(line);
}

bool SimController::script(std::string_view line, std::string& error) {
  urscript::Command c;
  try {
    c = urscript::parseLine(line);
  } catch (const FormatError& e) {
    error = e.what();
    return false;
  }
  {
    std::lock_guard lock(mutex_);
    if (frozen_) {
      error = "controller frozen";
      return false;
    }
    const bool motion = c.kind != urscript::CommandKind::StopJ && c.kind != urscript::CommandKind::StopL &&
                        c.kind != urscript::CommandKind::ProtectiveStop;
    if (motion && !readyToMove()) {
      error = "robot not ready (power on and release the brakes first)";
      return false;
    }
    if (motion) program_running_ = true;
  }
  bool ok = false;
  switch (c.kind) {
    case urscript::CommandKind::ServoJ:
    case urscript::CommandKind::MoveJ: ok = arm_.servoJ(c.q); break;
    case urscript::CommandKind::SpeedL: ok = arm_.speedL(c.twist, c.acceleration); break;
    case urscript::CommandKind::MoveL: {
      // Joint-space approach to the IK solution nearest the current joints (not a straight tool path).
      const auto q = arm_.kinematics().inverseNearest(c.pose, arm_.state().q, &arm_.options().limits);
      ok = q && arm_.servoJ(*q);
      break;
    }
    case urscript::CommandKind::StopJ: ok = arm_.stopJ(c.acceleration); break;
    case urscript::CommandKind::StopL: ok = arm_.stopJ(options_.arm.stop_deceleration_rad_s2); break;
    case urscript::CommandKind::ProtectiveStop: ok = arm_.protectiveStop(); break;
  }
  if (!ok) error = "refused by the arm (safety state, limits or speed)";
  return ok;
}

std::vector<std::string> SimController::claimInputs(const std::vector<std::string>& names, int session) {
  std::lock_guard lock(mutex_);
  std::vector<std::string> types;
  for (const auto& n : names) {
    if (!isRtdeInput(n)) {
      types.emplace_back("NOT_FOUND");
      continue;
    }
    const auto it = input_owner_.find(n);
    if (it != input_owner_.end() && it->second != session) {
      types.emplace_back("IN_USE");
      continue;
    }
    types.emplace_back(rtde::toString(*rtde::variableType(n)));
  }
  const bool all =
      std::none_of(types.begin(), types.end(), [](const std::string& t) { return t == "NOT_FOUND" || t == "IN_USE"; });
  if (all) {
    for (const auto& n : names) input_owner_[n] = session;
  }
  return types;
}

void SimController::releaseInputs(int session) {
  std::lock_guard lock(mutex_);
  std::erase_if(input_owner_, [session](const auto& kv) { return kv.second == session; });
}

void SimController::setInput(const std::string& name, const rtde::Value& value) {
  std::lock_guard lock(mutex_);
  inputs_[name] = value;
}

rtde::Value SimController::inputValue(const std::string& name, rtde::FieldType type) const {
  std::lock_guard lock(mutex_);
  const auto it = inputs_.find(name);
  return it != inputs_.end() && rtde::typeOf(it->second) == type ? it->second : rtde::zeroValue(type);
}

rtde::Value outputValue(const rtde::Field& f, const SimSnapshot& s, const SimController& controller) {
  const auto& n = f.name;
  const auto pose = urscript::toUrPose(s.arm.base_T_flange);
  if (n == "timestamp") return s.arm.time_s;
  if (n == "actual_q" || n == "target_q") return toArray(s.arm.q);
  if (n == "actual_qd" || n == "target_qd") return toArray(s.arm.qd);
  if (n == "actual_TCP_pose" || n == "target_TCP_pose") return pose;
  if (n == "actual_TCP_speed" || n == "target_TCP_speed") return toArray(s.arm.flange_twist, 1e-3);
  if (n == "robot_mode") return static_cast<std::int32_t>(s.mode);
  if (n == "safety_mode" || n == "safety_status") return static_cast<std::int32_t>(s.safety);
  if (n == "runtime_state") return std::uint32_t{s.program_running ? 2u : 1u};
  if (n == "speed_scaling" || n == "target_speed_fraction") return 1.0;
  if (n == "robot_status_bits") return robotStatusBits(s);
  if (n == "safety_status_bits") return safetyStatusBits(s.safety);
  if (n == "joint_mode") return std::array<std::int32_t, 6>{253, 253, 253, 253, 253, 253};
  if (n == "control_step") return std::uint64_t{s.arm.cycle};
  if (n == "actual_execution_time") return 0.1;  // ms, a plausible idle controller
  if (n == "actual_main_voltage") return 48.0;
  if (n == "actual_robot_voltage") return 48.0;
  if (n == "joint_temperatures") return std::array<double, 6>{30, 30, 30, 30, 30, 30};
  if (n.starts_with("input_")) return controller.inputValue(n, f.type);
  return rtde::zeroValue(f.type);
}

std::vector<std::uint8_t> RtdeSession::handle(const rtde::Package& p) {
  using rtde::PackageType;
  switch (p.type) {
    case PackageType::RequestProtocolVersion: {
      const auto v = rtde::decodeRequestProtocolVersion(p);
      const bool ok = v == rtde::kProtocolVersion;
      if (ok) protocol_ = v;
      return rtde::encodeAccepted(p.type, ok);
    }
    case PackageType::GetUrControlVersion: return rtde::encodeUrControlVersion(controller_.options().version);
    case PackageType::SetupOutputs: {
      if (protocol_ != rtde::kProtocolVersion) {
        return rtde::encodeTextMessage(
            {"request protocol version 2 first", "MR-SNS UR simulator", rtde::MessageLevel::Error});
      }
      const auto request = rtde::decodeSetupOutputsRequest(p);
      rtde::SetupReply reply;
      rtde::Recipe recipe;
      for (const auto& n : request.names) {
        const auto t = rtde::variableType(n);
        reply.types.emplace_back(t ? rtde::toString(*t) : "NOT_FOUND");
        if (t) recipe.fields.push_back({n, *t});
      }
      const bool ok = !request.names.empty() && recipe.fields.size() == request.names.size() &&
                      request.frequency_hz > 0 && request.frequency_hz <= 500 && !started_;
      if (ok) {
        recipe.id = next_recipe_id_++;
        outputs_ = recipe;
        const double cycles = 1.0 / (request.frequency_hz * controller_.arm().controlPeriodS());
        divider_ = std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::llround(cycles)));
        reply.recipe_id = recipe.id;
      }
      return rtde::encodeSetupReply(p.type, reply);
    }
    case PackageType::SetupInputs: {
      const auto names = rtde::decodeSetupInputsRequest(p);
      rtde::SetupReply reply;
      reply.types = controller_.claimInputs(names, id_);
      const bool ok = !names.empty() && std::none_of(reply.types.begin(), reply.types.end(),
                                                     [](const auto& t) { return t == "NOT_FOUND" || t == "IN_USE"; });
      if (ok) {
        inputs_ = rtde::recipeFromNames(names);
        inputs_.id = next_recipe_id_++;
        reply.recipe_id = inputs_.id;
      }
      return rtde::encodeSetupReply(p.type, reply);
    }
    case PackageType::Start: started_ = !outputs_.fields.empty(); return rtde::encodeAccepted(p.type, started_);
    case PackageType::Pause: started_ = false; return rtde::encodeAccepted(p.type, true);
    case PackageType::DataPackage: {
      if (inputs_.fields.empty()) return {};
      const auto values = rtde::decodeDataPackage(p, inputs_);
      for (std::size_t i = 0; i < values.size(); ++i) controller_.setInput(inputs_.fields[i].name, values[i]);
      return {};
    }
    case PackageType::TextMessage: return {};
  }
  return {};
}

bool RtdeSession::dataDue(std::uint64_t cycle) const {
  return started_ && cycle % divider_ == 0;
}

std::vector<std::uint8_t> RtdeSession::dataPackage(const SimSnapshot& snapshot) const {
  std::vector<rtde::Value> values;
  values.reserve(outputs_.fields.size());
  for (const auto& f : outputs_.fields) values.push_back(outputValue(f, snapshot, controller_));
  return rtde::encodeDataPackage(outputs_, values);
}

}  // namespace mrsns::robot::detail
