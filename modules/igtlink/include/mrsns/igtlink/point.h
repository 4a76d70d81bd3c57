#pragma once
// POINT content: a list of named points (fiducials, landmarks).
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace mrsns::igtlink {

/// One 136-byte element: name (<= 64), group (<= 32, e.g. "Landmark"), RGBA
/// colour, position (mm), radius (mm) and owner device name (<= 20).
struct PointElement {
  std::string name;
  std::string group;
  std::array<std::uint8_t, 4> rgba{255, 255, 255, 255};
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  double radius = 0.0;
  std::string owner;
};

struct PointContent {
  std::vector<PointElement> points;
};

inline constexpr std::size_t kPointElementSize = 136;

void encodePoint(const PointContent& content, std::vector<std::uint8_t>& out);
PointContent decodePoint(std::span<const std::uint8_t> content);

}  // namespace mrsns::igtlink
