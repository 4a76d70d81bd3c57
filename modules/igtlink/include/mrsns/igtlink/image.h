#pragma once
// IMAGE content: a 72-byte image header followed by the pixels of a
// (sub-)volume.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace mrsns::igtlink {

enum class ScalarType : std::uint8_t {
  kInt8 = 2,
  kUint8 = 3,
  kInt16 = 4,
  kUint16 = 5,
  kInt32 = 6,
  kUint32 = 7,
  kFloat32 = 10,
  kFloat64 = 11,
};

/// Bytes of one scalar, or 0 for a value that is not a ScalarType.
std::size_t scalarSize(std::uint8_t scalar_type);

enum class PixelEndian : std::uint8_t { kBig = 1, kLittle = 2 };
enum class ImageCoordinate : std::uint8_t { kRas = 1, kLps = 2 };

/// IMAGE. `ijk_to_xyz` holds the wire matrix: columns 0-2 are the unit
/// directions of the i, j, k axes times the spacing (mm), column 3 the
/// position sent as origin (OpenIGTLink senders put the centre of the volume
/// there). Pixels are the raw bytes of the sub-volume, i fastest, in
/// `endian` byte order; their count must be
/// subvolume_size[0]*[1]*[2]*components*scalarSize(scalar_type).
struct ImageContent {
  std::uint16_t image_header_version = 1;
  std::uint8_t components = 1;
  ScalarType scalar_type = ScalarType::kUint8;
  PixelEndian endian = PixelEndian::kBig;
  ImageCoordinate coordinate = ImageCoordinate::kRas;
  std::array<std::uint16_t, 3> size{0, 0, 0};
  Eigen::Matrix4d ijk_to_xyz = Eigen::Matrix4d::Identity();
  std::array<std::uint16_t, 3> subvolume_offset{0, 0, 0};
  std::array<std::uint16_t, 3> subvolume_size{0, 0, 0};
  std::vector<std::uint8_t> pixels;

  /// Spacing along i, j, k (mm): the column norms of ijk_to_xyz.
  [[nodiscard]] Eigen::Vector3d spacing() const;
  /// Unit direction of each axis as the columns of a 3x3 matrix.
  [[nodiscard]] Eigen::Matrix3d direction() const;
  [[nodiscard]] Eigen::Vector3d origin() const { return ijk_to_xyz.block<3, 1>(0, 3); }
  /// Sets ijk_to_xyz from spacing (mm), unit directions (columns) and origin.
  void setGeometry(const Eigen::Vector3d& spacing_mm, const Eigen::Matrix3d& direction, const Eigen::Vector3d& origin);
  /// Whole-volume helper: sets size and subvolume_size to `dims`, offset to 0
  /// and resizes pixels to match (zero-filled).
  void resizeWhole(std::array<std::uint16_t, 3> dims);
  /// Bytes the pixel array must hold for the current header fields.
  [[nodiscard]] std::uint64_t expectedPixelBytes() const;
  /// The pixels with every scalar in little-endian byte order (the order of
  /// the hosts MR-SNS runs on, and of its image and sequence files), whatever
  /// `endian` the sender used.
  [[nodiscard]] std::vector<std::uint8_t> littleEndianPixels() const;
};

inline constexpr std::size_t kImageHeaderSize = 72;

void encodeImage(const ImageContent& content, std::vector<std::uint8_t>& out);
/// Throws FormatError when a size field disagrees with the data length, the
/// sub-volume lies outside the volume, or a type/endian/coordinate code is unknown.
ImageContent decodeImage(std::span<const std::uint8_t> content);

}  // namespace mrsns::igtlink
