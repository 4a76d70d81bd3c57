#pragma once
// NDARRAY content (OpenIGTLink 2): a scalar type, the number of dimensions, a uint16 size per dimension and
// the elements, big-endian, last index fastest. Here float32 only: the vertex positions of a deforming mesh
// (N x 3) that the hologram stream sends instead of a whole POLYDATA.
#include <cstdint>
#include <span>
#include <vector>

namespace mrsns::igtlink {

inline constexpr std::uint8_t kNdArrayFloat32 = 10;

struct NdArrayFloat32 {
  std::vector<std::uint16_t> size;  ///< per dimension, each >= 1
  std::vector<float> values;        ///< the product of the sizes, last index fastest
};

/// The message body. Throws InvalidArgumentError for no dimension, more than 255, a size of 0, or a value
/// count that is not the product of the sizes.
std::vector<std::uint8_t> encodeNdArray(const NdArrayFloat32& array);
/// Throws FormatError (naming the field) for a truncated body, another scalar type than float32, a size of 0
/// or trailing bytes.
NdArrayFloat32 decodeNdArray(std::span<const std::uint8_t> body);

}  // namespace mrsns::igtlink
