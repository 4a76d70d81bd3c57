#pragma once
// Big-endian readers and writers shared by the UR protocol codecs (RTDE, primary/secondary). Every read names
// the field it reads, so a truncated package reports which field ran out of bytes.
#include <bit>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "mrsns/core/error.h"

namespace mrsns::robot::detail {

class BeReader {
 public:
  BeReader(std::span<const std::uint8_t> bytes, std::string_view context) : bytes_(bytes), context_(context) {}

  [[nodiscard]] std::size_t remaining() const { return bytes_.size() - pos_; }
  [[nodiscard]] std::size_t position() const { return pos_; }
  [[nodiscard]] bool atEnd() const { return pos_ == bytes_.size(); }

  void require(std::size_t count, std::string_view field) const {
    if (count > remaining()) {
      throw FormatError(context_ + ": field '" + std::string(field) + "' needs " + std::to_string(count) +
                        " bytes but only " + std::to_string(remaining()) +
                        " remain (package truncated or its size field is wrong)");
    }
  }
  std::uint8_t u8(std::string_view field) {
    require(1, field);
    return bytes_[pos_++];
  }
  std::int8_t i8(std::string_view field) { return static_cast<std::int8_t>(u8(field)); }
  std::uint16_t u16(std::string_view field) { return static_cast<std::uint16_t>(uint(2, field)); }
  std::uint32_t u32(std::string_view field) { return static_cast<std::uint32_t>(uint(4, field)); }
  std::int32_t i32(std::string_view field) { return static_cast<std::int32_t>(u32(field)); }
  std::uint64_t u64(std::string_view field) { return uint(8, field); }
  float f32(std::string_view field) { return std::bit_cast<float>(u32(field)); }
  double f64(std::string_view field) { return std::bit_cast<double>(u64(field)); }
  std::string string(std::size_t count, std::string_view field) {
    require(count, field);
    std::string out(reinterpret_cast<const char*>(bytes_.data() + pos_), count);
    pos_ += count;
    return out;
  }
  std::string rest() { return string(remaining(), "text"); }
  void skip(std::size_t count, std::string_view field) {
    require(count, field);
    pos_ += count;
  }

 private:
  std::uint64_t uint(std::size_t n, std::string_view field) {
    require(n, field);
    std::uint64_t v = 0;
    for (std::size_t i = 0; i < n; ++i) v = (v << 8) | bytes_[pos_ + i];
    pos_ += n;
    return v;
  }

  std::span<const std::uint8_t> bytes_;
  std::string context_;
  std::size_t pos_ = 0;
};

class BeWriter {
 public:
  void u8(std::uint8_t v) { out_.push_back(v); }
  void i8(std::int8_t v) { u8(static_cast<std::uint8_t>(v)); }
  void u16(std::uint16_t v) { uint(v, 2); }
  void u32(std::uint32_t v) { uint(v, 4); }
  void i32(std::int32_t v) { uint(static_cast<std::uint32_t>(v), 4); }
  void u64(std::uint64_t v) { uint(v, 8); }
  void f32(float v) { u32(std::bit_cast<std::uint32_t>(v)); }
  void f64(double v) { u64(std::bit_cast<std::uint64_t>(v)); }
  void string(std::string_view s) { out_.insert(out_.end(), s.begin(), s.end()); }
  [[nodiscard]] std::vector<std::uint8_t>& bytes() { return out_; }
  [[nodiscard]] std::size_t size() const { return out_.size(); }
  // Overwrites a big-endian value at `pos` (size fields written after the payload).
  void patch(std::size_t pos, std::uint64_t v, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) out_[pos + i] = static_cast<std::uint8_t>(v >> (8 * (n - 1 - i)));
  }

 private:
  void uint(std::uint64_t v, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) out_.push_back(static_cast<std::uint8_t>(v >> (8 * (n - 1 - i))));
  }
  std::vector<std::uint8_t> out_;
};

}  // namespace mrsns::robot::detail
