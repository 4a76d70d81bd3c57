#include "mrsns/igtlink/message.h"

#include <type_traits>

#include "mrsns/core/error.h"

namespace mrsns::igtlink {

namespace {

bool startsWith(std::string_view s, std::string_view prefix) {
  return s.substr(0, prefix.size()) == prefix;
}

}  // namespace

std::optional<std::string> Message::metadataValue(std::string_view key) const {
  for (const auto& m : metadata) {
    if (m.key == key) return m.value;
  }
  return std::nullopt;
}

std::size_t contentIndexForType(std::string_view type) {
  if (type == "TRANSFORM") return contentIndex<TransformContent>();
  if (type == "POSITION") return contentIndex<PositionContent>();
  if (type == "TDATA") return contentIndex<TrackingDataContent>();
  if (type == "STT_TDATA") return contentIndex<StartTrackingDataContent>();
  if (type == "IMAGE") return contentIndex<ImageContent>();
  if (type == "POLYDATA") return contentIndex<PolyDataContent>();
  if (type == "STRING") return contentIndex<StringContent>();
  if (type == "STATUS") return contentIndex<StatusContent>();
  if (type == "POINT") return contentIndex<PointContent>();
  if (type == "CAPABILITY") return contentIndex<CapabilityContent>();
  if (startsWith(type, "GET_")) return contentIndex<GetRequest>();
  if (startsWith(type, "STT_")) return contentIndex<StartStream>();
  if (startsWith(type, "STP_")) return contentIndex<StopStream>();
  if (startsWith(type, "RTS_")) return contentIndex<RtsStatus>();
  return contentIndex<RawContent>();
}

std::string_view defaultTypeFor(const Content& content) {
  return std::visit(
      [](const auto& c) -> std::string_view {
        using T = std::decay_t<decltype(c)>;
        if constexpr (std::is_same_v<T, TransformContent>) return "TRANSFORM";
        if constexpr (std::is_same_v<T, PositionContent>) return "POSITION";
        if constexpr (std::is_same_v<T, TrackingDataContent>) return "TDATA";
        if constexpr (std::is_same_v<T, StartTrackingDataContent>) return "STT_TDATA";
        if constexpr (std::is_same_v<T, ImageContent>) return "IMAGE";
        if constexpr (std::is_same_v<T, PolyDataContent>) return "POLYDATA";
        if constexpr (std::is_same_v<T, StringContent>) return "STRING";
        if constexpr (std::is_same_v<T, StatusContent>) return "STATUS";
        if constexpr (std::is_same_v<T, PointContent>) return "POINT";
        if constexpr (std::is_same_v<T, CapabilityContent>) return "CAPABILITY";
        return "";
      },
      content);
}

Message makeMessage(std::string type, std::string device_name, Content content, double timestamp_s) {
  Message m;
  m.header.type = std::move(type);
  m.header.device_name = std::move(device_name);
  m.header.timestamp = timestamp_s == 0.0 ? 0 : timestampFromSeconds(timestamp_s);  // negative or NaN throws
  m.content = std::move(content);
  return m;
}

Message makeMessage(std::string device_name, Content content, double timestamp_s) {
  std::string type(defaultTypeFor(content));
  if (type.empty()) {
    throw InvalidArgumentError("makeMessage: this content has no default type; pass the type name (e.g. GET_IMAGE)");
  }
  return makeMessage(std::move(type), std::move(device_name), std::move(content), timestamp_s);
}

}  // namespace mrsns::igtlink
