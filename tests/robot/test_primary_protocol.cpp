// Primary/secondary interface: the real captures from Universal Robots' simulator (shared data, robot/), decoded
// field by field against the bytes; the encoder writes the same layout; truncation gives FormatError.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <random>

#include "../support/test_data.h"
#include "mrsns/core/error.h"
#include "mrsns/robot/dashboard_protocol.h"
#include "mrsns/robot/primary_protocol.h"

using namespace mrsns::robot;
using namespace mrsns::robot::primary;
using Bytes = std::vector<std::uint8_t>;

namespace {

Bytes readBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return Bytes(std::istreambuf_iterator<char>(in), {});
}

}  // namespace

TEST(PrimaryProtocol, RealRobotStateCapture) {
  MRSNS_REQUIRE_DATA(path, "robot/primary_ROBOT_STATE.bin");
  const auto bytes = readBytes(path);
  const auto d = decodeMessage(bytes);
  EXPECT_EQ(d.consumed, 1386u);
  const auto& s = std::get<RobotState>(d.message);
  // 13 sub-packages in the capture, in this order.
  std::vector<int> types;
  for (const auto& sp : s.sub_packages) types.push_back(sp.type);
  EXPECT_EQ(types, (std::vector<int>{0, 1, 4, 5, 9, 3, 2, 6, 7, 8, 10, 11, 12}));
  ASSERT_TRUE(s.robot_mode);
  EXPECT_TRUE(s.robot_mode->real_robot_connected);
  EXPECT_TRUE(s.robot_mode->robot_power_on);
  EXPECT_FALSE(s.robot_mode->protective_stopped);
  EXPECT_EQ(urRobotModeFromInt(s.robot_mode->robot_mode), UrRobotMode::Running);
  EXPECT_DOUBLE_EQ(s.robot_mode->target_speed_fraction, 0.97);
  EXPECT_DOUBLE_EQ(s.robot_mode->target_speed_fraction_limit, 1.0);
  ASSERT_TRUE(s.joints);
  EXPECT_DOUBLE_EQ(s.joints->q_actual[0], -1.6007);
  EXPECT_DOUBLE_EQ(s.joints->q_actual[4], 1.5951);
  EXPECT_EQ(s.joints->q_actual, s.joints->q_target);
  EXPECT_FLOAT_EQ(s.joints->motor_temperature[0], 25.5f);
  EXPECT_EQ(s.joints->joint_mode[3], 253);  // JOINT_RUNNING_MODE
  ASSERT_TRUE(s.cartesian);
  EXPECT_NEAR(s.cartesian->tcp_pose[0], -0.14396865671352163, 1e-17);
  EXPECT_NEAR(s.cartesian->tcp_pose[4], 3.1162765284819756, 1e-15);
  ASSERT_TRUE(s.kinematics);
  // The nominal UR5e DH parameters (ur5e_default_kinematics.yaml): d1 0.1625, a2 -0.425, a3 -0.3922, ...
  EXPECT_DOUBLE_EQ(s.kinematics->dh_d[0], 0.1625);
  EXPECT_DOUBLE_EQ(s.kinematics->dh_a[1], -0.425);
  EXPECT_DOUBLE_EQ(s.kinematics->dh_a[2], -0.3922);
  EXPECT_DOUBLE_EQ(s.kinematics->dh_d[5], 0.0996);
  EXPECT_DOUBLE_EQ(s.kinematics->dh_alpha[0], 1.570796327);
  EXPECT_EQ(s.kinematics->checksum[0], 0xFFFFFFFFu);
}

TEST(PrimaryProtocol, RealRobotMessages) {
  MRSNS_REQUIRE_DATA(version_path, "robot/primary_VERSION_MESSAGE.bin");
  MRSNS_REQUIRE_DATA(safety_path, "robot/primary_SAFETY_MODE_MESSAGE.bin");
  MRSNS_REQUIRE_DATA(key_path, "robot/primary_KEY_MESSAGE.bin");
  MRSNS_REQUIRE_DATA(rt_path, "robot/primary_RUNTIME_EXCEPTION_MESSAGE.bin");
  const auto v = std::get<VersionMessage>(decodeMessage(readBytes(version_path)).message);
  EXPECT_EQ(v.project_name, "URControl");
  // Bytes 0x05 0x18: the capture is of PolyScope 5.24 (the data README says 5.8; the bytes decide).
  EXPECT_EQ(v.major, 5);
  EXPECT_EQ(v.minor, 24);
  EXPECT_EQ(v.bugfix, 0);
  EXPECT_EQ(v.build, 0);
  EXPECT_EQ(v.build_date, "04-10-2025, 00:25:33");
  EXPECT_EQ(v.header.source, -2);

  const auto safety = std::get<SafetyModeMessage>(decodeMessage(readBytes(safety_path)).message);
  EXPECT_EQ(urSafetyModeFromInt(safety.safety_mode), UrSafetyMode::ProtectiveStop);
  EXPECT_EQ(safety.report_data, 1u);

  const auto key = std::get<KeyMessage>(decodeMessage(readBytes(key_path)).message);
  EXPECT_EQ(key.title, "PROGRAM_XXX_STARTED");
  EXPECT_EQ(key.text, "textmsg");

  // The capture is 59 bytes but its size field says 57: the text ends where the size says, the last two bytes
  // ("g:") belong to whatever follows on the stream.
  const auto rt_decoded = decodeMessage(readBytes(rt_path));
  EXPECT_EQ(rt_decoded.consumed, 57u);
  const auto rt = std::get<RuntimeExceptionMessage>(rt_decoded.message);
  EXPECT_EQ(rt.line, 3);
  EXPECT_EQ(rt.column, 1);
  EXPECT_EQ(rt.text, "compile_error_name_not_found:txtms");
}

