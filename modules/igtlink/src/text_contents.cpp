// STRING, STATUS and CAPABILITY contents.
#include "mrsns/igtlink/byte_order.h"
#include "mrsns/igtlink/capability.h"
#include "mrsns/igtlink/header.h"
#include "mrsns/igtlink/status.h"
#include "mrsns/igtlink/string_message.h"

namespace mrsns::igtlink {

namespace {
constexpr std::size_t kErrorNameSize = 20;
}  // namespace

void encodeString(const StringContent& content, std::vector<std::uint8_t>& out) {
  if (content.text.size() > 0xFFFF) {
    throw InvalidArgumentError("STRING text has " + std::to_string(content.text.size()) +
                               " bytes; at most 65535 fit one message");
  }
  ByteWriter w(out);
  w.u16(content.encoding);
  w.u16(static_cast<std::uint16_t>(content.text.size()));
  w.bytes(std::span(reinterpret_cast<const std::uint8_t*>(content.text.data()), content.text.size()));
}

StringContent decodeString(std::span<const std::uint8_t> content) {
  ByteReader r(content, "STRING content");
  StringContent out;
  out.encoding = r.u16("encoding");
  const std::uint16_t length = r.u16("length");
  const auto text = r.bytes(length, "length");
  out.text.assign(reinterpret_cast<const char*>(text.data()), text.size());
  r.expectEnd("the string");
  return out;
}

void encodeStatus(const StatusContent& content, std::vector<std::uint8_t>& out) {
  checkFixedString(content.error_name, kErrorNameSize, "STATUS error name");
  if (content.message.find('\0') != std::string::npos) {
    throw InvalidArgumentError("STATUS message contains a NUL character: remove it");
  }
  ByteWriter w(out);
  w.u16(content.code);
  w.i64(content.subcode);
  w.fixedString(content.error_name, kErrorNameSize);
  w.fixedString(content.message, content.message.size());
  w.u8(0);
}

StatusContent decodeStatus(std::span<const std::uint8_t> content) {
  ByteReader r(content, "STATUS content");
  StatusContent out;
  out.code = r.u16("code");
  out.subcode = r.i64("subcode");
  out.error_name = r.fixedString(kErrorNameSize, "error_name");
  if (!r.atEnd()) {
    out.message = r.cString(r.remaining(), "status_message");
    r.expectEnd("the NUL-terminated status message");
  }
  return out;
}

void encodeCapability(const CapabilityContent& content, std::vector<std::uint8_t>& out) {
  for (const auto& t : content.types) checkFixedString(t, kTypeSize, "CAPABILITY type");
  ByteWriter w(out);
  for (const auto& t : content.types) w.fixedString(t, kTypeSize);
}

CapabilityContent decodeCapability(std::span<const std::uint8_t> content) {
  ByteReader r(content, "CAPABILITY content");
  if (content.size() % kTypeSize != 0) {
    r.fail("types", "span " + std::to_string(content.size()) + " bytes, not a multiple of 12");
  }
  CapabilityContent out;
  out.types.reserve(content.size() / kTypeSize);
  while (!r.atEnd()) out.types.push_back(r.fixedString(kTypeSize, "type"));
  return out;
}

}  // namespace mrsns::igtlink
