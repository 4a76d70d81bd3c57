#include "mrsns/igtlink/codec.h"

#include <type_traits>

#include "mrsns/igtlink/byte_order.h"
#include "mrsns/igtlink/crc64.h"

namespace mrsns::igtlink {

namespace {

constexpr std::size_t kMetadataEntryHeaderSize = 8;

}  // namespace

Content decodeContent(std::string_view type, std::span<const std::uint8_t> content) {
  const std::size_t index = contentIndexForType(type);
  const auto raw = [&content]() {
    return Content(RawContent{std::vector<std::uint8_t>(content.begin(), content.end())});
  };
  switch (index) {
    case contentIndex<TransformContent>(): return decodeTransform(content);
    case contentIndex<PositionContent>(): return decodePosition(content);
    case contentIndex<TrackingDataContent>(): return decodeTrackingData(content);
    case contentIndex<StartTrackingDataContent>(): return decodeStartTrackingData(content);
    case contentIndex<ImageContent>(): return decodeImage(content);
    case contentIndex<PolyDataContent>(): return decodePolyData(content);
    case contentIndex<StringContent>(): return decodeString(content);
    case contentIndex<StatusContent>(): return decodeStatus(content);
    case contentIndex<PointContent>(): return decodePoint(content);
    case contentIndex<CapabilityContent>(): return decodeCapability(content);
    case contentIndex<GetRequest>(): return content.empty() ? Content(GetRequest{}) : raw();
    case contentIndex<StartStream>():
      if (content.empty()) return StartStream{};
      if (content.size() == 8) {
        ByteReader r(content, "STT_ content");
        return StartStream{r.u64("resolution")};
      }
      return raw();
    case contentIndex<StopStream>(): return content.empty() ? Content(StopStream{}) : raw();
    case contentIndex<RtsStatus>(): return content.size() == 1 ? Content(RtsStatus{content[0]}) : raw();
    default: return raw();
  }
}

void encodeContent(std::string_view type, const Content& content, std::vector<std::uint8_t>& out) {
  if (const auto* raw = std::get_if<RawContent>(&content)) {
    out.insert(out.end(), raw->bytes.begin(), raw->bytes.end());
    return;
  }
  if (content.index() != contentIndexForType(type)) {
    throw InvalidArgumentError("OpenIGTLink message of type '" + std::string(type) +
                               "' cannot carry this content (content alternative " + std::to_string(content.index()) +
                               "): use the matching type name or RawContent");
  }
  std::visit(
      [&out](const auto& c) {
        using T = std::decay_t<decltype(c)>;
        ByteWriter w(out);
        if constexpr (std::is_same_v<T, TransformContent>) encodeTransform(c, out);
        if constexpr (std::is_same_v<T, PositionContent>) encodePosition(c, out);
        if constexpr (std::is_same_v<T, TrackingDataContent>) encodeTrackingData(c, out);
        if constexpr (std::is_same_v<T, StartTrackingDataContent>) encodeStartTrackingData(c, out);
        if constexpr (std::is_same_v<T, ImageContent>) encodeImage(c, out);
        if constexpr (std::is_same_v<T, PolyDataContent>) encodePolyData(c, out);
        if constexpr (std::is_same_v<T, StringContent>) encodeString(c, out);
        if constexpr (std::is_same_v<T, StatusContent>) encodeStatus(c, out);
        if constexpr (std::is_same_v<T, PointContent>) encodePoint(c, out);
        if constexpr (std::is_same_v<T, CapabilityContent>) encodeCapability(c, out);
        if constexpr (std::is_same_v<T, StartStream>) {
          if (c.resolution) w.u64(*c.resolution);
        }
        if constexpr (std::is_same_v<T, RtsStatus>) w.u8(c.status);
      },
      content);
}

std::vector<std::uint8_t> encodeMessage(const Message& message, HeaderVersion version) {
  const bool v2 = version == HeaderVersion::kV2;
  if (!v2 && !message.metadata.empty()) {
    throw InvalidArgumentError("OpenIGTLink header version 1 cannot carry metadata (" +
                               std::to_string(message.metadata.size()) + " entries): encode as version 2");
  }
  checkFixedString(message.header.type, kTypeSize, "message type");
  checkFixedString(message.header.device_name, kDeviceNameSize, "device name");
  std::vector<std::uint8_t> out(kHeaderSize);
  out.reserve(256);
  std::size_t extended_at = 0;
  if (v2) {
    if (message.extended.extra.size() > 0xFFFF - kExtendedHeaderSize) {
      throw InvalidArgumentError("OpenIGTLink extended header extra bytes exceed 65523");
    }
    if (message.metadata.size() > (0xFFFF - 2) / kMetadataEntryHeaderSize) {
      throw InvalidArgumentError("OpenIGTLink metadata has " + std::to_string(message.metadata.size()) +
                                 " entries; at most 8191 fit the metadata header");
    }
    extended_at = out.size();
    out.resize(out.size() + kExtendedHeaderSize);
    out.insert(out.end(), message.extended.extra.begin(), message.extended.extra.end());
  }
  encodeContent(message.header.type, message.content, out);
  if (v2) {
    ByteWriter w(out);
    std::uint64_t metadata_size = 0;
    w.u16(static_cast<std::uint16_t>(message.metadata.size()));
    for (const auto& m : message.metadata) {
      if (m.key.size() > 0xFFFF || m.value.size() > 0xFFFFFFFFULL) {
        throw InvalidArgumentError("OpenIGTLink metadata key '" + m.key.substr(0, 40) +
                                   "' or its value is too long (key <= 65535, value < 4 GiB bytes)");
      }
      w.u16(static_cast<std::uint16_t>(m.key.size()));
      w.u16(m.encoding);
      w.u32(static_cast<std::uint32_t>(m.value.size()));
      metadata_size += m.key.size() + m.value.size();
    }
    if (metadata_size > 0xFFFFFFFFULL) throw InvalidArgumentError("OpenIGTLink metadata exceeds 4 GiB");
    for (const auto& m : message.metadata) {
      w.fixedString(m.key, m.key.size());
      w.fixedString(m.value, m.value.size());
    }
    std::vector<std::uint8_t> ext;
    ByteWriter e(ext);
    e.u16(static_cast<std::uint16_t>(kExtendedHeaderSize + message.extended.extra.size()));
    e.u16(static_cast<std::uint16_t>(2 + kMetadataEntryHeaderSize * message.metadata.size()));
    e.u32(static_cast<std::uint32_t>(metadata_size));
    e.u32(message.extended.message_id);
    std::copy(ext.begin(), ext.end(), out.begin() + static_cast<std::ptrdiff_t>(extended_at));
  }
  Header h = message.header;
  h.version = static_cast<std::uint16_t>(version);
  h.body_size = out.size() - kHeaderSize;
  h.crc = crc64(std::span<const std::uint8_t>(out).subspan(kHeaderSize));
  const auto header = encodeHeader(h);
  std::copy(header.begin(), header.end(), out.begin());
  return out;
}

Message decodeBody(const Header& header, std::span<const std::uint8_t> body, const DecodeOptions& options) {
  if (header.body_size > options.max_body_size) {
    throw FormatError("OpenIGTLink header: field 'body_size' is " + std::to_string(header.body_size) +
                      " bytes, over the limit of " + std::to_string(options.max_body_size));
  }
  if (body.size() != header.body_size) {
    throw FormatError("OpenIGTLink header: field 'body_size' is " + std::to_string(header.body_size) + " but " +
                      std::to_string(body.size()) + " body bytes are available");
  }
  if (options.verify_crc) {
    const std::uint64_t crc = crc64(body);
    if (crc != header.crc) {
      throw FormatError("OpenIGTLink " + header.type + " message from '" + header.device_name +
                        "': field 'crc' does not match the body (corrupted message)");
    }
  }
  Message m;
  m.header = header;
  if (header.version < 2) {
    m.content = decodeContent(header.type, body);
    return m;
  }
  ByteReader r(body, "OpenIGTLink v2 extended header");
  auto& ext = m.extended;
  ext.extended_header_size = r.u16("extended_header_size");
  ext.metadata_header_size = r.u16("metadata_header_size");
  ext.metadata_size = r.u32("metadata_size");
  ext.message_id = r.u32("message_id");
  if (ext.extended_header_size < kExtendedHeaderSize) {
    r.fail("extended_header_size", "is " + std::to_string(ext.extended_header_size) + "; at least 12 expected");
  }
  const auto extra = r.bytes(ext.extended_header_size - kExtendedHeaderSize, "extended_header_size");
  ext.extra.assign(extra.begin(), extra.end());
  const std::uint64_t trailer = std::uint64_t{ext.metadata_header_size} + ext.metadata_size;
  if (trailer > r.remaining()) {
    r.fail("metadata_header_size + metadata_size", "is " + std::to_string(trailer) + " but only " +
                                                       std::to_string(r.remaining()) +
                                                       " bytes follow the extended header");
  }
  const auto content = r.bytes(r.remaining() - trailer, "content");
  if (ext.metadata_header_size == 0) {
    if (ext.metadata_size != 0) r.fail("metadata_size", "is non-zero without a metadata header");
  } else {
    ByteReader mh(r.bytes(ext.metadata_header_size, "metadata header"), "OpenIGTLink v2 metadata header");
    const std::uint16_t count = mh.u16("index_count");
    if (std::uint64_t{ext.metadata_header_size} != 2 + std::uint64_t{count} * kMetadataEntryHeaderSize) {
      mh.fail("index_count", "is " + std::to_string(count) + " but metadata_header_size is " +
                                 std::to_string(ext.metadata_header_size) + " (expected 2 + 8 x count)");
    }
    ByteReader md(r.bytes(ext.metadata_size, "metadata"), "OpenIGTLink v2 metadata");
    m.metadata.resize(count);
    std::vector<std::uint32_t> value_sizes(count);
    std::vector<std::uint16_t> key_sizes(count);
    std::uint64_t total = 0;
    for (std::uint16_t i = 0; i < count; ++i) {
      key_sizes[i] = mh.u16("key_size");
      m.metadata[i].encoding = mh.u16("value_encoding");
      value_sizes[i] = mh.u32("value_size");
      total += std::uint64_t{key_sizes[i]} + value_sizes[i];
    }
    if (total != ext.metadata_size) {
      r.fail("metadata_size", "is " + std::to_string(ext.metadata_size) +
                                  " but the metadata header entries add up to " + std::to_string(total));
    }
    for (std::uint16_t i = 0; i < count; ++i) {
      const auto key = md.bytes(key_sizes[i], "key");
      const auto value = md.bytes(value_sizes[i], "value");
      m.metadata[i].key.assign(reinterpret_cast<const char*>(key.data()), key.size());
      m.metadata[i].value.assign(reinterpret_cast<const char*>(value.data()), value.size());
    }
  }
  m.content = decodeContent(header.type, content);
  return m;
}

Message decodeMessage(std::span<const std::uint8_t> bytes, const DecodeOptions& options) {
  const Header header = decodeHeader(bytes);
  if (header.body_size > options.max_body_size) {
    throw FormatError("OpenIGTLink header: field 'body_size' is " + std::to_string(header.body_size) +
                      " bytes, over the limit of " + std::to_string(options.max_body_size));
  }
  const std::uint64_t available = bytes.size() - kHeaderSize;
  if (header.body_size != available) {
    throw FormatError("OpenIGTLink header: field 'body_size' is " + std::to_string(header.body_size) + " but " +
                      std::to_string(available) + " bytes follow the header (truncated or concatenated message)");
  }
  return decodeBody(header, bytes.subspan(kHeaderSize), options);
}

}  // namespace mrsns::igtlink
