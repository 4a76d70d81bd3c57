#pragma once
// TDATA (tracking data: many named transforms in one message) and its
// STT_TDATA request (start streaming).
#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace mrsns::igtlink {

enum class TrackingInstrumentType : std::uint8_t { kTracker = 1, k6D = 2, k3D = 3, k5D = 4 };

/// One tracked tool: name (<= 20 chars), instrument type and its 3x4 matrix
/// (as TRANSFORM).
struct TrackingElement {
  std::string name;
  std::uint8_t type = static_cast<std::uint8_t>(TrackingInstrumentType::k6D);
  Eigen::Matrix4d matrix = Eigen::Matrix4d::Identity();
};

/// TDATA: a list of 70-byte elements.
struct TrackingDataContent {
  std::vector<TrackingElement> elements;
};

inline constexpr std::size_t kTrackingElementSize = 70;

void encodeTrackingData(const TrackingDataContent& content, std::vector<std::uint8_t>& out);
TrackingDataContent decodeTrackingData(std::span<const std::uint8_t> content);

/// STT_TDATA: requested minimum interval in ms (0 = as fast as possible) and
/// the coordinate system name (<= 32 chars).
struct StartTrackingDataContent {
  std::int32_t resolution_ms = 0;
  std::string coordinate_name;
};

inline constexpr std::size_t kStartTrackingDataSize = 36;

void encodeStartTrackingData(const StartTrackingDataContent& content, std::vector<std::uint8_t>& out);
StartTrackingDataContent decodeStartTrackingData(std::span<const std::uint8_t> content);

}  // namespace mrsns::igtlink
