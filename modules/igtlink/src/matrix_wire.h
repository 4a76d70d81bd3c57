#pragma once
// Shared by the contents that carry a 3x4 float32 matrix.
#include <Eigen/Core>
#include <string_view>

#include "mrsns/igtlink/byte_order.h"

namespace mrsns::igtlink {

Eigen::Matrix4d readMatrix3x4(ByteReader& r, std::string_view field);

}  // namespace mrsns::igtlink
