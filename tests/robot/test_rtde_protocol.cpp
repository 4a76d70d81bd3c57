// RTDE v2 codec: golden bytes written by hand from Universal Robots' RTDE guide (header = uint16 size incl.
// header, uint8 type, big-endian), the real recipes of the shared data set, round trips, and malformed input.
#include <gtest/gtest.h>

#include <bit>
#include <fstream>
#include <random>
#include <sstream>

#include "../support/test_data.h"
#include "mrsns/core/error.h"
#include "mrsns/robot/rtde_protocol.h"

using namespace mrsns::robot::rtde;
using Bytes = std::vector<std::uint8_t>;

namespace {

std::string readText(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void appendDouble(Bytes& b, double v) {
  const auto u = std::bit_cast<std::uint64_t>(v);
  for (int i = 7; i >= 0; --i) b.push_back(static_cast<std::uint8_t>(u >> (8 * i)));
}

void appendString(Bytes& b, std::string_view s) {
  b.insert(b.end(), s.begin(), s.end());
}

}  // namespace

TEST(RtdeProtocol, RequestProtocolVersionGoldenBytes) {
  // size 5 = 3 header + uint16 version 2; type 'V' = 0x56.
  EXPECT_EQ(encodeRequestProtocolVersion(2), (Bytes{0x00, 0x05, 0x56, 0x00, 0x02}));
  EXPECT_EQ(decodeRequestProtocolVersion(decodePackage(Bytes{0x00, 0x05, 0x56, 0x00, 0x02})), 2);
  // Reply: one byte accepted.
  EXPECT_EQ(encodeAccepted(PackageType::RequestProtocolVersion, true), (Bytes{0x00, 0x04, 0x56, 0x01}));
  EXPECT_TRUE(decodeAccepted(decodePackage(Bytes{0x00, 0x04, 0x56, 0x01}), PackageType::RequestProtocolVersion));
  EXPECT_FALSE(decodeAccepted(decodePackage(Bytes{0x00, 0x04, 0x56, 0x00}), PackageType::RequestProtocolVersion));
}

TEST(RtdeProtocol, ControlVersionStartPauseGoldenBytes) {
  EXPECT_EQ(encodeGetUrControlVersion(), (Bytes{0x00, 0x03, 0x76}));
  EXPECT_EQ(encodeStart(), (Bytes{0x00, 0x03, 0x53}));
  EXPECT_EQ(encodePause(), (Bytes{0x00, 0x03, 0x50}));
  const Bytes version{0x00, 0x13, 0x76, 0, 0, 0, 5, 0, 0, 0, 8, 0, 0, 0, 1, 0, 0, 0x27, 0x10};
  EXPECT_EQ(encodeUrControlVersion({5, 8, 1, 10000}), version);
  const auto v = decodeUrControlVersion(decodePackage(version));
  EXPECT_EQ(v.major, 5u);
  EXPECT_EQ(v.minor, 8u);
  EXPECT_EQ(v.bugfix, 1u);
  EXPECT_EQ(v.build, 10000u);
}

TEST(RtdeProtocol, SetupOutputsGoldenBytes) {
  Bytes expected{0x00, 0x00, 0x4F};
  appendDouble(expected, 125.0);
  appendString(expected, "timestamp,actual_q");
  expected[1] = static_cast<std::uint8_t>(expected.size());
  EXPECT_EQ(encodeSetupOutputs(125.0, {"timestamp", "actual_q"}), expected);
  const auto request = decodeSetupOutputsRequest(decodePackage(expected));
  EXPECT_EQ(request.frequency_hz, 125.0);
  EXPECT_EQ(request.names, (std::vector<std::string>{"timestamp", "actual_q"}));

  // Reply: recipe id 1 then the types.
  Bytes reply{0x00, 0x00, 0x4F, 0x01};
  appendString(reply, "DOUBLE,VECTOR6D");
  reply[1] = static_cast<std::uint8_t>(reply.size());
  EXPECT_EQ(encodeSetupReply(PackageType::SetupOutputs, {1, {"DOUBLE", "VECTOR6D"}}), reply);
  const auto recipe =
      recipeFromReply({"timestamp", "actual_q"}, decodeSetupReply(decodePackage(reply), PackageType::SetupOutputs));
  EXPECT_EQ(recipe.id, 1);
  ASSERT_EQ(recipe.fields.size(), 2u);
  EXPECT_EQ(recipe.fields[1].type, FieldType::Vector6d);
  EXPECT_EQ(recipe.payloadSize(), 8u + 48u);
}

// ur_rtde 1.6 ends its variable list with a comma ("timestamp,actual_q,"): one trailing comma adds no empty
// variable, as on a real controller; an empty name inside the list is still an (unknown) empty variable.
TEST(RtdeProtocol, SetupRequestsTolerateOneTrailingComma) {
  Bytes outputs{0x00, 0x00, 0x4F};
  appendDouble(outputs, 500.0);
  appendString(outputs, "timestamp,actual_q,");
  outputs[1] = static_cast<std::uint8_t>(outputs.size());
  EXPECT_EQ(decodeSetupOutputsRequest(decodePackage(outputs)).names,
            (std::vector<std::string>{"timestamp", "actual_q"}));
  Bytes inputs{0x00, 0x00, 0x49};
  appendString(inputs, "input_int_register_0,");
  inputs[1] = static_cast<std::uint8_t>(inputs.size());
  EXPECT_EQ(decodeSetupInputsRequest(decodePackage(inputs)), (std::vector<std::string>{"input_int_register_0"}));
  Bytes gap{0x00, 0x00, 0x49};
  appendString(gap, "input_int_register_0,,input_int_register_1");
  gap[1] = static_cast<std::uint8_t>(gap.size());
  EXPECT_EQ(decodeSetupInputsRequest(decodePackage(gap)),
            (std::vector<std::string>{"input_int_register_0", "", "input_int_register_1"}));
}

TEST(RtdeProtocol, SetupInputsGoldenBytesAndRefusal) {
  Bytes expected{0x00, 0x00, 0x49};
  appendString(expected, "input_int_register_0");
  expected[1] = static_cast<std::uint8_t>(expected.size());
  EXPECT_EQ(encodeSetupInputs({"input_int_register_0"}), expected);
  EXPECT_EQ(decodeSetupInputsRequest(decodePackage(expected)), (std::vector<std::string>{"input_int_register_0"}));

  // A controller that has the register taken by another client answers IN_USE: the error names it.
  try {
    (void)recipeFromReply({"input_int_register_0", "speed_slider_mask"}, {2, {"IN_USE", "UINT32"}});
    FAIL() << "IN_USE accepted";
  } catch (const mrsns::FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("input_int_register_0:IN_USE"), std::string::npos) << e.what();
  }
  EXPECT_THROW((void)recipeFromReply({"bogus"}, {1, {"NOT_FOUND"}}), mrsns::FormatError);
  EXPECT_THROW((void)recipeFromReply({"a", "b"}, {1, {"DOUBLE"}}), mrsns::FormatError);
}

