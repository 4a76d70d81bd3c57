#pragma once
// TRANSFORM and POSITION contents.
#include <Eigen/Geometry>
#include <cstdint>
#include <span>
#include <vector>

namespace mrsns::igtlink {

/// TRANSFORM: a 4x4 homogeneous matrix whose top 3x4 block travels as 12
/// float32 (column by column: R11 R21 R31 R12 R22 R32 R13 R23 R33 TX TY TZ).
/// The device name says which frames it maps (PLUS style "ProbeToTracker").
struct TransformContent {
  Eigen::Matrix4d matrix = Eigen::Matrix4d::Identity();

  static TransformContent fromIsometry(const Eigen::Isometry3d& a_T_b) { return {a_T_b.matrix()}; }
  [[nodiscard]] Eigen::Isometry3d isometry() const { return Eigen::Isometry3d(matrix); }
};

inline constexpr std::size_t kTransformContentSize = 48;

void encodeTransform(const TransformContent& content, std::vector<std::uint8_t>& out);
TransformContent decodeTransform(std::span<const std::uint8_t> content);

/// Writes / reads the 12 float32 of a 3x4 matrix (shared by TRANSFORM, TDATA, IMAGE).
void appendMatrix3x4(const Eigen::Matrix4d& matrix, std::vector<std::uint8_t>& out);

/// POSITION: a position and, optionally, a quaternion. On the wire the
/// quaternion is (qx, qy, qz, w) with 4, 3 (w implied) or 0 components
/// (content sizes 28, 24 and 12 bytes).
struct PositionContent {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
  /// How many quaternion components are sent: 4, 3 or 0.
  int quaternion_components = 4;
};

void encodePosition(const PositionContent& content, std::vector<std::uint8_t>& out);
PositionContent decodePosition(std::span<const std::uint8_t> content);

}  // namespace mrsns::igtlink
