// Text helpers and per-frame fields shared by the MetaImage and NRRD
// sequence headers.
// GCC 12 reports a false -Wrestrict on "literal" + std::string at -O3 (GCC bug 105651).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wrestrict"
#endif
#include <algorithm>
#include <cctype>
#include <charconv>
#include <limits>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "sequence_internal.h"

namespace mrsns::io::detail {

std::string_view trim(std::string_view s) {
  const auto is_space = [](char c) {
    return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v';
  };
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
  return s;
}

bool iequals(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) == std::tolower(static_cast<unsigned char>(y));
         });
}

bool startsWith(std::string_view s, std::string_view prefix) {
  return s.substr(0, prefix.size()) == prefix;
}

bool endsWith(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}

std::vector<std::string_view> splitWhitespace(std::string_view s) {
  std::vector<std::string_view> parts;
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
    const std::size_t start = i;
    while (i < s.size() && !std::isspace(static_cast<unsigned char>(s[i]))) ++i;
    if (i > start) parts.push_back(s.substr(start, i - start));
  }
  return parts;
}

std::optional<double> parseDouble(std::string_view s) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  if (s.empty()) return std::nullopt;
  double value = 0.0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  if (ec != std::errc() || end != s.data() + s.size()) return std::nullopt;
  return value;
}

std::optional<std::int64_t> parseInt(std::string_view s) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  if (s.empty()) return std::nullopt;
  std::int64_t value = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  if (ec != std::errc() || end != s.data() + s.size()) return std::nullopt;
  return value;
}

std::string formatDouble(double value) {
  char buffer[64];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, value);
  if (ec != std::errc()) return "nan";
  return std::string(buffer, end);
}

std::optional<std::pair<std::uint64_t, std::string>> splitFrameKey(std::string_view key, const std::string& source,
                                                                   std::size_t line) {
  constexpr std::string_view kPrefix = "Seq_Frame";
  if (!startsWith(key, kPrefix)) return std::nullopt;
  std::string_view rest = key.substr(kPrefix.size());
  std::size_t digits = 0;
  while (digits < rest.size() && std::isdigit(static_cast<unsigned char>(rest[digits]))) ++digits;
  if (digits == 0 || digits > 12 || digits >= rest.size() || rest[digits] != '_' || digits + 1 == rest.size()) {
    throw FormatError("'" + source + "' line " + std::to_string(line) + ": malformed per-frame field '" +
                      std::string(key) + "' (expected Seq_Frame<number>_<name>)");
  }
  const auto index = parseInt(rest.substr(0, digits));
  return std::make_pair(static_cast<std::uint64_t>(*index), std::string(rest.substr(digits + 1)));
}

namespace {

TransformStatus parseStatus(const std::string& value, const std::string& where) {
  if (iequals(value, "OK")) return TransformStatus::Ok;
  if (iequals(value, "INVALID")) return TransformStatus::Invalid;
  if (iequals(value, "MISSING")) return TransformStatus::Missing;
  // PLUS itself reads anything but OK as invalid; say so rather than fail.
  logger()->warn("{}: unknown transform status '{}', read as INVALID", where, value);
  return TransformStatus::Invalid;
}

Eigen::Matrix4d parseMatrix(const std::string& value, const std::string& where) {
  const auto parts = splitWhitespace(value);
  if (parts.size() != 16) {
    throw FormatError(where + ": a transform needs 16 numbers (4x4 row-major), found " + std::to_string(parts.size()));
  }
  Eigen::Matrix4d m;
  for (int i = 0; i < 16; ++i) {
    const auto v = parseDouble(parts[static_cast<std::size_t>(i)]);
    if (!v) {
      throw FormatError(where + ": '" + std::string(parts[static_cast<std::size_t>(i)]) +
                        "' is not a number (element " + std::to_string(i) + " of the 4x4 matrix)");
    }
    m(i / 4, i % 4) = *v;
  }
  return m;
}

}  // namespace

