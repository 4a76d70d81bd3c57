#pragma once
// The parts of RFC 6455 the WebXR server needs, socket-free so they can be
// tested and fuzzed alone: the handshake's accept key, the server's frames
// (unmasked, never fragmented) and an incremental reader of a client's frames
// that refuses, before storing it, any frame a headset page has no reason to
// send: unmasked, fragmented, with reserved bits or opcodes, a control frame
// over 125 bytes, or a payload over the limit.
#include <cstddef>
#include <cstdint>
#include <exception>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace mrsns::webxr {

enum class WsOpcode : std::uint8_t { kText = 0x1, kBinary = 0x2, kClose = 0x8, kPing = 0x9, kPong = 0xA };

/// Sec-WebSocket-Accept for a client's Sec-WebSocket-Key: base64(SHA-1(key + RFC 6455's GUID)).
std::string websocketAcceptKey(std::string_view client_key);

/// One server frame: FIN set, unmasked, the shortest length encoding.
std::vector<std::uint8_t> encodeWsFrame(WsOpcode opcode, std::span<const std::uint8_t> payload);
std::vector<std::uint8_t> encodeWsFrame(WsOpcode opcode, std::string_view payload);
/// A close frame with a status code (RFC 6455 §7.4) and a short reason.
std::vector<std::uint8_t> encodeWsClose(std::uint16_t code, std::string_view reason);

struct WsFrame {
  WsOpcode opcode = WsOpcode::kText;
  std::vector<std::uint8_t> payload;  ///< unmasked
};

/// Reads a client's frames from a byte stream. Throws ProtocolViolation at the
/// first bad frame; the connection must then be closed (status code()).
class WsFrameReader {
 public:
  explicit WsFrameReader(std::size_t max_payload_bytes) : max_payload_(max_payload_bytes) {}
  /// Appends `bytes` and moves every complete frame to `frames`.
  void feed(std::span<const std::uint8_t> bytes, std::vector<WsFrame>& frames);

 private:
  std::size_t max_payload_;
  std::vector<std::uint8_t> pending_;
};

class ProtocolViolation : public std::exception {
 public:
  ProtocolViolation(std::uint16_t close_code, std::string what) : code_(close_code), what_(std::move(what)) {}
  [[nodiscard]] const char* what() const noexcept override { return what_.c_str(); }
  /// The close status to send: 1002 protocol error, 1003 unsupported data, 1009 too big.
  [[nodiscard]] std::uint16_t code() const noexcept { return code_; }

 private:
  std::uint16_t code_;
  std::string what_;
};

}  // namespace mrsns::webxr