TEST(RtdeProtocol, TextMessageGoldenBytes) {
  const Bytes expected{0x00, 0x0C, 0x4D, 0x02, 'h', 'i', 0x04, 'R', 'T', 'D', 'E', 0x02};
  EXPECT_EQ(encodeTextMessage({"hi", "RTDE", MessageLevel::Warning}), expected);
  const auto m = decodeTextMessage(decodePackage(expected));
  EXPECT_EQ(m.message, "hi");
  EXPECT_EQ(m.source, "RTDE");
  EXPECT_EQ(m.level, MessageLevel::Warning);
  // Message length pointing past the end.
  EXPECT_THROW((void)decodeTextMessage(decodePackage(Bytes{0x00, 0x06, 0x4D, 0x09, 'h', 'i'})), mrsns::FormatError);
}

TEST(RtdeProtocol, DataPackageGoldenBytesEveryType) {
  Recipe recipe;
  recipe.id = 3;
  recipe.fields = {{"b", FieldType::Bool},          {"u8", FieldType::Uint8},    {"u32", FieldType::Uint32},
                   {"u64", FieldType::Uint64},      {"i32", FieldType::Int32},   {"d", FieldType::Double},
                   {"v3", FieldType::Vector3d},     {"v6", FieldType::Vector6d}, {"vi", FieldType::Vector6Int32},
                   {"vu", FieldType::Vector6Uint32}};
  const std::vector<Value> values{true,
                                  std::uint8_t{0xAB},
                                  std::uint32_t{0x01020304},
                                  std::uint64_t{0x0102030405060708ULL},
                                  std::int32_t{-2},
                                  1.5,
                                  std::array<double, 3>{1, 2, 3},
                                  std::array<double, 6>{-1, 0, 1, 2, 3, 4},
                                  std::array<std::int32_t, 6>{-1, 0, 1, 2, 3, 4},
                                  std::array<std::uint32_t, 6>{1, 2, 3, 4, 5, 6}};
  Bytes expected{0x00, 0x00, 0x55, 0x03, 0x01, 0xAB, 0x01, 0x02, 0x03, 0x04, 1,
                 2,    3,    4,    5,    6,    7,    8,    0xFF, 0xFF, 0xFF, 0xFE};
  appendDouble(expected, 1.5);
  for (double d : {1.0, 2.0, 3.0}) appendDouble(expected, d);
  for (double d : {-1.0, 0.0, 1.0, 2.0, 3.0, 4.0}) appendDouble(expected, d);
  for (std::int32_t i : {-1, 0, 1, 2, 3, 4}) {
    const auto u = static_cast<std::uint32_t>(i);
    for (int s = 3; s >= 0; --s) expected.push_back(static_cast<std::uint8_t>(u >> (8 * s)));
  }
  for (std::uint32_t u : {1u, 2u, 3u, 4u, 5u, 6u}) {
    for (int s = 3; s >= 0; --s) expected.push_back(static_cast<std::uint8_t>(u >> (8 * s)));
  }
  expected[1] = static_cast<std::uint8_t>(expected.size());
  EXPECT_EQ(expected.size(), 3u + 1u + recipe.payloadSize());
  EXPECT_EQ(encodeDataPackage(recipe, values), expected);
  EXPECT_EQ(decodeDataPackage(decodePackage(expected), recipe), values);
}

