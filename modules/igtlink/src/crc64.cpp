#include "mrsns/igtlink/crc64.h"

#include <array>

namespace mrsns::igtlink {
namespace {

constexpr std::uint64_t kPolynomial = 0x42F0E1EBA9EA3693ULL;

constexpr std::array<std::uint64_t, 256> makeTable() {
  std::array<std::uint64_t, 256> table{};
  for (std::uint64_t i = 0; i < 256; ++i) {
    std::uint64_t crc = i << 56;
    for (int bit = 0; bit < 8; ++bit) crc = (crc & (1ULL << 63)) ? (crc << 1) ^ kPolynomial : crc << 1;
    table[i] = crc;
  }
  return table;
}

constexpr auto kTable = makeTable();
static_assert(kTable[1] == kPolynomial);

}  // namespace

std::uint64_t crc64(std::span<const std::uint8_t> data, std::uint64_t crc) {
  for (const std::uint8_t byte : data) crc = kTable[byte ^ static_cast<std::uint8_t>(crc >> 56)] ^ (crc << 8);
  return crc;
}

}  // namespace mrsns::igtlink
