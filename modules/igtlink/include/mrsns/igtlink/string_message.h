#pragma once
// STRING content: encoding (IANA MIBenum) + length + bytes.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace mrsns::igtlink {

/// IANA MIBenum character set codes used by STRING and metadata values.
inline constexpr std::uint16_t kEncodingUsAscii = 3;
inline constexpr std::uint16_t kEncodingUtf8 = 106;

/// STRING. `text` holds the bytes as sent (at most 65535), not re-encoded.
struct StringContent {
  std::uint16_t encoding = kEncodingUsAscii;
  std::string text;
};

void encodeString(const StringContent& content, std::vector<std::uint8_t>& out);
StringContent decodeString(std::span<const std::uint8_t> content);

}  // namespace mrsns::igtlink
