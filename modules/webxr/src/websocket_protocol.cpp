#include "mrsns/webxr/websocket_protocol.h"

#include <openssl/evp.h>
#include <openssl/sha.h>

#include <algorithm>
#include <array>

namespace mrsns::webxr {

std::string websocketAcceptKey(std::string_view client_key) {
  static constexpr std::string_view kGuid = "258EAFA5-E914-47DA-95CA-C5AB0DC85B11";
  std::string joined(client_key);
  joined += kGuid;
  std::array<unsigned char, SHA_DIGEST_LENGTH> digest{};
  SHA1(reinterpret_cast<const unsigned char*>(joined.data()), joined.size(), digest.data());
  std::array<unsigned char, 4 * ((SHA_DIGEST_LENGTH + 2) / 3) + 1> encoded{};
  const int n = EVP_EncodeBlock(encoded.data(), digest.data(), static_cast<int>(digest.size()));
  return {reinterpret_cast<const char*>(encoded.data()), static_cast<std::size_t>(n)};
}

std::vector<std::uint8_t> encodeWsFrame(WsOpcode opcode, std::span<const std::uint8_t> payload) {
  std::vector<std::uint8_t> frame;
  frame.reserve(payload.size() + 10);
  frame.push_back(static_cast<std::uint8_t>(0x80U | static_cast<unsigned>(opcode)));
  const std::uint64_t n = payload.size();
  if (n < 126) {
    frame.push_back(static_cast<std::uint8_t>(n));
  } else if (n <= 0xFFFF) {
    frame.push_back(126);
    frame.push_back(static_cast<std::uint8_t>(n >> 8));
    frame.push_back(static_cast<std::uint8_t>(n));
  } else {
    frame.push_back(127);
    for (int shift = 56; shift >= 0; shift -= 8) frame.push_back(static_cast<std::uint8_t>(n >> shift));
  }
  frame.insert(frame.end(), payload.begin(), payload.end());
  return frame;
}

std::vector<std::uint8_t> encodeWsFrame(WsOpcode opcode, std::string_view payload) {
  return encodeWsFrame(opcode, std::span(reinterpret_cast<const std::uint8_t*>(payload.data()), payload.size()));
}

std::vector<std::uint8_t> encodeWsClose(std::uint16_t code, std::string_view reason) {
  std::vector<std::uint8_t> payload{static_cast<std::uint8_t>(code >> 8), static_cast<std::uint8_t>(code)};
  // A control frame's payload is at most 125 bytes.
  payload.insert(payload.end(), reason.begin(),
                 reason.begin() + static_cast<std::ptrdiff_t>(std::min<std::size_t>(reason.size(), 123)));
  return encodeWsFrame(WsOpcode::kClose, payload);
}

void WsFrameReader::feed(std::span<const std::uint8_t> bytes, std::vector<WsFrame>& frames) {
  pending_.insert(pending_.end(), bytes.begin(), bytes.end());
  std::size_t at = 0;
  while (pending_.size() - at >= 2) {
    const std::uint8_t b0 = pending_[at];
    const std::uint8_t b1 = pending_[at + 1];
    if ((b0 & 0x70U) != 0) throw ProtocolViolation(1002, "reserved bits set (no extension was negotiated)");
    const unsigned opcode = b0 & 0x0FU;
    const bool control = (opcode & 0x8U) != 0;
    if (opcode != 0x1 && opcode != 0x2 && opcode != 0x8 && opcode != 0x9 && opcode != 0xA) {
      throw ProtocolViolation(opcode == 0 ? 1003 : 1002, opcode == 0 ? "fragmented messages are not accepted"
                                                                     : "unknown opcode " + std::to_string(opcode));
    }
    if ((b0 & 0x80U) == 0) throw ProtocolViolation(1003, "fragmented messages are not accepted");
    if ((b1 & 0x80U) == 0) throw ProtocolViolation(1002, "a client frame must be masked");
    std::uint64_t length = b1 & 0x7FU;
    std::size_t header = 2;
    if (control && length > 125) throw ProtocolViolation(1002, "control frame over 125 bytes");
    if (length == 126) {
      if (pending_.size() - at < 4) break;
      length = (std::uint64_t{pending_[at + 2]} << 8) | pending_[at + 3];
      header = 4;
    } else if (length == 127) {
      if (pending_.size() - at < 10) break;
      length = 0;
      for (int i = 0; i < 8; ++i) length = (length << 8) | pending_[at + 2 + static_cast<std::size_t>(i)];
      header = 10;
    }
    // Refused from the header, before the payload is stored.
    if (length > max_payload_) {
      throw ProtocolViolation(1009, "message of " + std::to_string(length) + " bytes, more than the " +
                                        std::to_string(max_payload_) + " a client may send");
    }
    if (pending_.size() - at < header + 4 + length) break;
    const std::uint8_t* mask = &pending_[at + header];
    WsFrame frame;
    frame.opcode = static_cast<WsOpcode>(opcode);
    frame.payload.resize(static_cast<std::size_t>(length));
    const std::uint8_t* data = mask + 4;
    for (std::size_t i = 0; i < frame.payload.size(); ++i) frame.payload[i] = data[i] ^ mask[i % 4];
    frames.push_back(std::move(frame));
    at += header + 4 + static_cast<std::size_t>(length);
  }
  pending_.erase(pending_.begin(), pending_.begin() + static_cast<std::ptrdiff_t>(at));
}

}  // namespace mrsns::webxr
