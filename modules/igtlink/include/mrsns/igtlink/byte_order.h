#pragma once
// Big-endian (network order) readers and writers with bounds checks. Every read
// names the field it reads, so a malformed message reports which field is wrong.
#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "mrsns/core/error.h"

namespace mrsns::igtlink {

/// Reads big-endian values from a byte span. Throws FormatError naming the
/// field when fewer bytes remain than the field needs; never reads past the end.
class ByteReader {
 public:
  /// `context` prefixes every error message (e.g. "IMAGE content").
  ByteReader(std::span<const std::uint8_t> bytes, std::string_view context) : bytes_(bytes), context_(context) {}

  [[nodiscard]] std::size_t remaining() const { return bytes_.size() - pos_; }
  [[nodiscard]] std::size_t position() const { return pos_; }
  [[nodiscard]] bool atEnd() const { return pos_ == bytes_.size(); }

  /// Throws unless at least `count` bytes remain for `field`.
  void require(std::uint64_t count, std::string_view field) const {
    if (count > remaining()) {
      throw FormatError(std::string(context_) + ": field '" + std::string(field) + "' needs " + std::to_string(count) +
                        " bytes but only " + std::to_string(remaining()) +
                        " remain (truncated or inconsistent size fields)");
    }
  }

  std::uint8_t u8(std::string_view field) {
    require(1, field);
    return bytes_[pos_++];
  }
  std::uint16_t u16(std::string_view field) { return static_cast<std::uint16_t>(uint(2, field)); }
  std::uint32_t u32(std::string_view field) { return static_cast<std::uint32_t>(uint(4, field)); }
  std::uint64_t u64(std::string_view field) { return uint(8, field); }
  std::int8_t i8(std::string_view field) { return static_cast<std::int8_t>(u8(field)); }
  std::int32_t i32(std::string_view field) { return static_cast<std::int32_t>(u32(field)); }
  std::int64_t i64(std::string_view field) { return static_cast<std::int64_t>(u64(field)); }
  float f32(std::string_view field) { return std::bit_cast<float>(u32(field)); }
  double f64(std::string_view field) { return std::bit_cast<double>(u64(field)); }

  /// The next `count` bytes as a view (no copy).
  std::span<const std::uint8_t> bytes(std::uint64_t count, std::string_view field) {
    require(count, field);
    auto out = bytes_.subspan(pos_, static_cast<std::size_t>(count));
    pos_ += static_cast<std::size_t>(count);
    return out;
  }

  /// A fixed-width, zero-padded character field: the text up to the first NUL.
  std::string fixedString(std::size_t width, std::string_view field) {
    auto raw = bytes(width, field);
    std::size_t len = 0;
    while (len < raw.size() && raw[len] != 0) ++len;
    return std::string(reinterpret_cast<const char*>(raw.data()), len);
  }

  /// A NUL-terminated string of at most `max_length` characters (the NUL is consumed).
  std::string cString(std::size_t max_length, std::string_view field) {
    const std::size_t limit = std::min(remaining(), max_length + 1);
    for (std::size_t i = 0; i < limit; ++i) {
      if (bytes_[pos_ + i] == 0) {
        std::string out(reinterpret_cast<const char*>(bytes_.data() + pos_), i);
        pos_ += i + 1;
        return out;
      }
    }
    throw FormatError(std::string(context_) + ": field '" + std::string(field) + "' has no NUL terminator within " +
                      std::to_string(max_length) + " characters");
  }

  /// Reads `count` big-endian float32 values into `out` (converted to T).
  template <typename T>
  void f32Array(T* out, std::size_t count, std::string_view field) {
    require(static_cast<std::uint64_t>(count) * 4, field);
    const std::uint8_t* p = bytes_.data() + pos_;
    for (std::size_t i = 0; i < count; ++i, p += 4) out[i] = static_cast<T>(std::bit_cast<float>(load32(p)));
    pos_ += count * 4;
  }

  /// Reads `count` big-endian uint32 values into `out`.
  void u32Array(std::uint32_t* out, std::size_t count, std::string_view field) {
    require(static_cast<std::uint64_t>(count) * 4, field);
    const std::uint8_t* p = bytes_.data() + pos_;
    for (std::size_t i = 0; i < count; ++i, p += 4) out[i] = load32(p);
    pos_ += count * 4;
  }

