#include "mrsns/igtlink/header.h"

#include <cmath>

#include "mrsns/core/error.h"
#include "mrsns/igtlink/byte_order.h"

namespace mrsns::igtlink {

void checkFixedString(std::string_view text, std::size_t width, std::string_view field) {
  if (text.size() > width) {
    throw InvalidArgumentError("OpenIGTLink " + std::string(field) + " '" + std::string(text) + "' has " +
                               std::to_string(text.size()) + " characters; the field holds at most " +
                               std::to_string(width) + ": shorten it");
  }
  if (text.find('\0') != std::string_view::npos) {
    throw InvalidArgumentError("OpenIGTLink " + std::string(field) + " contains a NUL character: remove it");
  }
}

double Header::timestampSeconds() const {
  return timestampToSeconds(timestamp);
}

Header decodeHeader(std::span<const std::uint8_t> bytes) {
  if (bytes.size() < kHeaderSize) {
    throw FormatError("OpenIGTLink header: needs " + std::to_string(kHeaderSize) + " bytes but only " +
                      std::to_string(bytes.size()) + " are available (truncated message)");
  }
  ByteReader r(bytes.first(kHeaderSize), "OpenIGTLink header");
  Header h;
  h.version = r.u16("version");
  if (h.version != 1 && h.version != 2) {
    r.fail("version", "is " + std::to_string(h.version) + "; only header versions 1 and 2 are supported");
  }
  h.type = r.fixedString(kTypeSize, "type");
  h.device_name = r.fixedString(kDeviceNameSize, "device_name");
  h.timestamp = r.u64("timestamp");
  h.body_size = r.u64("body_size");
  h.crc = r.u64("crc");
  return h;
}

std::array<std::uint8_t, kHeaderSize> encodeHeader(const Header& header) {
  checkFixedString(header.type, kTypeSize, "message type");
  checkFixedString(header.device_name, kDeviceNameSize, "device name");
  std::vector<std::uint8_t> buffer;
  buffer.reserve(kHeaderSize);
  ByteWriter w(buffer);
  w.u16(header.version);
  w.fixedString(header.type, kTypeSize);
  w.fixedString(header.device_name, kDeviceNameSize);
  w.u64(header.timestamp);
  w.u64(header.body_size);
  w.u64(header.crc);
  std::array<std::uint8_t, kHeaderSize> out{};
  std::copy(buffer.begin(), buffer.end(), out.begin());
  return out;
}

std::uint64_t timestampFromSeconds(double seconds) {
  if (!(seconds >= 0.0) || !(seconds < 4294967296.0)) {
    throw InvalidArgumentError("OpenIGTLink timestamp " + std::to_string(seconds) +
                               " s is outside [0, 2^32) s since 1970 UTC: pass UTC seconds");
  }
  const double whole = std::floor(seconds);
  const double fraction = std::round((seconds - whole) * 4294967296.0);
  auto high = static_cast<std::uint64_t>(whole);
  auto low = static_cast<std::uint64_t>(fraction);
  if (low >= (1ULL << 32)) {  // rounding carried into the next second
    low -= 1ULL << 32;
    ++high;
  }
  if (high >= (1ULL << 32)) return ~0ULL;
  return (high << 32) | low;
}

double timestampToSeconds(std::uint64_t timestamp) {
  return static_cast<double>(timestamp >> 32) + static_cast<double>(timestamp & 0xFFFFFFFFULL) / 4294967296.0;
}

}  // namespace mrsns::igtlink