TEST(RtdeProtocol, DataPackageRejectsWrongRecipeSizeAndType) {
  Recipe recipe;
  recipe.id = 1;
  recipe.fields = {{"timestamp", FieldType::Double}};
  auto bytes = encodeDataPackage(recipe, std::vector<Value>{2.0});
  Recipe other = recipe;
  other.id = 2;
  EXPECT_THROW((void)decodeDataPackage(decodePackage(bytes), other), mrsns::FormatError);
  Recipe longer = recipe;
  longer.fields.push_back({"speed_scaling", FieldType::Double});
  EXPECT_THROW((void)decodeDataPackage(decodePackage(bytes), longer), mrsns::FormatError);
  EXPECT_THROW((void)encodeDataPackage(recipe, std::vector<Value>{std::int32_t{1}}), mrsns::InvalidArgumentError);
  // BOOL must be 0 or 1.
  Recipe flag;
  flag.id = 1;
  flag.fields = {{"input_bit_register_64", FieldType::Bool}};
  EXPECT_THROW((void)decodeDataPackage(decodePackage(Bytes{0x00, 0x05, 0x55, 0x01, 0x02}), flag), mrsns::FormatError);
}

TEST(RtdeProtocol, MalformedPackagesGiveFormatErrors) {
  EXPECT_THROW((void)decodePackage(Bytes{}), mrsns::FormatError);
  EXPECT_THROW((void)decodePackage(Bytes{0x00}), mrsns::FormatError);
  EXPECT_THROW((void)decodePackage(Bytes{0x00, 0x02, 0x56}), mrsns::FormatError);        // size below header
  EXPECT_THROW((void)decodePackage(Bytes{0x00, 0x05, 0x56, 0x00}), mrsns::FormatError);  // truncated
  EXPECT_THROW((void)decodePackage(Bytes{0x00, 0x03, 0x7A}), mrsns::FormatError);        // unknown type 'z'
  try {
    (void)decodeUrControlVersion(decodePackage(Bytes{0x00, 0x07, 0x76, 0, 0, 0, 5}));
    FAIL();
  } catch (const mrsns::FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("minor"), std::string::npos) << "names the missing field: " << e.what();
  }
  // A reply of the wrong type is refused, not misread.
  EXPECT_THROW((void)decodeAccepted(decodePackage(encodeStart()), PackageType::Pause), mrsns::FormatError);
  EXPECT_THROW((void)encodeSetupOutputs(0.0, {"timestamp"}), mrsns::InvalidArgumentError);
  EXPECT_THROW((void)encodeSetupOutputs(125.0, {"a,b"}), mrsns::InvalidArgumentError);
}

