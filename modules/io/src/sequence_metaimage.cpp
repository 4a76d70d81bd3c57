// MetaImage (.mha/.mhd) headers of PLUS sequences: "Key = Value" lines, the
// image geometry, per-frame Seq_FrameNNNN_* fields, ending with ElementDataFile.
// GCC 12 reports a false -Wrestrict on "literal" + std::string at -O3 (GCC bug 105651).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wrestrict"
#endif
#include <array>
#include <cmath>
#include <map>

#include "mrsns/core/error.h"
#include "sequence_internal.h"

namespace mrsns::io::detail {
namespace {

constexpr std::array<std::pair<std::string_view, PixelType>, 8> kMetTypes{{
    {"MET_UCHAR", PixelType::UInt8},
    {"MET_CHAR", PixelType::Int8},
    {"MET_USHORT", PixelType::UInt16},
    {"MET_SHORT", PixelType::Int16},
    {"MET_UINT", PixelType::UInt32},
    {"MET_INT", PixelType::Int32},
    {"MET_FLOAT", PixelType::Float32},
    {"MET_DOUBLE", PixelType::Float64},
}};

std::string_view metTypeName(PixelType type) {
  for (const auto& [name, t] : kMetTypes) {
    if (t == type) return name;
  }
  return "MET_UCHAR";
}

// Fields that describe the image layout: rewritten from the typed values on
// output, so they are not kept among the custom fields.
}  // namespace

bool isMetaImageStructuralField(std::string_view key) {
  static constexpr std::array<std::string_view, 20> kStructural{"ObjectType",
                                                                "NDims",
                                                                "DimSize",
                                                                "ElementType",
                                                                "ElementNumberOfChannels",
                                                                "ElementSpacing",
                                                                "Offset",
                                                                "Position",
                                                                "Origin",
                                                                "TransformMatrix",
                                                                "Rotation",
                                                                "Orientation",
                                                                "CompressedData",
                                                                "CompressedDataSize",
                                                                "BinaryData",
                                                                "ElementByteOrderMSB",
                                                                "BinaryDataByteOrderMSB",
                                                                "ElementDataFile",
                                                                "HeaderSize",
                                                                "Kinds"};
  for (const auto k : kStructural) {
    if (iequals(key, k)) return true;
  }
  return iequals(key, "UltrasoundImageOrientation");
}

namespace {

class LineContext {
 public:
  LineContext(const std::string& source, std::size_t line, std::string_view key)
      : source_(source), line_(line), key_(key) {}
  [[noreturn]] void fail(const std::string& what) const {
    throw FormatError("'" + source_ + "' line " + std::to_string(line_) + " (" + std::string(key_) + "): " + what);
  }
  std::vector<double> numbers(std::string_view value, std::size_t count) const {
    const auto parts = splitWhitespace(value);
    if (parts.size() < count) {
      fail("expected " + std::to_string(count) + " numbers, found " + std::to_string(parts.size()));
    }
    std::vector<double> out;
    for (std::size_t i = 0; i < count; ++i) {
      const auto v = parseDouble(parts[i]);
      if (!v || !std::isfinite(*v)) fail("'" + std::string(parts[i]) + "' is not a finite number");
      out.push_back(*v);
    }
    return out;
  }
  bool boolean(std::string_view value) const {
    if (iequals(value, "True") || value == "1") return true;
    if (iequals(value, "False") || value == "0") return false;
    fail("'" + std::string(value) + "' is not True or False");
  }