void applyFrameFields(TrackedSequence& sequence, const std::vector<FrameField>& fields, const std::string& source,
                      std::vector<bool>* has_timestamp) {
  if (has_timestamp) has_timestamp->assign(sequence.frames.size(), false);
  // Status fields may come before their matrix; remember which matrices were seen.
  std::vector<std::vector<std::string>> status_only(sequence.frames.size());
  for (const auto& field : fields) {
    const std::string where = "'" + source + "' line " + std::to_string(field.line) + " (Seq_Frame" +
                              std::to_string(field.frame) + "_" + field.name + ")";
    if (field.frame >= sequence.frames.size()) {
      throw FormatError(where + ": frame " + std::to_string(field.frame) + " is beyond the " +
                        std::to_string(sequence.frames.size()) +
                        " frames the image size declares: the header is inconsistent");
    }
    TrackedFrame& frame = sequence.frames[field.frame];
    const std::string& name = field.name;
    if (name == "Timestamp") {
      const auto t = parseDouble(field.value);
      if (!t) throw FormatError(where + ": timestamp '" + field.value + "' is not a number");
      frame.timestamp = *t;
      if (has_timestamp) (*has_timestamp)[field.frame] = true;
    } else if (name == "ImageStatus") {
      frame.image_status = field.value;
    } else if (name.size() > 15 && endsWith(name, "TransformStatus")) {
      const std::string transform = name.substr(0, name.size() - 15);
      auto [it, inserted] = frame.transforms.try_emplace(transform);
      it->second.status = parseStatus(field.value, where);
      if (inserted) status_only[field.frame].push_back(transform);
    } else if (name.size() > 9 && endsWith(name, "Transform")) {
      const std::string transform = name.substr(0, name.size() - 9);
      frame.transforms[transform].matrix = parseMatrix(field.value, where);
      auto& pending = status_only[field.frame];
      pending.erase(std::remove(pending.begin(), pending.end(), transform), pending.end());
    } else {
      frame.custom_fields[name] = field.value;
    }
  }
  for (std::size_t i = 0; i < status_only.size(); ++i) {
    for (const auto& transform : status_only[i]) {
      if (sequence.frames[i].transforms[transform].status == TransformStatus::Ok) {
        throw FormatError("'" + source + "': frame " + std::to_string(i) + " marks " + transform + " OK but has no " +
                          transform + "Transform matrix");
      }
    }
  }
}

void forEachFrameField(const TrackedFrame& frame,
                       const std::function<void(const std::string&, const std::string&)>& emit) {
  for (const auto& [name, transform] : frame.transforms) {
    std::string matrix;
    for (int i = 0; i < 16; ++i) {
      if (i > 0) matrix += ' ';
      matrix += formatDouble(transform.matrix(i / 4, i % 4));
    }
    emit(name + "Transform", matrix);
    emit(name + "TransformStatus", std::string(toString(transform.status)));
  }
  for (const auto& [name, value] : frame.custom_fields) emit(name, value);
  emit("Timestamp", formatDouble(frame.timestamp));
  emit("ImageStatus", frame.image_status);
}

std::string frameKeyPrefix(std::size_t index, std::size_t frame_count) {
  std::size_t width = 4;
  for (std::size_t n = frame_count > 0 ? frame_count - 1 : 0; n >= 10000; n /= 10) ++width;
  std::string digits = std::to_string(index);
  if (digits.size() < width) digits.insert(0, width - digits.size(), '0');
  return "Seq_Frame" + digits + "_";
}

