#pragma once
// A decoded OpenIGTLink message: header, version-2 extended header and
// metadata, and the typed content.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <variant>
#include <vector>

#include "mrsns/igtlink/capability.h"
#include "mrsns/igtlink/control.h"
#include "mrsns/igtlink/header.h"
#include "mrsns/igtlink/image.h"
#include "mrsns/igtlink/point.h"
#include "mrsns/igtlink/polydata.h"
#include "mrsns/igtlink/status.h"
#include "mrsns/igtlink/string_message.h"
#include "mrsns/igtlink/tdata.h"
#include "mrsns/igtlink/transform.h"

namespace mrsns::igtlink {

/// Version-2 extended header (12 bytes at the start of the body, or more when
/// extended_header_size says so; the extra bytes are kept in `extra`). The
/// sizes are filled by the decoder; the encoder recomputes them.
struct ExtendedHeader {
  std::uint16_t extended_header_size = 12;
  std::uint16_t metadata_header_size = 0;
  std::uint32_t metadata_size = 0;
  std::uint32_t message_id = 0;
  std::vector<std::uint8_t> extra;
};

inline constexpr std::size_t kExtendedHeaderSize = 12;

/// One metadata key/value pair. `encoding` is the IANA MIBenum of the value
/// (3 = US-ASCII, 106 = UTF-8); keys are at most 65535 bytes.
struct MetadataEntry {
  std::string key;
  std::uint16_t encoding = kEncodingUsAscii;
  std::string value;

  friend bool operator==(const MetadataEntry&, const MetadataEntry&) = default;
};

using Content = std::variant<RawContent, TransformContent, PositionContent, TrackingDataContent,
                             StartTrackingDataContent, ImageContent, PolyDataContent, StringContent, StatusContent,
                             PointContent, CapabilityContent, GetRequest, StartStream, StopStream, RtsStatus>;

/// Index of alternative T in Content (compile time).
template <typename T, std::size_t I = 0>
constexpr std::size_t contentIndex() {
  if constexpr (std::is_same_v<std::variant_alternative_t<I, Content>, T>) {
    return I;
  } else {
    return contentIndex<T, I + 1>();
  }
}

/// A message. `header.type` decides how the content is laid out; the content
/// alternative must match it (see contentIndexForType), or be RawContent.
struct Message {
  Header header;
  ExtendedHeader extended;  ///< meaningful for header version 2
  std::vector<MetadataEntry> metadata;
  Content content;

  /// The metadata value of `key`, if present.
  [[nodiscard]] std::optional<std::string> metadataValue(std::string_view key) const;
  template <typename T>
  [[nodiscard]] const T* as() const {
    return std::get_if<T>(&content);
  }
};

/// Index in Content of the alternative the decoder produces for `type`
/// ("TRANSFORM" -> TransformContent, "GET_IMAGE" -> GetRequest, unknown ->
/// RawContent). Prefixed messages whose body does not have the generic shape
/// decode to RawContent too.
std::size_t contentIndexForType(std::string_view type);

/// The type name for a typed content: "TRANSFORM" for TransformContent, ...;
/// empty for RawContent and the prefixed requests (they need a type name).
std::string_view defaultTypeFor(const Content& content);

/// A message with the default type of `content` (see defaultTypeFor), the
/// device name and a timestamp in seconds since 1970 UTC (0 = unset).
Message makeMessage(std::string device_name, Content content, double timestamp_s = 0.0);
/// A message of an explicit type (needed for GET_/STT_/STP_/RTS_ and raw types).
Message makeMessage(std::string type, std::string device_name, Content content, double timestamp_s = 0.0);

}  // namespace mrsns::igtlink