TEST(RtdeProtocol, FramerSplitsAStreamFedByteByByte) {
  Bytes stream = encodeRequestProtocolVersion();
  const auto text = encodeTextMessage({"x", "y", MessageLevel::Info});
  stream.insert(stream.end(), text.begin(), text.end());
  const auto start = encodeStart();
  stream.insert(stream.end(), start.begin(), start.end());
  PackageFramer framer;
  std::vector<PackageType> types;
  for (auto b : stream) {
    framer.push(std::span<const std::uint8_t>(&b, 1));
    while (auto p = framer.next()) types.push_back(p->type);
  }
  EXPECT_EQ(types, (std::vector<PackageType>{PackageType::RequestProtocolVersion, PackageType::TextMessage,
                                             PackageType::Start}));
  EXPECT_EQ(framer.bufferedBytes(), 0u);
  PackageFramer bad;
  bad.push(Bytes{'H', 'T', 'T', 'P'});
  EXPECT_THROW((void)bad.next(), mrsns::FormatError);
}

// Bounded fuzz: random bytes and random truncations of valid packages never crash the decoders; anything
// rejected is a FormatError.
TEST(RtdeProtocol, RandomBytesNeverCrash) {
  std::mt19937 rng(42);
  Recipe recipe = recipeFromNames({"timestamp", "actual_q", "robot_mode", "joint_mode", "input_bit_register_64"});
  recipe.id = 1;
  const auto valid = encodeDataPackage(
      recipe, std::vector<Value>{1.0, std::array<double, 6>{}, std::int32_t{7}, std::array<std::int32_t, 6>{}, false});
  int rejected = 0;
  for (int i = 0; i < 20000; ++i) {
    Bytes bytes;
    if (i % 2 == 0) {
      bytes.resize(rng() % 80);
      for (auto& b : bytes) b = static_cast<std::uint8_t>(rng());
      if (bytes.size() >= 3 && i % 4 == 0) {
        bytes[0] = 0;
        bytes[1] = static_cast<std::uint8_t>(bytes.size());
        bytes[2] = "VvMUOISP"[rng() % 8];
      }
    } else {
      bytes = valid;
      bytes.resize(rng() % (valid.size() + 1));
      if (!bytes.empty() && rng() % 2) bytes[rng() % bytes.size()] ^= static_cast<std::uint8_t>(1 + rng() % 255);
    }
    try {
      const auto p = decodePackage(bytes);
      switch (p.type) {
        case PackageType::DataPackage: (void)decodeDataPackage(p, recipe); break;
        case PackageType::TextMessage: (void)decodeTextMessage(p); break;
        case PackageType::GetUrControlVersion: (void)decodeUrControlVersion(p); break;
        case PackageType::SetupOutputs: (void)decodeSetupReply(p, PackageType::SetupOutputs); break;
        case PackageType::RequestProtocolVersion: (void)decodeAccepted(p, p.type); break;
        default: break;
      }
    } catch (const mrsns::FormatError&) {
      ++rejected;
    }
  }
  EXPECT_GT(rejected, 10000);  // most random input is invalid; none of it crashed
}