void checkDeclaredSizes(const TrackedSequence& sequence, std::uint64_t frame_count, const std::string& source,
                        const SequenceReadOptions& options) {
  const auto& g = sequence.geometry;
  for (int i = 0; i < 3 && !sequence.trackingOnly(); ++i) {
    if (g.size[static_cast<std::size_t>(i)] <= 0 && frame_count > 0) {
      throw FormatError("'" + source + "': image size " + std::to_string(g.size[0]) + "x" + std::to_string(g.size[1]) +
                        "x" + std::to_string(g.size[2]) + " has an empty axis");
    }
  }
  if (frame_count > options.max_frames) {
    throw FormatError("'" + source + "': header declares " + std::to_string(frame_count) + " frames, more than the " +
                      std::to_string(options.max_frames) + " allowed (raise SequenceReadOptions::max_frames if real)");
  }
  // Saturating products so a lying header cannot overflow the check.
  const auto mul = [](std::uint64_t a, std::uint64_t b) {
    std::uint64_t r = 0;
    return __builtin_mul_overflow(a, b, &r) ? std::numeric_limits<std::uint64_t>::max() : r;
  };
  std::uint64_t frame_bytes = sequence.pixel_format.bytesPerPixel();
  for (const auto s : g.size) frame_bytes = mul(frame_bytes, static_cast<std::uint64_t>(s > 0 ? s : 0));
  if (frame_bytes > options.max_frame_bytes) {
    throw FormatError("'" + source + "': one frame would take " + std::to_string(frame_bytes) +
                      " bytes (image size x pixel size), more than the " + std::to_string(options.max_frame_bytes) +
                      " allowed: the header is wrong or the limit too low");
  }
  const std::uint64_t total = mul(frame_bytes, frame_count);
  if (total > options.max_total_bytes) {
    throw FormatError("'" + source + "': " + std::to_string(frame_count) + " frames would take " +
                      std::to_string(total) + " bytes, more than the " + std::to_string(options.max_total_bytes) +
                      " allowed: the header is wrong or the limit too low");
  }
}

void checkWritable(const TrackedSequence& sequence, const std::string& target) {
  const auto fail = [&](const std::string& what) {
    throw InvalidArgumentError("cannot write sequence to '" + target + "': " + what);
  };
  // '=' ends a MetaImage key and ": " / ":=" a NRRD one; line breaks end the line.
  const auto check_field = [&](std::string_view key, std::string_view value) {
    if (key.empty() || trim(key) != key || key.find_first_of("=\r\n") != std::string_view::npos ||
        key.find(": ") != std::string_view::npos || value.find_first_of("\r\n") != std::string_view::npos) {
      fail("field '" + std::string(key) +
           "' cannot be a header line (names need no '=', ': ', line breaks or outer spaces; values no line breaks)");
    }
  };

  for (const auto& [key, value] : sequence.custom_header_fields) {
    check_field(key, value);
    if (isMetaImageStructuralField(key) || isNrrdStructuralField(key) || startsWith(key, "Seq_Frame")) {
      fail("custom field '" + key + "' has the name of a field the writer generates; rename it");
    }
  }
  if (sequence.orientation.empty() || sequence.orientation.find_first_of(" \r\n") != std::string::npos) {
    fail("ultrasound image orientation '" + sequence.orientation + "' must be one word such as MF or MFA");
  }
  const auto& g = sequence.geometry;
  if (g.dimensions != 2 && g.dimensions != 3) fail("frames must be 2D or 3D");
  if (!sequence.trackingOnly() &&
      (g.size[0] <= 0 || g.size[1] <= 0 || g.size[2] <= 0 || (g.dimensions == 2 && g.size[2] != 1))) {
    fail("image size " + std::to_string(g.size[0]) + "x" + std::to_string(g.size[1]) + "x" + std::to_string(g.size[2]) +
         " is empty or not 2D");
  }
  if (sequence.pixel_format.components < 1) fail("pixels need at least one component");
  const std::size_t bytes = sequence.frameBytes();
  for (std::size_t i = 0; i < sequence.frames.size(); ++i) {
    const auto& frame = sequence.frames[i];
    if (frame.pixels.size() != bytes) {
      fail("frame " + std::to_string(i) + " holds " + std::to_string(frame.pixels.size()) + " pixel bytes, not " +
           std::to_string(bytes) + " (read it with pixels, or fix the geometry)");
    }
    for (const auto& [name, transform] : frame.transforms) {
      check_field(name + "Transform", "");
    }
    for (const auto& [key, value] : frame.custom_fields) {
      check_field(key, value);
    }
    check_field("ImageStatus", frame.image_status);
  }
}

}  // namespace mrsns::io::detail
