// NRRD sequence headers in Slicer's .seq.nrrd layout: spatial axes first, the
// frame ("list") axis last, per-frame index values and PLUS-style
// Seq_FrameNNNN_* key/value pairs ("key:=value").
// GCC 12 reports a false -Wrestrict on "literal" + std::string at -O3 (GCC bug 105651).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wrestrict"
#endif
#include <array>
#include <cmath>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "sequence_internal.h"

namespace mrsns::io::detail {
namespace {

struct NrrdTypeName {
  std::string_view name;
  PixelType type;
};

constexpr std::array<NrrdTypeName, 30> kNrrdTypes{{
    {"uchar", PixelType::UInt8},
    {"unsigned char", PixelType::UInt8},
    {"uint8", PixelType::UInt8},
    {"uint8_t", PixelType::UInt8},
    {"signed char", PixelType::Int8},
    {"int8", PixelType::Int8},
    {"int8_t", PixelType::Int8},
    {"short", PixelType::Int16},
    {"short int", PixelType::Int16},
    {"signed short", PixelType::Int16},
    {"signed short int", PixelType::Int16},
    {"int16", PixelType::Int16},
    {"int16_t", PixelType::Int16},
    {"ushort", PixelType::UInt16},
    {"unsigned short", PixelType::UInt16},
    {"unsigned short int", PixelType::UInt16},
    {"uint16", PixelType::UInt16},
    {"uint16_t", PixelType::UInt16},
    {"int", PixelType::Int32},
    {"signed int", PixelType::Int32},
    {"int32", PixelType::Int32},
    {"int32_t", PixelType::Int32},
    {"uint", PixelType::UInt32},
    {"unsigned int", PixelType::UInt32},
    {"uint32", PixelType::UInt32},
    {"uint32_t", PixelType::UInt32},
    {"float", PixelType::Float32},
    {"double", PixelType::Float64},
    {"float32", PixelType::Float32},
    {"float64", PixelType::Float64},
}};

std::string_view nrrdTypeName(PixelType type) {
  switch (type) {
    case PixelType::UInt8: return "unsigned char";
    case PixelType::Int8: return "signed char";
    case PixelType::UInt16: return "unsigned short";
    case PixelType::Int16: return "short";
    case PixelType::UInt32: return "unsigned int";
    case PixelType::Int32: return "int";
    case PixelType::Float32: return "float";
    case PixelType::Float64: return "double";
  }
  return "unsigned char";
}

bool isComponentKind(std::string_view kind) {
  return kind == "vector" || kind == "RGB-color" || kind == "RGBA-color" || kind == "3-vector" || kind == "4-vector" ||
         kind == "3-color" || kind == "4-color" || kind == "covariant-vector" || kind == "normal" || kind == "complex";
}

// "(1,0,0)" -> {1,0,0}; "none" -> empty.
std::vector<double> parseVector(std::string_view text, const std::function<void(const std::string&)>& fail) {
  text = trim(text);
  if (text == "none") return {};
  if (text.size() < 2 || text.front() != '(' || text.back() != ')')
    fail("'" + std::string(text) + "' is not a (x,y,z) vector");
  std::vector<double> out;
  std::string_view inner = text.substr(1, text.size() - 2);
  while (true) {
    const std::size_t comma = inner.find(',');
    const auto v = parseDouble(inner.substr(0, comma));
    if (!v || !std::isfinite(*v)) fail("'" + std::string(text) + "' holds a non-number");
    out.push_back(*v);
    if (comma == std::string_view::npos) break;
    inner.remove_prefix(comma + 1);
  }
  return out;
}

// Splits "(a,b) none (c,d)" into its vectors and "none"s.
std::vector<std::string_view> splitVectors(std::string_view text) {
  std::vector<std::string_view> parts;
  std::size_t i = 0;
  while (i < text.size()) {
    while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    if (i >= text.size()) break;
    const std::size_t start = i;
    if (text[i] == '(') {
      const std::size_t close = text.find(')', i);
      i = close == std::string_view::npos ? text.size() : close + 1;
    } else {
      while (i < text.size() && !std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    }
    parts.push_back(text.substr(start, i - start));
  }
  return parts;
}

}  // namespace

bool isNrrdStructuralField(std::string_view key) {
  return key == "DataNodeClassName" || key == "DataNodeName" ||
         (startsWith(key, "axis ") &&
          (key.find(" index ") != std::string_view::npos || key.find(" item ") != std::string_view::npos));
}

bool isNrrdText(std::string_view text) {
  return startsWith(text, "NRRD000");
}

std::optional<std::size_t> findNrrdHeaderEnd(std::string_view text, bool at_end) {
  std::size_t pos = 0;
  while (pos < text.size()) {
    const std::size_t newline = text.find('\n', pos);
    if (newline == std::string_view::npos) break;
    if (trim(text.substr(pos, newline - pos)).empty() && pos > 0) return newline + 1;
    pos = newline + 1;
  }
  if (at_end) return text.size();
  return std::nullopt;
}

ParsedHeader parseNrrdHeader(std::string_view text, const std::string& source, const SequenceReadOptions& options) {
  ParsedHeader parsed;
  parsed.storage.format = SequenceFormat::Nrrd;
  TrackedSequence& seq = parsed.sequence;
  if (!isNrrdText(text)) throw FormatError("'" + source + "' does not start with the NRRD magic 'NRRD000x'");
  std::vector<FrameField> frame_fields;
  std::optional<int> dimension;
  std::vector<std::int64_t> sizes;
  std::vector<std::string_view> kinds, directions;
  std::vector<double> spacings, origin, index_values;
  bool have_type = false, ras = false;
  std::size_t index_values_line = 0;
  std::optional<std::string> data_file;

  std::size_t pos = text.find('\n');
  pos = pos == std::string_view::npos ? text.size() : pos + 1;
  std::size_t line_number = 1;
  while (pos < text.size()) {
    std::size_t newline = text.find('\n', pos);
    if (newline == std::string_view::npos) newline = text.size();
    const std::string_view line = trim(text.substr(pos, newline - pos));
    pos = newline + 1;
    ++line_number;
    if (line.empty()) break;
    if (line.front() == '#') continue;
    const auto fail = [&](const std::string& what) {
      throw FormatError("'" + source + "' line " + std::to_string(line_number) + ": " + what);
    };
    const std::size_t custom = line.find(":=");
    const std::size_t colon = line.find(": ");
    if (custom != std::string_view::npos && (colon == std::string_view::npos || custom < colon)) {
      const std::string_view key = trim(line.substr(0, custom));
      const std::string_view value = trim(line.substr(custom + 2));
      if (auto frame_key = splitFrameKey(key, source, line_number)) {
        frame_fields.push_back({frame_key->first, std::move(frame_key->second), std::string(value), line_number});
      } else if (startsWith(key, "axis ") && key.find(" item ") != std::string_view::npos) {
        // Slicer's per-item attributes: "axis 3 item 12 Name:=value".
        const auto parts = splitWhitespace(key);
        const auto item = parts.size() == 5 ? parseInt(parts[3]) : std::nullopt;
        if (!item || *item < 0) fail("malformed per-item field '" + std::string(key) + "'");
        frame_fields.push_back(
            {static_cast<std::uint64_t>(*item), std::string(parts[4]), std::string(value), line_number});
      } else if (startsWith(key, "axis ") && endsWith(key, " index values")) {
        index_values.clear();
        index_values_line = line_number;
        for (const auto part : splitWhitespace(value)) {
          const auto v = parseDouble(part);
          if (!v) {
            index_values.clear();  // a text index (not times): keep the frames' own timestamps
            break;
          }
          index_values.push_back(*v);
        }
      } else if (key == "UltrasoundImageOrientation" || key == "ultrasound image orientation") {
        seq.orientation = value;
      } else if (!isNrrdStructuralField(key)) {
        if (key.empty()) fail("empty field name");
        seq.custom_header_fields.emplace_back(std::string(key), std::string(value));
      }
      continue;
    }
    const std::size_t sep = line.find(':');
    if (sep == std::string_view::npos) fail("'" + std::string(line.substr(0, 60)) + "' is not a 'field: value' line");
    const std::string_view field = trim(line.substr(0, sep));
    const std::string_view value = trim(line.substr(sep + 1));
    if (field == "type") {
      for (const auto& t : kNrrdTypes) {
        if (value == t.name) {
          seq.pixel_format.scalar = t.type;
          have_type = true;
        }
      }
      if (!have_type) {
        throw UnsupportedError("'" + source + "' line " + std::to_string(line_number) + ": NRRD type '" +
                               std::string(value) + "' is not supported (8 to 32-bit integers, float, double)");
      }
    } else if (field == "dimension") {
      const auto n = parseInt(value);
      if (!n || *n < 3 || *n > 5) fail("a sequence needs dimension 3, 4 or 5, not '" + std::string(value) + "'");
      dimension = static_cast<int>(*n);
    } else if (field == "sizes") {
      for (const auto part : splitWhitespace(value)) {
        const auto n = parseInt(part);
        if (!n || *n < 0) fail("'" + std::string(part) + "' is not a size");
        sizes.push_back(*n);
      }
    } else if (field == "kinds") {
      kinds = splitWhitespace(value);
    } else if (field == "space directions") {
      directions = splitVectors(value);
    } else if (field == "spacings") {
      for (const auto part : splitWhitespace(value)) spacings.push_back(parseDouble(part).value_or(NAN));
    } else if (field == "space origin") {
      origin = parseVector(value, fail);
    } else if (field == "space") {
      ras = value == "right-anterior-superior" || value == "RAS";
    } else if (field == "endian") {
      parsed.storage.big_endian = value == "big";
    } else if (field == "encoding") {
      if (value == "gzip" || value == "gz") {
        parsed.storage.compressed = true;
      } else if (value != "raw") {
        throw UnsupportedError("'" + source + "' line " + std::to_string(line_number) + ": NRRD encoding '" +
                               std::string(value) + "' is not supported (raw, gzip)");
      }
    } else if (field == "data file" || field == "datafile") {
      data_file = std::string(value);
    } else if (field == "byte skip" || field == "line skip") {
      if (parseInt(value).value_or(-1) != 0) {
        throw UnsupportedError("'" + source + "': NRRD '" + std::string(field) + "' other than 0 is not supported");
      }
    }
    // Other standard fields (content, labels, measurement frame, units...) do not affect the frames.
  }
  parsed.header_bytes = std::min<std::size_t>(pos, text.size());

  if (!have_type) throw FormatError("'" + source + "': the NRRD header has no 'type' field");
  if (!dimension) throw FormatError("'" + source + "': the NRRD header has no 'dimension' field");
  const auto dim = static_cast<std::size_t>(*dimension);
  if (sizes.size() != dim) {
    throw FormatError("'" + source + "': 'sizes' has " + std::to_string(sizes.size()) + " values for dimension " +
                      std::to_string(dim));
  }
  if (!kinds.empty() && kinds.size() != dim) {
    throw FormatError("'" + source + "': 'kinds' has " + std::to_string(kinds.size()) + " values for dimension " +
                      std::to_string(dim));
  }
  if (!kinds.empty() && kinds.front() == "list" && kinds.back() != "list") {
    throw UnsupportedError("'" + source +
                           "': the frame (list) axis is the first axis, so frames are interleaved voxel by voxel; "
                           "re-save it from Slicer (list axis last) to read it here");
  }
  const bool has_components = !kinds.empty() ? isComponentKind(kinds.front()) : dim == 5;
  const std::size_t first_spatial = has_components ? 1 : 0;
  const std::size_t spatial = dim - 1 - first_spatial;
  if (spatial < 2 || spatial > 3) {
    throw FormatError("'" + source + "': " + std::to_string(spatial) +
                      " spatial axes; a sequence needs 2 or 3 plus the frame axis");
  }
  if (has_components) {
    if (sizes[0] < 1 || sizes[0] > 64)
      throw FormatError("'" + source + "': " + std::to_string(sizes[0]) + " components per pixel");
    seq.pixel_format.components = static_cast<int>(sizes[0]);
  }
  auto& g = seq.geometry;
  for (std::size_t i = 0; i < spatial; ++i) g.size[i] = sizes[first_spatial + i];
  if (spatial == 2) g.size[2] = 1;
  g.dimensions = (spatial == 3 && g.size[2] > 1) ? 3 : 2;
  parsed.frame_count = static_cast<std::uint64_t>(sizes.back());

  if (!directions.empty()) {
    if (directions.size() != dim) {
      throw FormatError("'" + source + "': 'space directions' has " + std::to_string(directions.size()) +
                        " entries for dimension " + std::to_string(dim));
    }
    const auto fail = [&](const std::string& what) {
      throw FormatError("'" + source + "' (space directions): " + what);
    };
    for (std::size_t i = 0; i < spatial; ++i) {
      const auto v = parseVector(directions[first_spatial + i], fail);
      if (v.size() < 2 || v.size() > 3) fail("axis " + std::to_string(first_spatial + i) + " has no 2D/3D vector");
      Eigen::Vector3d d(v[0], v[1], v.size() == 3 ? v[2] : 0.0);
      const double norm = d.norm();
      if (!(norm > 0.0)) fail("axis " + std::to_string(first_spatial + i) + " has a zero direction");
      g.spacing[i] = norm;
      g.direction.col(static_cast<Eigen::Index>(i)) = d / norm;
    }
  } else if (spacings.size() == dim) {
    for (std::size_t i = 0; i < spatial; ++i) {
      if (std::isfinite(spacings[first_spatial + i])) g.spacing[i] = spacings[first_spatial + i];
    }
  }
  for (std::size_t i = 0; i < std::min<std::size_t>(origin.size(), 3); ++i) g.origin[i] = origin[i];
  if (ras) {
    // Keep everything in LPS, as MetaImage and ITK do.
    g.origin[0] = -g.origin[0];
    g.origin[1] = -g.origin[1];
    g.direction.row(0) *= -1.0;
    g.direction.row(1) *= -1.0;
  }
  checkDeclaredSizes(seq, parsed.frame_count, source, options);

  seq.frames.resize(parsed.frame_count);
  std::vector<bool> has_timestamp;
  applyFrameFields(seq, frame_fields, source, &has_timestamp);
  if (!index_values.empty()) {
    if (index_values.size() != seq.frames.size()) {
      throw FormatError("'" + source + "' line " + std::to_string(index_values_line) + ": " +
                        std::to_string(index_values.size()) + " index values for " + std::to_string(seq.frames.size()) +
                        " frames");
    }
    for (std::size_t i = 0; i < seq.frames.size(); ++i) {
      if (!has_timestamp[i]) seq.frames[i].timestamp = index_values[i];
    }
  }
  parsed.storage.data_file = data_file ? *data_file : "LOCAL";
  if (data_file) parsed.header_bytes = 0;
  return parsed;
}

std::string formatNrrdHeader(const TrackedSequence& sequence, bool compressed) {
  const auto& g = sequence.geometry;
  const bool components = sequence.pixel_format.components > 1;
  const int dim = 4 + (components ? 1 : 0);
  std::string h =
      "NRRD0004\n# Complete NRRD file format specification at:\n# http://teem.sourceforge.net/nrrd/format.html\n";
  h += "type: " + std::string(nrrdTypeName(sequence.pixel_format.scalar)) + "\n";
  h += "dimension: " + std::to_string(dim) + "\n";
  h += "space: left-posterior-superior\n";
  h += "sizes:";
  if (components) h += " " + std::to_string(sequence.pixel_format.components);
  for (const auto s : g.size) h += " " + std::to_string(s);
  h += " " + std::to_string(sequence.frames.size()) + "\n";
  h += "space directions:";
  if (components) h += " none";
  for (int c = 0; c < 3; ++c) {
    const Eigen::Vector3d d = g.direction.col(c) * g.spacing[static_cast<std::size_t>(c)];
    h += " (" + formatDouble(d.x()) + "," + formatDouble(d.y()) + "," + formatDouble(d.z()) + ")";
  }
  h += " none\n";
  h += std::string("kinds:") + (components ? " vector" : "") + " domain domain domain list\n";
  h += std::string("labels:") + (components ? " \"\"" : "") + " \"\" \"\" \"\" \"frame\"\n";
  h += "endian: little\n";
  h += std::string("encoding: ") + (compressed ? "gzip" : "raw") + "\n";
  h += "space origin: (" + formatDouble(g.origin[0]) + "," + formatDouble(g.origin[1]) + "," +
       formatDouble(g.origin[2]) + ")\n";
  const std::string axis = "axis " + std::to_string(dim - 1);
  h += std::string("DataNodeClassName:=") + (components ? "vtkMRMLVectorVolumeNode" : "vtkMRMLScalarVolumeNode") + "\n";
  h += axis + " index type:=numeric\n";
  h += axis + " index values:=";
  for (std::size_t i = 0; i < sequence.frames.size(); ++i) {
    h += (i ? " " : "") + formatDouble(sequence.frames[i].timestamp);
  }
  h += "\nUltrasoundImageOrientation:=" + sequence.orientation + "\n";
  for (const auto& [key, value] : sequence.custom_header_fields) h += key + ":=" + value + "\n";
  for (std::size_t i = 0; i < sequence.frames.size(); ++i) {
    const std::string prefix = frameKeyPrefix(i, sequence.frames.size());
    forEachFrameField(sequence.frames[i], [&](const std::string& key, const std::string& value) {
      h += prefix + key + ":=" + value + "\n";
    });
  }
  h += "\n";
  return h;
}

}  // namespace mrsns::io::detail
