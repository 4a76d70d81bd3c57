#include "mrsns/igtlink/point.h"

#include "mrsns/igtlink/byte_order.h"

namespace mrsns::igtlink {

namespace {
constexpr std::size_t kNameSize = 64;
constexpr std::size_t kGroupSize = 32;
constexpr std::size_t kOwnerSize = 20;
}  // namespace

void encodePoint(const PointContent& content, std::vector<std::uint8_t>& out) {
  for (const auto& p : content.points) {
    checkFixedString(p.name, kNameSize, "POINT name");
    checkFixedString(p.group, kGroupSize, "POINT group name");
    checkFixedString(p.owner, kOwnerSize, "POINT owner");
  }
  out.reserve(out.size() + content.points.size() * kPointElementSize);
  ByteWriter w(out);
  for (const auto& p : content.points) {
    w.fixedString(p.name, kNameSize);
    w.fixedString(p.group, kGroupSize);
    for (auto v : p.rgba) w.u8(v);
    for (int i = 0; i < 3; ++i) w.f32(static_cast<float>(p.position[i]));
    w.f32(static_cast<float>(p.radius));
    w.fixedString(p.owner, kOwnerSize);
  }
}

PointContent decodePoint(std::span<const std::uint8_t> content) {
  ByteReader r(content, "POINT content");
  if (content.size() % kPointElementSize != 0) {
    r.fail("points", "span " + std::to_string(content.size()) + " bytes, not a multiple of the 136-byte element");
  }
  PointContent out;
  out.points.reserve(content.size() / kPointElementSize);
  while (!r.atEnd()) {
    PointElement p;
    p.name = r.fixedString(kNameSize, "name");
    p.group = r.fixedString(kGroupSize, "group_name");
    for (auto& v : p.rgba) v = r.u8("rgba");
    for (int i = 0; i < 3; ++i) p.position[i] = r.f32("position");
    p.radius = r.f32("radius");
    p.owner = r.fixedString(kOwnerSize, "owner");
    out.points.push_back(std::move(p));
  }
  return out;
}

}  // namespace mrsns::igtlink