 private:
  const std::string& source_;
  std::size_t line_;
  std::string_view key_;
};

}  // namespace

std::optional<std::size_t> findMetaImageHeaderEnd(std::string_view text, bool at_end) {
  std::size_t pos = 0;
  while (pos < text.size()) {
    const std::size_t newline = text.find('\n', pos);
    if (newline == std::string_view::npos && !at_end) return std::nullopt;
    const std::size_t line_end = newline == std::string_view::npos ? text.size() : newline;
    const std::string_view line = trim(text.substr(pos, line_end - pos));
    const std::size_t eq = line.find('=');
    if (eq != std::string_view::npos && trim(line.substr(0, eq)) == "ElementDataFile") {
      return newline == std::string_view::npos ? text.size() : newline + 1;
    }
    pos = line_end + 1;
  }
  return std::nullopt;
}

ParsedHeader parseMetaImageHeader(std::string_view text, const std::string& source,
                                  const SequenceReadOptions& options) {
  ParsedHeader parsed;
  parsed.storage.format = SequenceFormat::MetaImage;
  TrackedSequence& seq = parsed.sequence;
  std::vector<FrameField> frame_fields;
  std::optional<int> ndims;
  std::vector<std::int64_t> dim_size;
  std::string dim_size_line, spacing_value, offset_value, matrix_value;
  std::size_t spacing_line = 0, offset_line = 0, matrix_line = 0;
  bool have_type = false, binary = true;
  std::optional<std::string> data_file;
  std::int64_t header_size = 0;

  std::size_t pos = 0, line_number = 0;
  while (pos < text.size() && !data_file) {
    std::size_t newline = text.find('\n', pos);
    if (newline == std::string_view::npos) newline = text.size();
    const std::string_view line = trim(text.substr(pos, newline - pos));
    pos = newline + 1;
    ++line_number;
    if (line.empty()) continue;
    const std::size_t eq = line.find('=');
    if (eq == std::string_view::npos) {
      throw FormatError("'" + source + "' line " + std::to_string(line_number) + ": '" +
                        std::string(line.substr(0, 60)) + "' is not a 'Key = Value' header line");
    }
    const std::string_view key = trim(line.substr(0, eq));
    const std::string_view value = trim(line.substr(eq + 1));
    const LineContext ctx(source, line_number, key);
    if (key.empty()) ctx.fail("empty field name");
    if (auto frame_key = splitFrameKey(key, source, line_number)) {
      frame_fields.push_back({frame_key->first, std::move(frame_key->second), std::string(value), line_number});
      continue;
    }
    if (key == "ObjectType") {
      if (!iequals(value, "Image")) ctx.fail("ObjectType '" + std::string(value) + "' is not Image");
    } else if (key == "NDims") {
      const auto n = parseInt(value);
      if (!n || *n < 2 || *n > 4) ctx.fail("NDims must be 2, 3 or 4, not '" + std::string(value) + "'");
      ndims = static_cast<int>(*n);
    } else if (key == "DimSize") {
      dim_size_line = std::to_string(line_number);
      for (const auto part : splitWhitespace(value)) {
        const auto n = parseInt(part);
        if (!n || *n < 0) ctx.fail("'" + std::string(part) + "' is not a size (non-negative integer)");
        dim_size.push_back(*n);
      }
    } else if (key == "ElementType") {
      have_type = false;
      for (const auto& [name, type] : kMetTypes) {
        if (value == name) {
          seq.pixel_format.scalar = type;
          have_type = true;
        }
      }
      if (!have_type) {
        throw UnsupportedError("'" + source + "' line " + std::to_string(line_number) + ": ElementType '" +
                               std::string(value) + "' is not supported (MET_UCHAR ... MET_DOUBLE)");
      }
    } else if (key == "ElementNumberOfChannels") {
      const auto n = parseInt(value);
      if (!n || *n < 1 || *n > 64) ctx.fail("ElementNumberOfChannels must be 1..64, not '" + std::string(value) + "'");
      seq.pixel_format.components = static_cast<int>(*n);
    } else if (key == "ElementSpacing") {
      spacing_value = value;
      spacing_line = line_number;
    } else if (key == "Offset" || key == "Position" || key == "Origin") {
      offset_value = value;
      offset_line = line_number;
    } else if (key == "TransformMatrix" || key == "Rotation" || key == "Orientation") {
      matrix_value = value;
      matrix_line = line_number;
    } else if (key == "CompressedData") {
      parsed.storage.compressed = ctx.boolean(value);
    } else if (key == "CompressedDataSize") {
      const auto n = parseInt(value);
      if (!n || *n < 0) ctx.fail("'" + std::string(value) + "' is not a byte count");
      parsed.storage.stored_bytes = static_cast<std::uint64_t>(*n);
    } else if (key == "BinaryData") {
      binary = ctx.boolean(value);
    } else if (key == "BinaryDataByteOrderMSB" || key == "ElementByteOrderMSB") {
      parsed.storage.big_endian = ctx.boolean(value);
    } else if (key == "HeaderSize") {
      const auto n = parseInt(value);
      if (!n || *n < 0) ctx.fail("only a non-negative HeaderSize is supported, not '" + std::string(value) + "'");
      header_size = *n;
    } else if (key == "UltrasoundImageOrientation") {
      seq.orientation = value;
    } else if (key == "ElementDataFile") {
      if (value.empty()) ctx.fail("empty data file name");
      data_file = std::string(value);
    } else if (!isMetaImageStructuralField(key)) {
      seq.custom_header_fields.emplace_back(std::string(key), std::string(value));
    }
  }
  parsed.header_bytes = std::min<std::size_t>(pos, text.size());

  const auto missing = [&](const std::string& field) {
    throw FormatError("'" + source + "': the MetaImage header has no " + field + " field: not a valid .mha/.mhd file");
  };
  if (!ndims) missing("NDims");
  if (dim_size.empty()) missing("DimSize");
  if (!have_type) missing("ElementType");
  if (!data_file) missing("ElementDataFile (it must be the last header line)");
  if (!binary) {
    throw UnsupportedError("'" + source + "': ASCII pixel data (BinaryData = False) is not supported");
  }
  if (dim_size.size() != static_cast<std::size_t>(*ndims)) {
    throw FormatError("'" + source + "' line " + dim_size_line + " (DimSize): " + std::to_string(dim_size.size()) +
                      " sizes for NDims = " + std::to_string(*ndims));
  }
  const std::string& file = *data_file;
  if (iequals(file, "LIST") || file.find('%') != std::string::npos || file.find(' ') != std::string::npos) {
    throw UnsupportedError("'" + source + "': ElementDataFile '" + file +
                           "' lists several data files; only LOCAL or one data file is supported");
  }

  // NDims 3: 2D frames along the third axis; NDims 4: 3D frames; NDims 2: a single 2D frame.
  auto& g = seq.geometry;
  const int n = *ndims;
  g.dimensions = n == 4 ? 3 : 2;
  const int spatial = g.dimensions;
  for (int i = 0; i < spatial; ++i) g.size[static_cast<std::size_t>(i)] = dim_size[static_cast<std::size_t>(i)];
  if (spatial == 2) g.size[2] = 1;
  parsed.frame_count = n == 2 ? 1 : static_cast<std::uint64_t>(dim_size.back());
  if (!spacing_value.empty()) {
    const auto v = LineContext(source, spacing_line, "ElementSpacing")
                       .numbers(spacing_value, static_cast<std::size_t>(std::min(n, 3)));
    for (std::size_t i = 0; i < v.size(); ++i) g.spacing[i] = v[i];
  }
  if (!offset_value.empty()) {
    const auto v =
        LineContext(source, offset_line, "Offset").numbers(offset_value, static_cast<std::size_t>(std::min(n, 3)));
    for (std::size_t i = 0; i < v.size(); ++i) g.origin[i] = v[i];
  }
  if (!matrix_value.empty()) {
    const auto v =
        LineContext(source, matrix_line, "TransformMatrix").numbers(matrix_value, static_cast<std::size_t>(n * n));
    const int m = std::min(n, 3);
    for (int r = 0; r < m; ++r) {
      for (int c = 0; c < m; ++c) g.direction(r, c) = v[static_cast<std::size_t>(r * n + c)];
    }
  }
  checkDeclaredSizes(seq, parsed.frame_count, source, options);

  seq.frames.resize(parsed.frame_count);
  applyFrameFields(seq, frame_fields, source, nullptr);

  if (iequals(file, "LOCAL")) {
    parsed.storage.data_file = "LOCAL";
  } else {
    parsed.storage.format = SequenceFormat::MetaImageDetached;
    parsed.storage.data_file = file;
    parsed.header_bytes = static_cast<std::uint64_t>(header_size);
  }
  return parsed;
}

std::string formatMetaImageHeader(const TrackedSequence& sequence, bool compressed,
                                  std::optional<std::uint64_t> compressed_size, const std::string& data_file,
                                  std::size_t* size_field_offset) {
  const auto& g = sequence.geometry;
  const bool volume_frames = g.dimensions == 3;
  const int n = volume_frames ? 4 : 3;
  const auto join = [](const auto& values) {
    std::string s;
    for (const auto& v : values) s += (s.empty() ? "" : " ") + formatDouble(static_cast<double>(v));
    return s;
  };
  std::string h;
  const auto line = [&h](std::string_view key, const std::string& value) {
    h += key;
    h += " = ";
    h += value;
    h += '\n';
  };
  line("ObjectType", "Image");
  line("NDims", std::to_string(n));
  for (const auto& [key, value] : sequence.custom_header_fields) line(key, value);
  line("BinaryData", "True");
  line("BinaryDataByteOrderMSB", "False");
  line("CompressedData", compressed ? "True" : "False");
  if (compressed) {
    h += "CompressedDataSize = ";
    if (size_field_offset) *size_field_offset = h.size();
    std::string size = compressed_size ? std::to_string(*compressed_size) : std::string();
    size.resize(kCompressedSizeFieldWidth, ' ');
    h += size + '\n';
  }
  std::vector<std::int64_t> dims{g.size[0], g.size[1]};
  std::vector<double> spacing{g.spacing[0], g.spacing[1], g.spacing[2]};
  std::vector<double> origin{g.origin[0], g.origin[1], g.origin[2]};
  if (volume_frames) {
    dims.push_back(g.size[2]);
    spacing.push_back(1.0);
    origin.push_back(0.0);
  }
  dims.push_back(static_cast<std::int64_t>(sequence.frames.size()));
  line("DimSize", join(dims));
  if (sequence.pixel_format.components > 1) {
    line("ElementNumberOfChannels", std::to_string(sequence.pixel_format.components));
  }
  line("ElementSpacing", join(spacing));
  line("ElementType", std::string(metTypeName(sequence.pixel_format.scalar)));
  line("Kinds", volume_frames ? "domain domain domain list" : "domain domain list");
  line("Offset", join(origin));
  std::vector<double> matrix;
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) matrix.push_back(r < 3 && c < 3 ? g.direction(r, c) : (r == c ? 1.0 : 0.0));
  }
  line("TransformMatrix", join(matrix));
  line("UltrasoundImageOrientation", sequence.orientation);
  for (std::size_t i = 0; i < sequence.frames.size(); ++i) {
    const std::string prefix = frameKeyPrefix(i, sequence.frames.size());
    forEachFrameField(sequence.frames[i],
                      [&](const std::string& key, const std::string& value) { line(prefix + key, value); });
  }
  line("ElementDataFile", data_file);
  return h;
}

}  // namespace mrsns::io::detail
