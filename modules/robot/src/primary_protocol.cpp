#include "mrsns/robot/primary_protocol.h"

#include "mrsns/core/error.h"
#include "ur_bytes.h"

namespace mrsns::robot::primary {
namespace {

using detail::BeReader;
using detail::BeWriter;

constexpr std::size_t kMaxMessage = 1 << 20;

// PolyScope 5 sub-package sizes (header included); a larger size means newer fields we skip.
constexpr std::uint32_t kRobotModeSize = 47;
constexpr std::uint32_t kJointDataSize = 5 + 6 * 41;
constexpr std::uint32_t kCartesianSize = 5 + 12 * 8;
constexpr std::uint32_t kKinematicsSize = 5 + 6 * 4 + 4 * 48 + 4;

void requireSize(std::uint32_t have, std::uint32_t need, const char* what) {
  if (have < need) {
    throw FormatError(std::string("primary ROBOT_STATE: ") + what + " sub-package is " + std::to_string(have) +
                      " bytes, its layout needs " + std::to_string(need) + " (truncated or not PolyScope 3.x/5.x)");
  }
}

RobotModeData readRobotMode(BeReader& r) {
  RobotModeData m;
  m.timestamp = r.u64("robot mode timestamp");
  m.real_robot_connected = r.u8("is_real_robot_connected") != 0;
  m.real_robot_enabled = r.u8("is_real_robot_enabled") != 0;
  m.robot_power_on = r.u8("is_robot_power_on") != 0;
  m.emergency_stopped = r.u8("is_emergency_stopped") != 0;
  m.protective_stopped = r.u8("is_protective_stopped") != 0;
  m.program_running = r.u8("is_program_running") != 0;
  m.program_paused = r.u8("is_program_paused") != 0;
  m.robot_mode = r.i8("robot_mode");
  m.control_mode = r.u8("control_mode");
  m.target_speed_fraction = r.f64("target_speed_fraction");
  m.speed_scaling = r.f64("speed_scaling");
  m.target_speed_fraction_limit = r.f64("target_speed_fraction_limit");
  return m;
}

JointData readJoints(BeReader& r) {
  JointData j;
  for (int i = 0; i < 6; ++i) {
    j.q_actual[i] = r.f64("q_actual");
    j.q_target[i] = r.f64("q_target");
    j.qd_actual[i] = r.f64("qd_actual");
    j.current[i] = r.f32("I_actual");
    j.voltage[i] = r.f32("V_actual");
    j.motor_temperature[i] = r.f32("T_motor");
    j.micro_temperature[i] = r.f32("T_micro");
    j.joint_mode[i] = r.u8("joint_mode");
  }
  return j;
}

void read6(BeReader& r, std::array<double, 6>& v, const char* field) {
  for (auto& d : v) d = r.f64(field);
}

RobotState readRobotState(BeReader& r) {
  RobotState s;
  while (!r.atEnd()) {
    const auto start = r.position();
    const auto size = r.u32("sub-package size");
    const auto type = r.u8("sub-package type");
    if (size < kHeaderSize) {
      throw FormatError("primary ROBOT_STATE: sub-package of type " + std::to_string(type) + " has size " +
                        std::to_string(size) + ", below its 5-byte header");
    }
    r.require(size - kHeaderSize, "sub-package body");
    s.sub_packages.push_back({type, size});
    switch (static_cast<SubPackageType>(type)) {
      case SubPackageType::RobotModeData:
        requireSize(size, kRobotModeSize - 1, "robot mode data");
        s.robot_mode = readRobotMode(r);
        break;
      case SubPackageType::JointData:
        requireSize(size, kJointDataSize, "joint data");
        s.joints = readJoints(r);
        break;
      case SubPackageType::CartesianInfo:
        requireSize(size, kCartesianSize, "cartesian info");
        s.cartesian.emplace();
        read6(r, s.cartesian->tcp_pose, "tcp pose");
        read6(r, s.cartesian->tcp_offset, "tcp offset");
        break;
      case SubPackageType::KinematicsInfo: {
        requireSize(size, kKinematicsSize, "kinematics info");
        KinematicsInfo k;
        for (auto& c : k.checksum) c = r.u32("checksum");
        read6(r, k.dh_theta, "DHtheta");
        read6(r, k.dh_a, "DHa");
        read6(r, k.dh_d, "Dhd");
        read6(r, k.dh_alpha, "Dhalpha");
        k.calibration_status = r.u32("calibration_status");
        s.kinematics = k;
        break;
      }
      default: break;
    }
    // Skip what remains of the sub-package (reserved bytes, newer fields, undecoded types).
    const auto used = r.position() - start;
    r.skip(size - used, "sub-package remainder");
  }
  return s;
}

MessageHeader readMessageHeader(BeReader& r) {
  MessageHeader h;
  h.timestamp = r.u64("timestamp");
  h.source = r.i8("source");
  return h;
}

Message readRobotMessage(BeReader& r, std::span<const std::uint8_t> payload) {
  const auto header = readMessageHeader(r);
  const auto type = r.u8("robot_message_type");
  switch (static_cast<RobotMessageType>(type)) {
    case RobotMessageType::Version: {
      VersionMessage v;
      v.header = header;
      v.project_name = r.string(r.u8("project_name_size"), "project_name");
      v.major = r.u8("major_version");
      v.minor = r.u8("minor_version");
      v.bugfix = r.i32("bugfix_version");
      v.build = r.i32("build_number");
      v.build_date = r.rest();
      return v;
    }
    case RobotMessageType::SafetyMode: {
      SafetyModeMessage m;
      m.header = header;
      m.code = r.i32("robot_message_code");
      m.argument = r.i32("robot_message_argument");
      m.safety_mode = r.u8("safety_mode_type");
      m.report_data_type = r.u32("report_data_type");
      m.report_data = r.u32("report_data");
      return m;
    }
    case RobotMessageType::Key: {
      KeyMessage m;
      m.header = header;
      m.code = r.i32("robot_message_code");
      m.argument = r.i32("robot_message_argument");
      m.title = r.string(r.u8("title_size"), "message_title");
      m.text = r.rest();
      return m;
    }
    case RobotMessageType::RuntimeException: {
      RuntimeExceptionMessage m;
      m.header = header;
      m.line = r.i32("script_line_number");
      m.column = r.i32("script_column_number");
      m.text = r.rest();
      return m;
    }
    case RobotMessageType::Text: {
      TextMessage m;
      m.header = header;
      m.text = r.rest();
      return m;
    }
    default: break;
  }
  OtherMessage o;
  o.type = static_cast<std::uint8_t>(MessageType::RobotMessage);
  o.robot_message_type = type;
  o.payload.assign(payload.begin(), payload.end());
  return o;
}

void writeHeader(BeWriter& w, MessageType type) {
  w.u32(0);  // patched at the end
  w.u8(static_cast<std::uint8_t>(type));
}

std::vector<std::uint8_t> finish(BeWriter& w) {
  w.patch(0, w.size(), 4);
  return std::move(w.bytes());
}

void writeRobotMessageHeader(BeWriter& w, const MessageHeader& h, RobotMessageType type) {
  writeHeader(w, MessageType::RobotMessage);
  w.u64(h.timestamp);
  w.i8(h.source);
  w.u8(static_cast<std::uint8_t>(type));
}

}  // namespace

std::size_t messageSize(std::span<const std::uint8_t> bytes) {
  if (bytes.size() < kHeaderSize) return 0;
  BeReader r(bytes, "primary message");
  const auto size = r.u32("size");
  if (size < kHeaderSize || size > kMaxMessage) {
    throw FormatError("primary interface: message size field " + std::to_string(size) +
                      " is impossible (below 5 or above 1 MiB): not a UR primary/secondary stream, or framing lost");
  }
  return size;
}

Decoded decodeMessage(std::span<const std::uint8_t> bytes) {
  if (bytes.size() < kHeaderSize) {
    throw FormatError("primary interface: " + std::to_string(bytes.size()) +
                      " bytes are fewer than the 5-byte message header (truncated)");
  }
  const auto size = messageSize(bytes);
  if (size > bytes.size()) {
    throw FormatError("primary interface: message size field says " + std::to_string(size) + " bytes but only " +
                      std::to_string(bytes.size()) + " are available (truncated)");
  }
  const auto type = bytes[4];
  const auto payload = bytes.subspan(kHeaderSize, size - kHeaderSize);
  BeReader r(payload, "primary message type " + std::to_string(type));
  Decoded d{OtherMessage{}, size};
  switch (static_cast<MessageType>(type)) {
    case MessageType::RobotState: d.message = readRobotState(r); break;
    case MessageType::RobotMessage: d.message = readRobotMessage(r, payload); break;
    default: {
      OtherMessage o;
      o.type = type;
      o.payload.assign(payload.begin(), payload.end());
      d.message = std::move(o);
    }
  }
  return d;
}

std::vector<std::uint8_t> encodeRobotState(const RobotState& s) {
  BeWriter w;
  writeHeader(w, MessageType::RobotState);
  if (s.robot_mode) {
    const auto& m = *s.robot_mode;
    w.u32(kRobotModeSize);
    w.u8(static_cast<std::uint8_t>(SubPackageType::RobotModeData));
    w.u64(m.timestamp);
    for (bool b : {m.real_robot_connected, m.real_robot_enabled, m.robot_power_on, m.emergency_stopped,
                   m.protective_stopped, m.program_running, m.program_paused}) {
      w.u8(b ? 1 : 0);
    }
    w.i8(m.robot_mode);
    w.u8(m.control_mode);
    w.f64(m.target_speed_fraction);
    w.f64(m.speed_scaling);
    w.f64(m.target_speed_fraction_limit);
    w.u8(0);  // reserved (PolyScope 5)
  }
  if (s.joints) {
    const auto& j = *s.joints;
    w.u32(kJointDataSize);
    w.u8(static_cast<std::uint8_t>(SubPackageType::JointData));
    for (int i = 0; i < 6; ++i) {
      w.f64(j.q_actual[i]);
      w.f64(j.q_target[i]);
      w.f64(j.qd_actual[i]);
      w.f32(j.current[i]);
      w.f32(j.voltage[i]);
      w.f32(j.motor_temperature[i]);
      w.f32(j.micro_temperature[i]);
      w.u8(j.joint_mode[i]);
    }
  }
  if (s.cartesian) {
    w.u32(kCartesianSize);
    w.u8(static_cast<std::uint8_t>(SubPackageType::CartesianInfo));
    for (double d : s.cartesian->tcp_pose) w.f64(d);
    for (double d : s.cartesian->tcp_offset) w.f64(d);
  }
  if (s.kinematics) {
    const auto& k = *s.kinematics;
    w.u32(kKinematicsSize);
    w.u8(static_cast<std::uint8_t>(SubPackageType::KinematicsInfo));
    for (auto c : k.checksum) w.u32(c);
    for (const auto* v : {&k.dh_theta, &k.dh_a, &k.dh_d, &k.dh_alpha}) {
      for (double d : *v) w.f64(d);
    }
    w.u32(k.calibration_status);
  }
  return finish(w);
}

std::vector<std::uint8_t> encodeVersionMessage(const VersionMessage& v) {
  if (v.project_name.size() > 255) throw InvalidArgumentError("primary version message: project name > 255 bytes");
  BeWriter w;
  writeRobotMessageHeader(w, v.header, RobotMessageType::Version);
  w.u8(static_cast<std::uint8_t>(v.project_name.size()));
  w.string(v.project_name);
  w.u8(v.major);
  w.u8(v.minor);
  w.i32(v.bugfix);
  w.i32(v.build);
  w.string(v.build_date);
  return finish(w);
}

std::vector<std::uint8_t> encodeSafetyModeMessage(const SafetyModeMessage& m) {
  BeWriter w;
  writeRobotMessageHeader(w, m.header, RobotMessageType::SafetyMode);
  w.i32(m.code);
  w.i32(m.argument);
  w.u8(m.safety_mode);
  w.u32(m.report_data_type);
  w.u32(m.report_data);
  return finish(w);
}

std::vector<std::uint8_t> encodeTextMessage(const TextMessage& m) {
  BeWriter w;
  writeRobotMessageHeader(w, m.header, RobotMessageType::Text);
  w.string(m.text);
  return finish(w);
}

}  // namespace mrsns::robot::primary
