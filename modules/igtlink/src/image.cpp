#include "mrsns/igtlink/image.h"

#include <algorithm>

#include "matrix_wire.h"
#include "mrsns/igtlink/byte_order.h"
#include "mrsns/igtlink/transform.h"

namespace mrsns::igtlink {

std::size_t scalarSize(std::uint8_t scalar_type) {
  switch (scalar_type) {
    case 2:
    case 3: return 1;
    case 4:
    case 5: return 2;
    case 6:
    case 7:
    case 10: return 4;
    case 11: return 8;
    default: return 0;
  }
}

Eigen::Vector3d ImageContent::spacing() const {
  return ijk_to_xyz.block<3, 3>(0, 0).colwise().norm().transpose();
}

Eigen::Matrix3d ImageContent::direction() const {
  Eigen::Matrix3d d = ijk_to_xyz.block<3, 3>(0, 0);
  const Eigen::Vector3d s = spacing();
  for (int c = 0; c < 3; ++c) {
    if (s[c] > 0.0) d.col(c) /= s[c];
  }
  return d;
}

void ImageContent::setGeometry(const Eigen::Vector3d& spacing_mm, const Eigen::Matrix3d& dir,
                               const Eigen::Vector3d& origin_xyz) {
  ijk_to_xyz.setIdentity();
  ijk_to_xyz.block<3, 3>(0, 0) = dir * spacing_mm.asDiagonal();
  ijk_to_xyz.block<3, 1>(0, 3) = origin_xyz;
}

void ImageContent::resizeWhole(std::array<std::uint16_t, 3> dims) {
  size = dims;
  subvolume_size = dims;
  subvolume_offset = {0, 0, 0};
  pixels.assign(static_cast<std::size_t>(expectedPixelBytes()), 0);
}

std::uint64_t ImageContent::expectedPixelBytes() const {
  return std::uint64_t{subvolume_size[0]} * subvolume_size[1] * subvolume_size[2] * components *
         scalarSize(static_cast<std::uint8_t>(scalar_type));
}

std::vector<std::uint8_t> ImageContent::littleEndianPixels() const {
  std::vector<std::uint8_t> out = pixels;
  const std::size_t element = scalarSize(static_cast<std::uint8_t>(scalar_type));
  if (endian == PixelEndian::kBig && element > 1) {
    for (std::size_t i = 0; i + element <= out.size(); i += element) {
      std::reverse(out.begin() + static_cast<std::ptrdiff_t>(i),
                   out.begin() + static_cast<std::ptrdiff_t>(i + element));
    }
  }
  return out;
}

namespace {

void checkSubvolume(const std::array<std::uint16_t, 3>& size, const std::array<std::uint16_t, 3>& offset,
                    const std::array<std::uint16_t, 3>& sub, const auto& fail) {
  for (int a = 0; a < 3; ++a) {
    if (std::uint32_t{offset[a]} + sub[a] > size[a]) {
      fail("subvol_offset/subvol_size", "axis " + std::to_string(a) + ": offset " + std::to_string(offset[a]) +
                                            " + size " + std::to_string(sub[a]) + " exceeds the volume size " +
                                            std::to_string(size[a]));
    }
  }
}

}  // namespace

void encodeImage(const ImageContent& c, std::vector<std::uint8_t>& out) {
  const auto invalid = [](std::string_view field, const std::string& what) {
    throw InvalidArgumentError("IMAGE " + std::string(field) + " " + what);
  };
  if (scalarSize(static_cast<std::uint8_t>(c.scalar_type)) == 0) invalid("scalar_type", "is not a known scalar type");
  if (c.components == 0) invalid("components", "is 0; use at least 1");
  checkSubvolume(c.size, c.subvolume_offset, c.subvolume_size, invalid);
  if (c.pixels.size() != c.expectedPixelBytes()) {
    invalid("pixels", "hold " + std::to_string(c.pixels.size()) + " bytes but the sub-volume needs " +
                          std::to_string(c.expectedPixelBytes()) + ": resize them");
  }
  out.reserve(out.size() + kImageHeaderSize + c.pixels.size());
  ByteWriter w(out);
  w.u16(c.image_header_version);
  w.u8(c.components);
  w.u8(static_cast<std::uint8_t>(c.scalar_type));
  w.u8(static_cast<std::uint8_t>(c.endian));
  w.u8(static_cast<std::uint8_t>(c.coordinate));
  for (auto s : c.size) w.u16(s);
  appendMatrix3x4(c.ijk_to_xyz, out);
  for (auto s : c.subvolume_offset) w.u16(s);
  for (auto s : c.subvolume_size) w.u16(s);
  w.bytes(c.pixels);
}

ImageContent decodeImage(std::span<const std::uint8_t> content) {
  ByteReader r(content, "IMAGE content");
  const auto fail = [&r](std::string_view field, const std::string& what) { r.fail(field, what); };
  ImageContent c;
  c.image_header_version = r.u16("version");
  c.components = r.u8("num_components");
  if (c.components == 0) r.fail("num_components", "is 0");
  const std::uint8_t scalar = r.u8("scalar_type");
  if (scalarSize(scalar) == 0) r.fail("scalar_type", "is " + std::to_string(scalar) + ", not a known scalar type");
  c.scalar_type = static_cast<ScalarType>(scalar);
  const std::uint8_t endian = r.u8("endian");
  if (endian != 1 && endian != 2) r.fail("endian", "is " + std::to_string(endian) + "; expected 1 (big) or 2 (little)");
  c.endian = static_cast<PixelEndian>(endian);
  const std::uint8_t coord = r.u8("coord");
  if (coord != 1 && coord != 2) r.fail("coord", "is " + std::to_string(coord) + "; expected 1 (RAS) or 2 (LPS)");
  c.coordinate = static_cast<ImageCoordinate>(coord);
  for (auto& s : c.size) s = r.u16("size");
  c.ijk_to_xyz = readMatrix3x4(r, "matrix");
  for (auto& s : c.subvolume_offset) s = r.u16("subvol_offset");
  for (auto& s : c.subvolume_size) s = r.u16("subvol_size");
  checkSubvolume(c.size, c.subvolume_offset, c.subvolume_size, fail);
  const std::uint64_t expected = c.expectedPixelBytes();
  if (expected != r.remaining()) {
    r.fail("subvol_size", "x components x scalar size gives " + std::to_string(expected) + " pixel bytes but " +
                              std::to_string(r.remaining()) + " follow the image header");
  }
  const auto data = r.bytes(expected, "pixels");
  c.pixels.assign(data.begin(), data.end());
  return c;
}

}  // namespace mrsns::igtlink
