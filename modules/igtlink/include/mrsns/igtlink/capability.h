#pragma once
// CAPABILITY content: the message types a peer supports, 12 bytes each.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace mrsns::igtlink {

struct CapabilityContent {
  std::vector<std::string> types;  ///< each at most 12 characters
};

void encodeCapability(const CapabilityContent& content, std::vector<std::uint8_t>& out);
CapabilityContent decodeCapability(std::span<const std::uint8_t> content);

}  // namespace mrsns::igtlink
