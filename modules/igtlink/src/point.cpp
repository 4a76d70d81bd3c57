#include "mrsns/igtlink/point.h"

#include "mrsns/igtlink/byte_order.h"

namespace mrsns::igtlink {

namespace {
constexpr std::size_t kPointNameSize = 64;
constexpr std::size_t kPointGroupSize = 32;
constexpr std::size_t kPointOwnerSize = 20;
}  // namespace

void encodePoint(const PointContent& content, std::vector<std::uint8_t>& out) {
  for (const auto& p : content.points) {
    checkFixedString(p.name, kPointNameSize, "POINT name");
    checkFixedString(p.group, kPointGroupSize, "POINT group name");
    checkFixedString(p.owner, kPointOwnerSize, "POINT owner");
  }
  out.reserve(out.size() + content.points.size() * kPointElementSize);
  ByteWriter w(out);
  for (const auto& p : content.points) {
    w.fixedString(p.name, kPointNameSize);
    w.fixedString(p.group, kPointGroupSize);
    for (auto v : p.rgba) w.u8(v);
    for (int i = 0; i < 3; ++i) w.f32(static_cast<float>(p.position[i]));
    w.f32(static_cast<float>(p.radius));
    w.fixedString(p.owner, kPointOwnerSize);
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
    p.name = r.fixedString(kPointNameSize, "name");
    p.group = r.fixedString(kPointGroupSize, "group_name");
    for (auto& v : p.rgba) v = r.u8("rgba");
    for (int i = 0; i < 3; ++i) p.position[i] = r.f32("position");
    p.radius = r.f32("radius");
    p.owner = r.fixedString(kPointOwnerSize, "owner");
    out.points.push_back(std::move(p));
  }
  return out;
}

}  // namespace mrsns::igtlink
