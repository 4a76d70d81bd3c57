#pragma once
// Whole-message encoding and decoding (header + body, CRC, version-2
// extended header and metadata).
#include <cstdint>
#include <span>
#include <vector>

#include "mrsns/igtlink/message.h"

namespace mrsns::igtlink {

struct DecodeOptions {
  /// Bodies larger than this are refused before anything is allocated.
  std::uint64_t max_body_size = 256ULL * 1024 * 1024;
  /// Refuse a message whose CRC-64 does not match its body.
  bool verify_crc = true;
};

/// Serialises `message` as header version `version` (type, device name,
/// timestamp from message.header; body size and CRC computed; for v2 the
/// extended header sizes computed and message.extended.message_id used).
/// Throws InvalidArgumentError when the content does not match the type, a
/// field does not fit, or metadata is given for version 1.
std::vector<std::uint8_t> encodeMessage(const Message& message, HeaderVersion version = HeaderVersion::kV1);

/// Decodes one complete message (exactly header + body_size bytes). Throws
/// FormatError naming the field when anything is malformed, truncated,
/// inconsistent, over max_body_size or (if verify_crc) fails the CRC.
Message decodeMessage(std::span<const std::uint8_t> bytes, const DecodeOptions& options = {});

/// Decodes the body of a message whose header was already parsed (used by
/// MessageFramer). `body.size()` must equal header.body_size.
Message decodeBody(const Header& header, std::span<const std::uint8_t> body, const DecodeOptions& options = {});

/// Decodes content bytes as the alternative contentIndexForType(type) says.
Content decodeContent(std::string_view type, std::span<const std::uint8_t> content);
/// Appends the content bytes of `content` for `type`.
void encodeContent(std::string_view type, const Content& content, std::vector<std::uint8_t>& out);

}  // namespace mrsns::igtlink
