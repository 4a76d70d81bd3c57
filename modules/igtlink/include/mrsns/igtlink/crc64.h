#pragma once
// CRC-64 of OpenIGTLink: ECMA-182 polynomial 0x42F0E1EBA9EA3693, MSB first
// (not reflected), initial value 0, no final XOR.
#include <cstdint>
#include <span>

namespace mrsns::igtlink {

/// Continues a CRC over `data`; start with crc = 0. crc64(a+b) == crc64(b, crc64(a)).
std::uint64_t crc64(std::span<const std::uint8_t> data, std::uint64_t crc = 0);

}  // namespace mrsns::igtlink
