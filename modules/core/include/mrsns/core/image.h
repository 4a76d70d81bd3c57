#pragma once
// A scalar volume with its geometry, in the patient coordinate system of
// DICOM and ITK: LPS (x towards the patient's Left, y Posterior, z Superior),
// millimetres. Readers convert every format (NIfTI's RAS, NRRD's declared
// space) to LPS, so code never has to ask which convention a volume uses.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace mrsns {

/// Storage type of one voxel.
enum class PixelType { UInt8, Int8, UInt16, Int16, UInt32, Int32, Float32, Float64 };

/// Bytes of one voxel of `type`.
[[nodiscard]] inline std::size_t pixelTypeSize(PixelType type) {
  switch (type) {
    case PixelType::UInt8:
    case PixelType::Int8: return 1;
    case PixelType::UInt16:
    case PixelType::Int16: return 2;
    case PixelType::UInt32:
    case PixelType::Int32:
    case PixelType::Float32: return 4;
    case PixelType::Float64: return 8;
  }
  return 1;
}

/// Name used in reports and files: "uint8", "int16", "float32", ...
[[nodiscard]] inline std::string pixelTypeName(PixelType type) {
  switch (type) {
    case PixelType::UInt8: return "uint8";
    case PixelType::Int8: return "int8";
    case PixelType::UInt16: return "uint16";
    case PixelType::Int16: return "int16";
    case PixelType::UInt32: return "uint32";
    case PixelType::Int32: return "int32";
    case PixelType::Float32: return "float32";
    case PixelType::Float64: return "float64";
  }
  return "unknown";
}

[[nodiscard]] inline bool isIntegerPixelType(PixelType type) {
  return type != PixelType::Float32 && type != PixelType::Float64;
}

/// A 3D scalar image. Voxel (i, j, k) is stored at byte offset
/// ((k * size[1] + j) * size[0] + i) * pixelTypeSize(pixel_type) (i fastest),
/// and its centre lies at
///   p_lps = origin + direction * diag(spacing) * (i, j, k)^T.
/// `direction` columns are the unit directions of the i, j, k axes in LPS;
/// `origin` is the centre of voxel (0, 0, 0) in LPS mm. `frame` names the
/// coordinate frame (e.g. "CT"), empty when unknown.
struct ImageVolume {
  std::array<int, 3> size{0, 0, 0};
  Eigen::Vector3d spacing = Eigen::Vector3d::Ones();
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Matrix3d direction = Eigen::Matrix3d::Identity();
  PixelType pixel_type = PixelType::UInt8;
  std::vector<std::byte> data;
  std::string name;
  std::string frame;

  [[nodiscard]] std::size_t voxelCount() const {
    return static_cast<std::size_t>(size[0]) * static_cast<std::size_t>(size[1]) * static_cast<std::size_t>(size[2]);
  }
  [[nodiscard]] std::size_t byteCount() const { return voxelCount() * pixelTypeSize(pixel_type); }
  [[nodiscard]] bool empty() const { return voxelCount() == 0; }

  /// Linear index of voxel (i, j, k); no bounds check.
  [[nodiscard]] std::size_t linearIndex(int i, int j, int k) const {
    return (static_cast<std::size_t>(k) * static_cast<std::size_t>(size[1]) + static_cast<std::size_t>(j)) *
               static_cast<std::size_t>(size[0]) +
           static_cast<std::size_t>(i);
  }

  /// Value of voxel number `index` (linear) converted to double; no bounds check.
  [[nodiscard]] double valueAtIndex(std::size_t index) const {
    const std::byte* p = data.data() + index * pixelTypeSize(pixel_type);
    switch (pixel_type) {
      case PixelType::UInt8: return read<std::uint8_t>(p);
      case PixelType::Int8: return read<std::int8_t>(p);
      case PixelType::UInt16: return read<std::uint16_t>(p);
      case PixelType::Int16: return read<std::int16_t>(p);
      case PixelType::UInt32: return read<std::uint32_t>(p);
      case PixelType::Int32: return read<std::int32_t>(p);
      case PixelType::Float32: return read<float>(p);
      case PixelType::Float64: return read<double>(p);
    }
    return 0.0;
  }

  /// Value of voxel (i, j, k) as double; no bounds check.
  [[nodiscard]] double value(int i, int j, int k) const { return valueAtIndex(linearIndex(i, j, k)); }

  [[nodiscard]] bool contains(int i, int j, int k) const {
    return i >= 0 && j >= 0 && k >= 0 && i < size[0] && j < size[1] && k < size[2];
  }

  /// 4x4 homogeneous matrix mapping continuous voxel indices (i, j, k, 1) to LPS mm.
  [[nodiscard]] Eigen::Matrix4d ijkToLps() const {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = direction * spacing.asDiagonal();
    m.topRightCorner<3, 1>() = origin;
    return m;
  }

  /// LPS position (mm) of continuous index (i, j, k).
  [[nodiscard]] Eigen::Vector3d indexToPhysical(const Eigen::Vector3d& ijk) const {
    return origin + direction * spacing.asDiagonal() * ijk;
  }

  /// Continuous index of an LPS position (mm); the inverse of indexToPhysical.
  [[nodiscard]] Eigen::Vector3d physicalToIndex(const Eigen::Vector3d& p_lps) const {
    const Eigen::Matrix3d m = direction * spacing.asDiagonal();
    return m.inverse() * (p_lps - origin);
  }

  /// Extent of the voxel grid in mm along i, j, k (size * spacing).
  [[nodiscard]] Eigen::Vector3d physicalExtent() const {
    return Eigen::Vector3d(size[0] * spacing.x(), size[1] * spacing.y(), size[2] * spacing.z());
  }

  /// Volume of one voxel in mm^3.
  [[nodiscard]] double voxelVolume() const { return spacing.prod(); }

 private:
  template <typename T>
  static double read(const std::byte* p) {
    T v;
    std::memcpy(&v, p, sizeof v);
    return static_cast<double>(v);
  }
};

/// 3x3 matrix taking RAS coordinates to LPS and back (its own inverse).
[[nodiscard]] inline Eigen::Matrix3d rasToLps() {
  return Eigen::Vector3d(-1.0, -1.0, 1.0).asDiagonal();
}

}  // namespace mrsns
