#include <gtest/gtest.h>

#include "mrsns/core/error.h"
#include "mrsns/igtlink/framer.h"

namespace mrsns::igtlink {
namespace {

std::vector<std::uint8_t> stream(int count) {
  std::vector<std::uint8_t> out;
  for (int i = 0; i < count; ++i) {
    Message m = makeMessage("Dev" + std::to_string(i), StringContent{kEncodingUsAscii, std::string(i * 7, 'a')});
    m.extended.message_id = static_cast<std::uint32_t>(i);
    const auto b = encodeMessage(m, i % 2 ? HeaderVersion::kV2 : HeaderVersion::kV1);
    out.insert(out.end(), b.begin(), b.end());
  }
  return out;
}

TEST(Framer, ChunksOfEverySizeYieldTheSameMessages) {
  const auto bytes = stream(9);
  for (const std::size_t chunk :
       {std::size_t{1}, std::size_t{3}, std::size_t{57}, std::size_t{58}, std::size_t{100}, bytes.size()}) {
    MessageFramer framer;
    std::vector<Message> got;
    for (std::size_t at = 0; at < bytes.size(); at += chunk) {
      framer.push(std::span<const std::uint8_t>(bytes).subspan(at, std::min(chunk, bytes.size() - at)));
      while (auto m = framer.next()) got.push_back(std::move(*m));
    }
    ASSERT_EQ(got.size(), 9u) << chunk;
    for (int i = 0; i < 9; ++i) {
      EXPECT_EQ(got[static_cast<std::size_t>(i)].header.device_name, "Dev" + std::to_string(i));
      EXPECT_EQ(got[static_cast<std::size_t>(i)].as<StringContent>()->text.size(), static_cast<std::size_t>(i * 7));
    }
    EXPECT_EQ(framer.bufferedBytes(), 0u);
  }
}

TEST(Framer, WaitsForTheWholeBody) {
  const auto bytes = stream(2);
  MessageFramer framer;
  framer.push(std::span<const std::uint8_t>(bytes).first(kHeaderSize + 2));
  EXPECT_FALSE(framer.next());
  framer.push(std::span<const std::uint8_t>(bytes).subspan(kHeaderSize + 2));
  EXPECT_TRUE(framer.next());
  EXPECT_TRUE(framer.next());
  EXPECT_FALSE(framer.next());
}

TEST(Framer, BodySizeBeyondLimitIsRejectedFromTheHeaderAlone) {
  DecodeOptions options;
  options.max_body_size = 1024;
  MessageFramer framer(options);
  Header h;
  h.type = "IMAGE";
  h.body_size = 1ULL << 62;  // a body that could never be allocated
  const auto header = encodeHeader(h);
  EXPECT_THROW(framer.push(header), FormatError);
  EXPECT_TRUE(framer.failed());
  EXPECT_LE(framer.bufferedBytes(), kHeaderSize);
  // The stream has lost its message boundaries: every later call fails until reset.
  EXPECT_THROW(framer.push(stream(1)), FormatError);
  EXPECT_THROW(framer.next(), FormatError);
  framer.reset();
  framer.push(stream(1));
  EXPECT_TRUE(framer.next());
}

TEST(Framer, ABodyLimitByHeaderLowersTheLimitForSomeMessagesOnly) {
  DecodeOptions options;
  options.max_body_size = 1000;  // the ceiling, whatever the limit by header says
  MessageFramer framer(options);
  framer.setBodyLimit([](const Header& h) -> std::uint64_t { return h.device_name == "Photo" ? 5000 : 20; });
  auto message = [](const std::string& device, std::size_t length) {
    return encodeMessage(makeMessage(device, StringContent{kEncodingUsAscii, std::string(length, 'x')}));
  };
  framer.push(message("Photo", 500));  // 504-byte body: under the ceiling, from the device allowed more
  framer.push(message("Confirm", 16));  // 20 bytes: at the limit
  EXPECT_EQ(framer.next()->header.device_name, "Photo");
  EXPECT_EQ(framer.next()->header.device_name, "Confirm");
  EXPECT_THROW(framer.push(message("Confirm", 17)), FormatError);
  EXPECT_TRUE(framer.failed());
  framer.reset();
  try {
    framer.push(message("Photo", 997));  // 1001 bytes: the ceiling holds for the large device too
    FAIL() << "a body over the ceiling was accepted";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("over the limit of 1000"), std::string::npos) << e.what();
  }
}

TEST(Framer, BadCrcLosesOnlyThatMessage) {
  auto bytes = stream(3);
  const std::size_t first = kHeaderSize + 4;  // message 0: empty STRING
  bytes[first + kHeaderSize + 5] ^= 1;        // corrupt message 1's body
  MessageFramer framer;
  framer.push(bytes);
  EXPECT_TRUE(framer.next());
  EXPECT_THROW(framer.next(), FormatError);
  const auto third = framer.next();
  ASSERT_TRUE(third);
  EXPECT_EQ(third->header.device_name, "Dev2");
}

TEST(Framer, FramesCarryRawBodiesForRelays) {
  const auto bytes = stream(2);
  MessageFramer framer;
  framer.push(bytes);
  const auto f0 = framer.nextFrame();
  const auto f1 = framer.nextFrame();
  ASSERT_TRUE(f0 && f1);
  std::vector<std::uint8_t> rebuilt;
  for (const auto* f : {&*f0, &*f1}) {
    const auto h = encodeHeader(f->header);
    rebuilt.insert(rebuilt.end(), h.begin(), h.end());
    rebuilt.insert(rebuilt.end(), f->body.begin(), f->body.end());
  }
  EXPECT_TRUE(rebuilt == bytes);
}

}  // namespace
}  // namespace mrsns::igtlink
