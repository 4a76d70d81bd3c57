#include "mrsns/igtlink/crc64.h"

#include <array>

namespace mrsns::igtlink {
namespace {

constexpr std::uint64_t kPolynomial = 0x42F0E1EBA9EA3693ULL;

// Slicing-by-8: table[k][b] is the CRC contribution of byte b followed by k
// zero bytes, so eight input bytes are folded in per step (about 4x the
// byte-wise loop on image-sized bodies).
using Tables = std::array<std::array<std::uint64_t, 256>, 8>;

constexpr Tables makeTables() {
  Tables t{};
  for (std::uint64_t i = 0; i < 256; ++i) {
    std::uint64_t crc = i << 56;
    for (int bit = 0; bit < 8; ++bit) crc = (crc & (1ULL << 63)) ? (crc << 1) ^ kPolynomial : crc << 1;
    t[0][i] = crc;
  }
  for (std::size_t k = 1; k < 8; ++k) {
    for (std::size_t i = 0; i < 256; ++i) t[k][i] = (t[k - 1][i] << 8) ^ t[0][t[k - 1][i] >> 56];
  }
  return t;
}

constexpr Tables kTables = makeTables();
static_assert(kTables[0][1] == kPolynomial);

}  // namespace

std::uint64_t crc64(std::span<const std::uint8_t> data, std::uint64_t crc) {
  const std::uint8_t* p = data.data();
  std::size_t n = data.size();
  while (n >= 8) {
    std::uint64_t word = 0;
    for (int i = 0; i < 8; ++i) word = (word << 8) | p[i];
    crc ^= word;
    crc = kTables[7][crc >> 56] ^ kTables[6][(crc >> 48) & 0xFF] ^ kTables[5][(crc >> 40) & 0xFF] ^
          kTables[4][(crc >> 32) & 0xFF] ^ kTables[3][(crc >> 24) & 0xFF] ^ kTables[2][(crc >> 16) & 0xFF] ^
          kTables[1][(crc >> 8) & 0xFF] ^ kTables[0][crc & 0xFF];
    p += 8;
    n -= 8;
  }
  for (; n > 0; --n, ++p) crc = kTables[0][*p ^ static_cast<std::uint8_t>(crc >> 56)] ^ (crc << 8);
  return crc;
}

}  // namespace mrsns::igtlink