TEST(RtdeProtocol, VariableTypesFollowTheRtdeGuide) {
  EXPECT_EQ(variableType("timestamp"), FieldType::Double);
  EXPECT_EQ(variableType("actual_q"), FieldType::Vector6d);
  EXPECT_EQ(variableType("joint_mode"), FieldType::Vector6Int32);
  EXPECT_EQ(variableType("actual_digital_input_bits"), FieldType::Uint64);
  EXPECT_EQ(variableType("runtime_state"), FieldType::Uint32);
  EXPECT_EQ(variableType("robot_mode"), FieldType::Int32);
  EXPECT_EQ(variableType("actual_tool_accelerometer"), FieldType::Vector3d);
  EXPECT_EQ(variableType("input_bit_register_127"), FieldType::Bool);
  EXPECT_EQ(variableType("output_int_register_47"), FieldType::Int32);
  EXPECT_EQ(variableType("input_double_register_0"), FieldType::Double);
  EXPECT_EQ(variableType("standard_digital_output_mask"), FieldType::Uint8);
  EXPECT_FALSE(variableType("input_bit_register_63"));  // the low 64 bits travel as two UINT32 words
  EXPECT_FALSE(variableType("output_int_register_48"));
  EXPECT_FALSE(variableType("output_int_register_07"));
  EXPECT_FALSE(variableType("actual_Q"));
}

TEST(RtdeProtocol, RealRecipeFilesParse) {
  MRSNS_REQUIRE_DATA(out_path, "robot/rtde_output_recipe.txt");
  MRSNS_REQUIRE_DATA(in_path, "robot/rtde_input_recipe.txt");
  MRSNS_REQUIRE_DATA(all_path, "robot/exhaustive_rtde_output_recipe.txt");
  const auto out = parseRecipeText(readText(out_path), out_path.string());
  EXPECT_EQ(out.fields.size(), 28u);
  EXPECT_EQ(out.fields.front().name, "timestamp");
  EXPECT_EQ(out.fields[out.indexOf("tcp_offset")].type, FieldType::Vector6d);
  const auto in = parseRecipeText(readText(in_path), in_path.string());
  EXPECT_EQ(in.fields.size(), 12u);
  EXPECT_EQ(in.fields[in.indexOf("speed_slider_mask")].type, FieldType::Uint32);
  const auto all = parseRecipeText(readText(all_path), all_path.string());
  EXPECT_GT(all.fields.size(), 300u);
  // Every variable of the exhaustive recipe is known and round-trips through a data package.
  Recipe r = all;
  r.id = 1;
  std::vector<Value> values;
  for (const auto& f : r.fields) values.push_back(zeroValue(f.type));
  EXPECT_EQ(decodeDataPackage(decodePackage(encodeDataPackage(r, values)), r).size(), r.fields.size());
  EXPECT_THROW((void)parseRecipeText("timestamp\nactual_qq\n", "typo.txt"), mrsns::FormatError);
}

TEST(RtdeProtocol, RealXmlConfigurationsParse) {
  MRSNS_REQUIRE_DATA(loop_path, "robot/rtde_control_loop_configuration.xml");
  MRSNS_REQUIRE_DATA(record_path, "robot/rtde_record_configuration.xml");
  const auto loop = parseRecipeXml(readText(loop_path), loop_path.string());
  ASSERT_EQ(loop.size(), 3u);
  EXPECT_EQ(loop[0].first, "state");
  EXPECT_EQ(loop[0].second.fields.size(), 3u);
  EXPECT_EQ(loop[0].second.fields[2].type, FieldType::Int32);
  EXPECT_EQ(loop[1].first, "setp");
  EXPECT_EQ(loop[1].second.fields.size(), 6u);
  EXPECT_EQ(loop[2].first, "watchdog");
  // The record configuration keeps most fields in comments: only the active ones count.
  const auto record = parseRecipeXml(readText(record_path), record_path.string());
  ASSERT_EQ(record.size(), 1u);
  EXPECT_EQ(record[0].first, "out");
  EXPECT_EQ(record[0].second.fields.size(), 32u);
  EXPECT_EQ(record[0].second.fields.back().name, "joint_position_deviation_ratio");
  // Every type the file declares agrees with the controller's table.
  for (const auto& f : record[0].second.fields) EXPECT_EQ(variableType(f.name), f.type) << f.name;
  EXPECT_THROW((void)parseRecipeXml("<rtde_config><recipe key=\"a\"><field name=\"x\" type=\"FLOAT\"/>", "bad.xml"),
               mrsns::FormatError);
  EXPECT_THROW((void)parseRecipeXml("<config/>", "bad.xml"), mrsns::FormatError);
}