  /// Throws when bytes remain after the last field of `what`.
  void expectEnd(std::string_view what) const {
    if (!atEnd()) {
      throw FormatError(std::string(context_) + ": " + std::to_string(remaining()) + " unexpected bytes after " +
                        std::string(what) + " (size fields disagree with the data length)");
    }
  }

  [[noreturn]] void fail(std::string_view field, std::string_view what) const {
    throw FormatError(std::string(context_) + ": field '" + std::string(field) + "' " + std::string(what));
  }

  static std::uint32_t load32(const std::uint8_t* p) {
    return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | std::uint32_t{p[3]};
  }

 private:
  std::uint64_t uint(int width, std::string_view field) {
    require(static_cast<std::uint64_t>(width), field);
    std::uint64_t v = 0;
    for (int i = 0; i < width; ++i) v = (v << 8) | bytes_[pos_ + static_cast<std::size_t>(i)];
    pos_ += static_cast<std::size_t>(width);
    return v;
  }

  std::span<const std::uint8_t> bytes_;
  std::size_t pos_ = 0;
  std::string_view context_;
};

/// Appends big-endian values to a byte vector.
class ByteWriter {
 public:
  explicit ByteWriter(std::vector<std::uint8_t>& out) : out_(out) {}

  void u8(std::uint8_t v) { out_.push_back(v); }
  void u16(std::uint16_t v) { uint(v, 2); }
  void u32(std::uint32_t v) { uint(v, 4); }
  void u64(std::uint64_t v) { uint(v, 8); }
  void i8(std::int8_t v) { u8(static_cast<std::uint8_t>(v)); }
  void i32(std::int32_t v) { u32(static_cast<std::uint32_t>(v)); }
  void i64(std::int64_t v) { u64(static_cast<std::uint64_t>(v)); }
  void f32(float v) { u32(std::bit_cast<std::uint32_t>(v)); }
  void f64(double v) { u64(std::bit_cast<std::uint64_t>(v)); }
  void bytes(std::span<const std::uint8_t> b) { out_.insert(out_.end(), b.begin(), b.end()); }
  void zeros(std::size_t n) { out_.insert(out_.end(), n, 0); }

  /// Writes `text` into a zero-padded field of `width` bytes; the caller has
  /// checked that it fits (see checkFixedString).
  void fixedString(std::string_view text, std::size_t width) {
    const std::size_t n = std::min(text.size(), width);
    out_.insert(out_.end(), text.begin(), text.begin() + static_cast<std::ptrdiff_t>(n));
    zeros(width - n);
  }

  /// Appends `count` values as big-endian float32.
  template <typename T>
  void f32Array(const T* values, std::size_t count) {
    const std::size_t start = out_.size();
    out_.resize(start + count * 4);
    std::uint8_t* p = out_.data() + start;
    for (std::size_t i = 0; i < count; ++i, p += 4)
      store32(p, std::bit_cast<std::uint32_t>(static_cast<float>(values[i])));
  }

  /// Appends `count` values as big-endian uint32.
  void u32Array(const std::uint32_t* values, std::size_t count) {
    const std::size_t start = out_.size();
    out_.resize(start + count * 4);
    std::uint8_t* p = out_.data() + start;
    for (std::size_t i = 0; i < count; ++i, p += 4) store32(p, values[i]);
  }

  [[nodiscard]] std::size_t size() const { return out_.size(); }

  static void store32(std::uint8_t* p, std::uint32_t v) {
    p[0] = static_cast<std::uint8_t>(v >> 24);
    p[1] = static_cast<std::uint8_t>(v >> 16);
    p[2] = static_cast<std::uint8_t>(v >> 8);
    p[3] = static_cast<std::uint8_t>(v);
  }

 private:
  void uint(std::uint64_t v, int width) {
    for (int i = width - 1; i >= 0; --i) out_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }

  std::vector<std::uint8_t>& out_;
};

/// Throws InvalidArgumentError when `text` does not fit a fixed field of
/// `width` bytes (a full-width field without NUL is allowed by the protocol).
void checkFixedString(std::string_view text, std::size_t width, std::string_view field);

}  // namespace mrsns::igtlink
