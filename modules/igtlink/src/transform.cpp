#include "mrsns/igtlink/transform.h"

#include <cmath>

#include "matrix_wire.h"
#include "mrsns/igtlink/byte_order.h"

namespace mrsns::igtlink {

void appendMatrix3x4(const Eigen::Matrix4d& matrix, std::vector<std::uint8_t>& out) {
  ByteWriter w(out);
  for (int col = 0; col < 4; ++col) {
    for (int row = 0; row < 3; ++row) w.f32(static_cast<float>(matrix(row, col)));
  }
}

Eigen::Matrix4d readMatrix3x4(ByteReader& r, std::string_view field) {
  float values[12];
  r.f32Array(values, 12, field);
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  for (int col = 0; col < 4; ++col) {
    for (int row = 0; row < 3; ++row) m(row, col) = values[col * 3 + row];
  }
  return m;
}

void encodeTransform(const TransformContent& content, std::vector<std::uint8_t>& out) {
  appendMatrix3x4(content.matrix, out);
}

TransformContent decodeTransform(std::span<const std::uint8_t> content) {
  ByteReader r(content, "TRANSFORM content");
  if (content.size() != kTransformContentSize) {
    r.fail("matrix", "is " + std::to_string(content.size()) + " bytes; TRANSFORM content must be 48 bytes");
  }
  return TransformContent{readMatrix3x4(r, "matrix")};
}

void encodePosition(const PositionContent& content, std::vector<std::uint8_t>& out) {
  const int n = content.quaternion_components;
  if (n != 0 && n != 3 && n != 4) {
    throw InvalidArgumentError("POSITION quaternion_components is " + std::to_string(n) + "; use 4, 3 or 0");
  }
  ByteWriter w(out);
  for (int i = 0; i < 3; ++i) w.f32(static_cast<float>(content.position[i]));
  const auto& q = content.orientation;
  const double xyzw[4] = {q.x(), q.y(), q.z(), q.w()};
  for (int i = 0; i < n; ++i) w.f32(static_cast<float>(xyzw[i]));
}

PositionContent decodePosition(std::span<const std::uint8_t> content) {
  ByteReader r(content, "POSITION content");
  PositionContent out;
  switch (content.size()) {
    case 28: out.quaternion_components = 4; break;
    case 24: out.quaternion_components = 3; break;
    case 12: out.quaternion_components = 0; break;
    default:
      r.fail("quaternion", "gives a content of " + std::to_string(content.size()) +
                               " bytes; POSITION content must be 28, 24 or 12 bytes");
  }
  for (int i = 0; i < 3; ++i) out.position[i] = r.f32("position");
  double xyzw[4] = {0.0, 0.0, 0.0, 1.0};
  for (int i = 0; i < out.quaternion_components; ++i) xyzw[i] = r.f32("quaternion");
  if (out.quaternion_components == 3) {
    // The three-component form implies a unit quaternion with w >= 0.
    const double s = xyzw[0] * xyzw[0] + xyzw[1] * xyzw[1] + xyzw[2] * xyzw[2];
    xyzw[3] = s < 1.0 ? std::sqrt(1.0 - s) : 0.0;
  }
  out.orientation = Eigen::Quaterniond(xyzw[3], xyzw[0], xyzw[1], xyzw[2]);
  return out;
}

}  // namespace mrsns::igtlink
