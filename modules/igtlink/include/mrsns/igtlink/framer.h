#pragma once
// Splits a byte stream (TCP chunks of any size) into OpenIGTLink messages.
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <vector>

#include "mrsns/igtlink/codec.h"

namespace mrsns::igtlink {

/// A header and its raw body, not yet decoded (what a relay forwards).
struct Frame {
  Header header;
  std::vector<std::uint8_t> body;
};

/// The largest body accepted for a message, decided from its header.
using BodyLimit = std::function<std::uint64_t(const Header&)>;

/// Accepts chunks with push() and yields complete messages with next().
///
/// The header's body_size is checked against options.max_body_size (and the
/// BodyLimit, when one is set) as soon as the 58 header bytes have arrived,
/// before any body storage is reserved; a bad
/// header (unknown version, body too large) leaves the stream unusable: the
/// framer then throws on every call until reset(). A bad body (CRC, malformed
/// content) only loses that message: next() throws once and the following
/// messages decode normally.
class MessageFramer {
 public:
  explicit MessageFramer(DecodeOptions options = {}) : options_(options) {}

  /// A limit per message below options.max_body_size (e.g. a server that only
  /// accepts large bodies of one type from one device). Empty: none.
  void setBodyLimit(BodyLimit limit) { body_limit_ = std::move(limit); }

  /// Appends bytes. Throws FormatError when a header in the stream is invalid.
  void push(std::span<const std::uint8_t> chunk);

  /// The next complete message, decoded; nullopt when more bytes are needed.
  std::optional<Message> next();
  /// The next complete frame, undecoded (the CRC is still checked when
  /// options.verify_crc).
  std::optional<Frame> nextFrame();

  /// Bytes received but not yet returned.
  [[nodiscard]] std::size_t bufferedBytes() const { return buffer_.size() - start_; }
  [[nodiscard]] bool failed() const { return failed_; }
  /// Drops buffered bytes and the failed state (after reconnecting).
  void reset();

 private:
  void checkPendingHeader();

  DecodeOptions options_;
  BodyLimit body_limit_;
  std::vector<std::uint8_t> buffer_;
  std::size_t start_ = 0;
  std::optional<Header> pending_;
  bool failed_ = false;
};

}  // namespace mrsns::igtlink
