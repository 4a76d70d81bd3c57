#pragma once
// The 58-byte OpenIGTLink message header (identical layout in versions 1 and 2;
// version 2 adds an extended header at the start of the body).
#include <array>
#include <cstdint>
#include <span>
#include <string>

namespace mrsns::igtlink {

inline constexpr std::size_t kHeaderSize = 58;
inline constexpr std::size_t kTypeSize = 12;
inline constexpr std::size_t kDeviceNameSize = 20;

enum class HeaderVersion : std::uint16_t { kV1 = 1, kV2 = 2 };

/// Header fields as on the wire. `timestamp` is the raw 32.32 fixed-point
/// value (seconds since 1970-01-01 UTC in the high word, fraction of a second
/// in the low word), kept raw so a message re-encodes bit for bit.
struct Header {
  std::uint16_t version = 1;
  std::string type;         ///< at most 12 characters, e.g. "TRANSFORM"
  std::string device_name;  ///< at most 20 characters, e.g. "ProbeToTracker"
  std::uint64_t timestamp = 0;
  std::uint64_t body_size = 0;
  std::uint64_t crc = 0;  ///< CRC-64 of the body

  [[nodiscard]] double timestampSeconds() const;
};

/// Parses the first 58 bytes. Throws FormatError when fewer are given or the
/// version is not 1 or 2 (other versions are laid out differently or unknown).
Header decodeHeader(std::span<const std::uint8_t> bytes);

/// Serialises the header as given (body_size and crc included). Throws
/// InvalidArgumentError when type or device name do not fit their fields.
std::array<std::uint8_t, kHeaderSize> encodeHeader(const Header& header);

/// Seconds since 1970 UTC -> 32.32 fixed point (rounded to the nearest 2^-32 s).
/// Throws InvalidArgumentError for negative, NaN or >= 2^32 s.
std::uint64_t timestampFromSeconds(double seconds);
/// 32.32 fixed point -> seconds since 1970 UTC.
double timestampToSeconds(std::uint64_t timestamp);

}  // namespace mrsns::igtlink