TEST(PrimaryProtocol, TrailingBytesAreLeftForTheNextMessage) {
  MRSNS_REQUIRE_DATA(path, "robot/primary_REPORT_LEVELS_TEMPLATE.bin");
  const auto bytes = readBytes(path);
  const auto d = decodeMessage(bytes);
  EXPECT_EQ(d.consumed, 32u);  // the file holds 38 bytes; the size field says 32
  EXPECT_EQ(std::get<OtherMessage>(d.message).robot_message_type, 6);
}

TEST(PrimaryProtocol, EncoderReproducesTheCapturedLayout) {
  MRSNS_REQUIRE_DATA(path, "robot/primary_ROBOT_STATE.bin");
  MRSNS_REQUIRE_DATA(version_path, "robot/primary_VERSION_MESSAGE.bin");
  MRSNS_REQUIRE_DATA(safety_path, "robot/primary_SAFETY_MODE_MESSAGE.bin");
  const auto bytes = readBytes(path);
  auto state = std::get<RobotState>(decodeMessage(bytes).message);
  const auto encoded = encodeRobotState(state);
  // The first four sub-packages (robot mode, joints, cartesian, kinematics) are bytes 5..629 of the capture.
  ASSERT_EQ(encoded.size(), 5u + 47u + 251u + 101u + 225u);
  EXPECT_TRUE(std::equal(encoded.begin() + 5, encoded.end(), bytes.begin() + 5));
  EXPECT_EQ(encoded[4], 16);
  const auto back = std::get<RobotState>(decodeMessage(encoded).message);
  EXPECT_EQ(back.joints->q_actual, state.joints->q_actual);
  EXPECT_EQ(back.kinematics->dh_d, state.kinematics->dh_d);

  const auto version_bytes = readBytes(version_path);
  EXPECT_EQ(encodeVersionMessage(std::get<VersionMessage>(decodeMessage(version_bytes).message)), version_bytes);
  const auto safety_bytes = readBytes(safety_path);
  EXPECT_EQ(encodeSafetyModeMessage(std::get<SafetyModeMessage>(decodeMessage(safety_bytes).message)), safety_bytes);
  TextMessage t;
  t.text = "hello";
  EXPECT_EQ(std::get<TextMessage>(decodeMessage(encodeTextMessage(t)).message).text, "hello");
}

TEST(PrimaryProtocol, TruncatedAndCorruptMessagesThrowFormatError) {
  MRSNS_REQUIRE_DATA(path, "robot/primary_ROBOT_STATE.bin");
  const auto bytes = readBytes(path);
  for (std::size_t n : {0u, 3u, 5u, 100u, 1385u}) {
    EXPECT_THROW((void)decodeMessage(std::span(bytes.data(), n)), mrsns::FormatError) << n;
  }
  // A joint-data sub-package claiming 20 bytes (shorter than its layout).
  auto shortened = bytes;
  shortened[52 + 3] = 20;
  EXPECT_THROW((void)decodeMessage(shortened), mrsns::FormatError);
  // A sub-package claiming more bytes than the message holds.
  auto overlong = bytes;
  overlong[5 + 2] = 0x10;
  EXPECT_THROW((void)decodeMessage(overlong), mrsns::FormatError);
  EXPECT_THROW((void)messageSize(Bytes{0x7F, 0, 0, 0, 16}), mrsns::FormatError);
  // Bounded fuzz: random corruption never crashes.
  std::mt19937 rng(3);
  int rejected = 0;
  for (int i = 0; i < 3000; ++i) {
    auto b = bytes;
    for (int k = 0; k < 4; ++k) b[rng() % b.size()] = static_cast<std::uint8_t>(rng());
    b.resize(rng() % (b.size() + 1));
    try {
      (void)decodeMessage(b);
    } catch (const mrsns::FormatError&) {
      ++rejected;
    }
  }
  EXPECT_GT(rejected, 0);
}
