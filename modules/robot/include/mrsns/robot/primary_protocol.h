#pragma once
// The UR primary/secondary client interface (TCP 30001 primary, 30002 secondary) as documented by Universal
// Robots: the controller streams big-endian messages (int32 size including the header, uint8 type). ROBOT_STATE
// (16) holds sub-packages (int32 size, uint8 type): robot mode data, joint data, cartesian info, kinematics
// info, ...; ROBOT_MESSAGE (20) carries version, safety-mode, key, runtime-exception and text messages. The
// decoder reads the sub-packages it knows and lists every sub-package it skipped; the encoder writes the same
// layout (PolyScope 5) so the in-project simulator streams what a real controller streams. Pure bytes.
#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <variant>
#include <vector>

namespace mrsns::robot::primary {

constexpr unsigned short kPrimaryPort = 30001;
constexpr unsigned short kSecondaryPort = 30002;
constexpr unsigned short kRealtimePort = 30003;
constexpr std::size_t kHeaderSize = 5;

enum class MessageType : std::uint8_t { RobotState = 16, RobotMessage = 20, ProgramStateMessage = 25 };
enum class SubPackageType : std::uint8_t {
  RobotModeData = 0,
  JointData = 1,
  ToolData = 2,
  MasterboardData = 3,
  CartesianInfo = 4,
  KinematicsInfo = 5,
  ConfigurationData = 6,
  ForceModeData = 7,
  AdditionalInfo = 8,
  CalibrationData = 9,
  SafetyData = 10,
  ToolCommInfo = 11,
  ToolModeInfo = 12,
};
enum class RobotMessageType : std::uint8_t {
  Text = 0,
  ProgramLabel = 1,
  Version = 3,
  SafetyMode = 5,
  ErrorCode = 6,
  Key = 7,
  RequestValue = 9,
  RuntimeException = 10,
};

struct RobotModeData {
  std::uint64_t timestamp = 0;  // controller clock, microseconds
  bool real_robot_connected = false, real_robot_enabled = false, robot_power_on = false, emergency_stopped = false,
       protective_stopped = false, program_running = false, program_paused = false;
  std::int8_t robot_mode = 0;  // UrRobotMode
  std::uint8_t control_mode = 0;
  double target_speed_fraction = 0, speed_scaling = 0, target_speed_fraction_limit = 0;
};

struct JointData {
  std::array<double, 6> q_actual{}, q_target{}, qd_actual{};  // rad, rad/s
  std::array<float, 6> current{}, voltage{}, motor_temperature{}, micro_temperature{};
  std::array<std::uint8_t, 6> joint_mode{};
};

struct CartesianInfo {
  std::array<double, 6> tcp_pose{};    // x, y, z (m), rotation vector (rad), base frame
  std::array<double, 6> tcp_offset{};  // flange -> TCP, same units
};

struct KinematicsInfo {
  std::array<std::uint32_t, 6> checksum{};
  std::array<double, 6> dh_theta{}, dh_a{}, dh_d{}, dh_alpha{};  // m, rad
  std::uint32_t calibration_status = 0;
};

struct SubPackageInfo {
  std::uint8_t type = 0;
  std::uint32_t size = 0;  // including its 5-byte header
};

struct RobotState {
  std::optional<RobotModeData> robot_mode;
  std::optional<JointData> joints;
  std::optional<CartesianInfo> cartesian;
  std::optional<KinematicsInfo> kinematics;
  std::vector<SubPackageInfo> sub_packages;  // every sub-package in the message, in order (decoded or not)
};

struct MessageHeader {
  std::uint64_t timestamp = 0;
  std::int8_t source = 0;
};

struct VersionMessage {
  MessageHeader header;
  std::string project_name;
  std::uint8_t major = 0, minor = 0;
  std::int32_t bugfix = 0, build = 0;
  std::string build_date;
};

struct SafetyModeMessage {
  MessageHeader header;
  std::int32_t code = 0, argument = 0;
  std::uint8_t safety_mode = 0;  // UrSafetyMode
  std::uint32_t report_data_type = 0, report_data = 0;
};

struct KeyMessage {
  MessageHeader header;
  std::int32_t code = 0, argument = 0;
  std::string title, text;
};

struct RuntimeExceptionMessage {
  MessageHeader header;
  std::int32_t line = 0, column = 0;
  std::string text;
};

struct TextMessage {
  MessageHeader header;
  std::string text;
};

/// A message whose type (or robot-message subtype) this decoder does not interpret.
struct OtherMessage {
  std::uint8_t type = 0;
  std::uint8_t robot_message_type = 0;  // for ROBOT_MESSAGE, else 0
  std::vector<std::uint8_t> payload;
};

using Message = std::variant<RobotState, VersionMessage, SafetyModeMessage, KeyMessage, RuntimeExceptionMessage,
                             TextMessage, OtherMessage>;

struct Decoded {
  Message message;
  std::size_t consumed = 0;  // bytes of the first message (the buffer may hold more)
};

/// Decodes the message at the front of `bytes`. Throws FormatError when the bytes are truncated, a size field is
/// impossible, or a known sub-package is shorter than its layout.
Decoded decodeMessage(std::span<const std::uint8_t> bytes);
/// Bytes the message at the front needs (from its size field), or 0 when fewer than 5 bytes are available.
/// Throws FormatError on a size below the header or above 1 MiB (not a primary-interface stream).
std::size_t messageSize(std::span<const std::uint8_t> bytes);

/// ROBOT_STATE with the sub-packages present in `state` (robot mode, joint, cartesian, kinematics), in that order.
std::vector<std::uint8_t> encodeRobotState(const RobotState& state);
std::vector<std::uint8_t> encodeVersionMessage(const VersionMessage& message);
std::vector<std::uint8_t> encodeSafetyModeMessage(const SafetyModeMessage& message);
std::vector<std::uint8_t> encodeTextMessage(const TextMessage& message);

}  // namespace mrsns::robot::primary
