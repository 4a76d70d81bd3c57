#include "mrsns/igtlink/tdata.h"

#include "matrix_wire.h"
#include "mrsns/igtlink/byte_order.h"
#include "mrsns/igtlink/transform.h"

namespace mrsns::igtlink {

namespace {
constexpr std::size_t kToolNameSize = 20;
constexpr std::size_t kCoordinateNameSize = 32;
}  // namespace

void encodeTrackingData(const TrackingDataContent& content, std::vector<std::uint8_t>& out) {
  for (const auto& e : content.elements) checkFixedString(e.name, kToolNameSize, "TDATA element name");
  out.reserve(out.size() + content.elements.size() * kTrackingElementSize);
  ByteWriter w(out);
  for (const auto& e : content.elements) {
    w.fixedString(e.name, kToolNameSize);
    w.u8(e.type);
    w.u8(0);  // reserved
    appendMatrix3x4(e.matrix, out);
  }
}

TrackingDataContent decodeTrackingData(std::span<const std::uint8_t> content) {
  ByteReader r(content, "TDATA content");
  if (content.size() % kTrackingElementSize != 0) {
    r.fail("elements", "span " + std::to_string(content.size()) + " bytes, not a multiple of the 70-byte element");
  }
  TrackingDataContent out;
  out.elements.reserve(content.size() / kTrackingElementSize);
  while (!r.atEnd()) {
    TrackingElement e;
    e.name = r.fixedString(kToolNameSize, "name");
    e.type = r.u8("type");
    r.u8("reserved");
    e.matrix = readMatrix3x4(r, "matrix");
    out.elements.push_back(std::move(e));
  }
  return out;
}

void encodeStartTrackingData(const StartTrackingDataContent& content, std::vector<std::uint8_t>& out) {
  checkFixedString(content.coordinate_name, kCoordinateNameSize, "STT_TDATA coordinate name");
  ByteWriter w(out);
  w.i32(content.resolution_ms);
  w.fixedString(content.coordinate_name, kCoordinateNameSize);
}

StartTrackingDataContent decodeStartTrackingData(std::span<const std::uint8_t> content) {
  ByteReader r(content, "STT_TDATA content");
  StartTrackingDataContent out;
  out.resolution_ms = r.i32("resolution");
  out.coordinate_name = r.fixedString(kCoordinateNameSize, "coordinate_name");
  r.expectEnd("coordinate_name");
  return out;
}

}  // namespace mrsns::igtlink
