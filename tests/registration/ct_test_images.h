#pragma once
// Small synthetic volumes for the CT-model tests: label maps and CT-like
// images painted from a predicate on the LPS position of each voxel centre.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <cstring>
#include <functional>

#include "mrsns/core/image.h"

namespace mrsns::test {

/// A volume of `type` with the given geometry, every voxel set from
/// value(p_lps) (rounded for integer types).
inline ImageVolume paintVolume(const std::array<int, 3>& size, const Eigen::Vector3d& spacing,
                               const Eigen::Vector3d& origin, const Eigen::Matrix3d& direction, PixelType type,
                               const std::function<double(const Eigen::Vector3d&)>& value) {
  ImageVolume image;
  image.size = size;
  image.spacing = spacing;
  image.origin = origin;
  image.direction = direction;
  image.pixel_type = type;
  image.name = "synthetic";
  image.frame = "CT";
  image.data.assign(image.byteCount(), std::byte{0});
  for (int k = 0; k < size[2]; ++k) {
    for (int j = 0; j < size[1]; ++j) {
      for (int i = 0; i < size[0]; ++i) {
        const double v = value(image.indexToPhysical(Eigen::Vector3d(i, j, k)));
        std::byte* p = image.data.data() + image.linearIndex(i, j, k) * pixelTypeSize(type);
        if (type == PixelType::UInt8) {
          const auto x = static_cast<std::uint8_t>(v);
          std::memcpy(p, &x, 1);
        } else if (type == PixelType::Int16) {
          const auto x = static_cast<std::int16_t>(v);
          std::memcpy(p, &x, 2);
        } else if (type == PixelType::Float32) {
          const auto x = static_cast<float>(v);
          std::memcpy(p, &x, 4);
        }
      }
    }
  }
  return image;
}

/// An oblique, mirrored direction matrix (determinant -1) to catch code that
/// ignores the direction or assumes a right-handed one.
inline Eigen::Matrix3d obliqueMirroredDirection() {
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.6, Eigen::Vector3d(1.0, -2.0, 0.5).normalized()).toRotationMatrix();
  return r * Eigen::Vector3d(1.0, 1.0, -1.0).asDiagonal();
}

/// Count of voxels with value(i) satisfying pred.
inline std::size_t countVoxels(const ImageVolume& image, const std::function<bool(double)>& pred) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < image.voxelCount(); ++i) n += pred(image.valueAtIndex(i)) ? 1 : 0;
  return n;
}

}  // namespace mrsns::test
