#include "mrsns/igtlink/ndarray.h"

#include <string>

#include "mrsns/core/error.h"
#include "mrsns/igtlink/byte_order.h"

namespace mrsns::igtlink {

std::vector<std::uint8_t> encodeNdArray(const NdArrayFloat32& array) {
  if (array.size.empty() || array.size.size() > 255) {
    throw InvalidArgumentError("NDARRAY: 1 to 255 dimensions, not " + std::to_string(array.size.size()));
  }
  std::size_t count = 1;
  for (const auto s : array.size) {
    if (s == 0) throw InvalidArgumentError("NDARRAY: a dimension of size 0");
    count *= s;
  }
  if (count != array.values.size()) {
    throw InvalidArgumentError("NDARRAY: " + std::to_string(array.values.size()) + " values for a " +
                               std::to_string(count) + "-element array");
  }
  std::vector<std::uint8_t> out;
  out.reserve(2 + 2 * array.size.size() + 4 * count);
  ByteWriter w(out);
  w.u8(kNdArrayFloat32);
  w.u8(static_cast<std::uint8_t>(array.size.size()));
  for (const auto s : array.size) w.u16(s);
  for (const float v : array.values) w.f32(v);
  return out;
}

NdArrayFloat32 decodeNdArray(std::span<const std::uint8_t> body) {
  ByteReader r(body, "NDARRAY content");
  const std::uint8_t type = r.u8("scalar type");
  if (type != kNdArrayFloat32) r.fail("scalar type", std::to_string(type) + " is not float32 (10)");
  const std::uint8_t dim = r.u8("dimension");
  if (dim == 0) r.fail("dimension", "is 0");
  NdArrayFloat32 out;
  std::uint64_t count = 1;
  for (int d = 0; d < dim; ++d) {
    const std::uint16_t s = r.u16("size");
    if (s == 0) r.fail("size", "of a dimension is 0");
    out.size.push_back(s);
    count *= s;
  }
  r.require(4 * count, "values");
  out.values.resize(static_cast<std::size_t>(count));
  for (auto& v : out.values) v = r.f32("value");
  r.expectEnd("NDARRAY content");
  return out;
}

}  // namespace mrsns::igtlink
