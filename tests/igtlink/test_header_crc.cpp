#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string_view>
#include <vector>

#include "mrsns/core/error.h"
#include "mrsns/igtlink/crc64.h"
#include "mrsns/igtlink/header.h"
#include "mrsns/igtlink/message.h"

namespace mrsns::igtlink {
namespace {

std::span<const std::uint8_t> bytesOf(std::string_view s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

TEST(Crc64, MatchesTheEcma182CheckValue) {
  // CRC-64/ECMA-182 (MSB first, init 0, no final XOR) of "123456789".
  EXPECT_EQ(crc64(bytesOf("123456789")), 0x6C40DF5F0B497347ULL);
  EXPECT_EQ(crc64({}), 0u);
}

TEST(Crc64, ContinuesAcrossChunks) {
  const std::string_view text = "The quick brown fox jumps over the lazy dog";
  const auto whole = crc64(bytesOf(text));
  for (std::size_t cut = 0; cut <= text.size(); cut += 7) {
    EXPECT_EQ(crc64(bytesOf(text.substr(cut)), crc64(bytesOf(text.substr(0, cut)))), whole) << cut;
  }
}

TEST(Header, EncodeDecodeRoundTrip) {
  Header h;
  h.version = 2;
  h.type = "TRANSFORM";
  h.device_name = "ProbeToTrackerDevice";  // exactly 20 characters, no NUL on the wire
  h.timestamp = 0x1234567889ABCDEFULL;
  h.body_size = 48;
  h.crc = 0xFEDCBA9876543210ULL;
  const auto bytes = encodeHeader(h);
  EXPECT_EQ(bytes[0], 0);
  EXPECT_EQ(bytes[1], 2);
  EXPECT_EQ(bytes[2], 'T');
  EXPECT_EQ(bytes[13], 0);     // type is zero padded
  EXPECT_EQ(bytes[33], 'e');   // last device-name byte
  EXPECT_EQ(bytes[34], 0x12);  // timestamp high byte, big endian
  const Header back = decodeHeader(bytes);
  EXPECT_EQ(back.version, 2);
  EXPECT_EQ(back.type, "TRANSFORM");
  EXPECT_EQ(back.device_name, "ProbeToTrackerDevice");
  EXPECT_EQ(back.timestamp, h.timestamp);
  EXPECT_EQ(back.body_size, 48u);
  EXPECT_EQ(back.crc, h.crc);
}

TEST(Header, RejectsNamesThatDoNotFit) {
  Header h;
  h.type = "THIRTEEN_CHAR";
  EXPECT_THROW(encodeHeader(h), InvalidArgumentError);
  h.type = "STATUS";
  h.device_name = std::string(21, 'x');
  EXPECT_THROW(encodeHeader(h), InvalidArgumentError);
}

TEST(Header, RejectsTruncatedAndUnknownVersions) {
  Header h;
  h.type = "STRING";
  auto bytes = encodeHeader(h);
  EXPECT_THROW(decodeHeader(std::span<const std::uint8_t>(bytes).first(57)), FormatError);
  bytes[1] = 3;
  try {
    decodeHeader(bytes);
    FAIL() << "version 3 accepted";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("version"), std::string::npos) << e.what();
  }
}

TEST(Timestamp, SecondsRoundTripWithinOneTick) {
  const double tick = 1.0 / 4294967296.0;
  for (const double t : {0.0, 0.5, 1.0 - 1e-12, 1234567890.123456, 1763900000.999999999, 4294967295.5}) {
    const auto fixed = timestampFromSeconds(t);
    // Doubles near 1.7e9 s resolve ~2.4e-7 s, so the round trip is exact to that, and to a tick near 0.
    EXPECT_NEAR(timestampToSeconds(fixed), t, std::max(tick, t * 2.3e-16)) << t;
  }
  EXPECT_EQ(timestampFromSeconds(1.5), (1ULL << 32) | (1ULL << 31));
  EXPECT_EQ(timestampToSeconds((7ULL << 32) | (1ULL << 30)), 7.25);
}

TEST(Timestamp, RejectsNegativeNanAndOverflow) {
  EXPECT_THROW(timestampFromSeconds(-1.0), InvalidArgumentError);
  EXPECT_THROW(timestampFromSeconds(std::nan("")), InvalidArgumentError);
  EXPECT_THROW(timestampFromSeconds(4294967296.0), InvalidArgumentError);
  EXPECT_THROW(makeMessage("T", TransformContent{}, -5.0), InvalidArgumentError);
  EXPECT_EQ(makeMessage("T", TransformContent{}).header.timestamp, 0u);  // 0 = unset
}

}  // namespace
}  // namespace mrsns::igtlink

namespace mrsns::igtlink {
namespace {

/// Bit-at-a-time definition of the CRC, independent of the table code.
std::uint64_t crc64BitByBit(std::span<const std::uint8_t> data) {
  std::uint64_t crc = 0;
  for (const std::uint8_t byte : data) {
    crc ^= std::uint64_t{byte} << 56;
    for (int bit = 0; bit < 8; ++bit) crc = (crc & (1ULL << 63)) ? (crc << 1) ^ 0x42F0E1EBA9EA3693ULL : crc << 1;
  }
  return crc;
}

TEST(Crc64, SlicedTablesAgreeWithTheBitwiseDefinitionAtEveryLength) {
  std::vector<std::uint8_t> data(1031);
  std::uint32_t state = 12345;
  for (auto& b : data) {
    state = state * 1664525u + 1013904223u;
    b = static_cast<std::uint8_t>(state >> 24);
  }
  for (std::size_t n = 0; n <= data.size(); n += (n < 40 ? 1 : 97)) {
    const auto part = std::span<const std::uint8_t>(data).first(n);
    EXPECT_EQ(crc64(part), crc64BitByBit(part)) << n;
  }
}

}  // namespace
}  // namespace mrsns::igtlink
