// RFC 6455 as the WebXR server speaks it: the handshake's accept key (the
// RFC's own example), server frames, and the reader of client frames: masked
// frames in any split, every refusal decided from the header.
#include <gtest/gtest.h>

#include <random>

#include "mrsns/webxr/websocket_protocol.h"

namespace mrsns::webxr {
namespace {

std::vector<std::uint8_t> clientFrame(std::uint8_t first_byte, const std::vector<std::uint8_t>& payload,
                                      bool masked = true, std::uint32_t mask_key = 0x37fa213d) {
  std::vector<std::uint8_t> f{first_byte};
  const std::uint8_t mask_bit = masked ? 0x80 : 0x00;
  const std::uint64_t n = payload.size();
  if (n < 126) {
    f.push_back(static_cast<std::uint8_t>(mask_bit | n));
  } else if (n <= 0xFFFF) {
    f.push_back(mask_bit | 126);
    f.push_back(static_cast<std::uint8_t>(n >> 8));
    f.push_back(static_cast<std::uint8_t>(n));
  } else {
    f.push_back(mask_bit | 127);
    for (int s = 56; s >= 0; s -= 8) f.push_back(static_cast<std::uint8_t>(n >> s));
  }
  const std::uint8_t mask[4] = {static_cast<std::uint8_t>(mask_key >> 24), static_cast<std::uint8_t>(mask_key >> 16),
                                static_cast<std::uint8_t>(mask_key >> 8), static_cast<std::uint8_t>(mask_key)};
  if (masked) f.insert(f.end(), mask, mask + 4);
  for (std::size_t i = 0; i < payload.size(); ++i) f.push_back(masked ? payload[i] ^ mask[i % 4] : payload[i]);
  return f;
}

std::vector<std::uint8_t> bytes(const std::string& s) {
  return {s.begin(), s.end()};
}

TEST(WebSocketProtocol, AcceptKeyIsTheRfcExample) {
  // RFC 6455 §1.3.
  EXPECT_EQ(websocketAcceptKey("dGhlIHNhbXBsZSBub25jZQ=="), "s3pPLMBiTxaQ9kYGzzhZRbK+xOo=");
}

TEST(WebSocketProtocol, ServerFramesUseTheShortestLengthAndNoMask) {
  for (const std::size_t n : {0UL, 125UL, 126UL, 65535UL, 65536UL, 200000UL}) {
    const std::vector<std::uint8_t> payload(n, 0xAB);
    const auto f = encodeWsFrame(WsOpcode::kBinary, payload);
    EXPECT_EQ(f[0], 0x82);
    const std::size_t header = n < 126 ? 2 : n <= 0xFFFF ? 4 : 10;
    ASSERT_EQ(f.size(), header + n);
    EXPECT_EQ(f[1] & 0x80, 0) << "a server frame is never masked";
    EXPECT_EQ(f[1] & 0x7F, n < 126 ? n : n <= 0xFFFF ? 126U : 127U);
  }
  const auto close = encodeWsClose(1009, std::string(300, 'x'));
  EXPECT_EQ(close[0], 0x88);
  EXPECT_EQ(close[1], 125) << "a close frame's reason is cut to the 125 bytes of a control frame";
}

TEST(WebSocketProtocol, ReaderUnmasksFramesSplitAnywhere) {
  std::mt19937 rng(7);
  std::vector<std::uint8_t> stream;
  std::vector<std::string> texts;
  for (int i = 0; i < 40; ++i) {
    std::string text(std::uniform_int_distribution<int>(0, 3000)(rng), 'a');
    for (auto& c : text) c = static_cast<char>('a' + rng() % 26);
    texts.push_back(text);
    const auto f = clientFrame(0x81, bytes(text), true, static_cast<std::uint32_t>(rng()));
    stream.insert(stream.end(), f.begin(), f.end());
  }
  WsFrameReader reader(4096);
  std::vector<WsFrame> frames;
  for (std::size_t at = 0; at < stream.size();) {
    const std::size_t n = std::min<std::size_t>(stream.size() - at, 1 + rng() % 700);
    reader.feed(std::span(stream.data() + at, n), frames);
    at += n;
  }
  ASSERT_EQ(frames.size(), texts.size());
  for (std::size_t i = 0; i < texts.size(); ++i) {
    EXPECT_EQ(frames[i].opcode, WsOpcode::kText);
    EXPECT_EQ(std::string(frames[i].payload.begin(), frames[i].payload.end()), texts[i]);
  }
}

void expectRefused(const std::vector<std::uint8_t>& frame, std::uint16_t code, std::size_t limit = 4096) {
  WsFrameReader reader(limit);
  std::vector<WsFrame> frames;
  try {
    reader.feed(frame, frames);
    ADD_FAILURE() << "accepted a frame that must be refused";
  } catch (const ProtocolViolation& e) {
    EXPECT_EQ(e.code(), code) << e.what();
  }
  EXPECT_TRUE(frames.empty());
}

TEST(WebSocketProtocol, ReaderRefusesWhatAPageHasNoReasonToSend) {
  expectRefused(clientFrame(0x81, bytes("hello"), false), 1002);              // unmasked
  expectRefused(clientFrame(0x01, bytes("part")), 1003);                      // fragmented (FIN clear)
  expectRefused(clientFrame(0x80, bytes("continuation")), 1003);              // continuation
  expectRefused(clientFrame(0xC1, bytes("compressed")), 1002);                // RSV1 without an extension
  expectRefused(clientFrame(0x83, bytes("?")), 1002);                         // reserved opcode
  expectRefused(clientFrame(0x89, std::vector<std::uint8_t>(126, 1)), 1002);  // control frame over 125 bytes
}

TEST(WebSocketProtocol, AnOversizedMessageIsRefusedFromItsHeaderAlone) {
  // A 100 MB frame announced in a 14-byte header: refused before any payload arrives.
  std::vector<std::uint8_t> header{0x81, 0xFF};
  const std::uint64_t n = 100ULL << 20;
  for (int s = 56; s >= 0; s -= 8) header.push_back(static_cast<std::uint8_t>(n >> s));
  header.insert(header.end(), {1, 2, 3, 4});
  expectRefused(header, 1009);
  // The limit itself is accepted, one byte more is not.
  WsFrameReader reader(4096);
  std::vector<WsFrame> frames;
  reader.feed(clientFrame(0x81, std::vector<std::uint8_t>(4096, 'x')), frames);
  EXPECT_EQ(frames.size(), 1U);
  expectRefused(clientFrame(0x81, std::vector<std::uint8_t>(4097, 'x')), 1009);
}

TEST(WebSocketProtocol, RandomBytesNeverCrashTheReader) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 2000; ++trial) {
    std::vector<std::uint8_t> junk(rng() % 64);
    for (auto& b : junk) b = static_cast<std::uint8_t>(rng());
    WsFrameReader reader(64);
    std::vector<WsFrame> frames;
    try {
      reader.feed(junk, frames);
    } catch (const ProtocolViolation&) {
    }
    for (const auto& f : frames) EXPECT_LE(f.payload.size(), 64U);
  }
}

}  // namespace
}  // namespace mrsns::webxr
