// PLUS device-set configuration (XML) into typed values.
#include "mrsns/io/device_set.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <numbers>
#include <pugixml.hpp>
#include <sstream>

#include "mrsns/core/error.h"

namespace mrsns::io {
namespace {

class Parser {
 public:
  explicit Parser(std::string source) : source_(std::move(source)) {}

  [[noreturn]] void fail(const pugi::xml_node& node, const std::string& attribute, const std::string& what) const {
    std::string where = std::string("<") + node.name() + ">";
    if (!attribute.empty()) where += " attribute " + attribute;
    throw FormatError("'" + source_ + "': " + where + ": " + what);
  }

  std::vector<double> numbers(const pugi::xml_node& node, const char* attribute, std::size_t count,
                              bool required = true) const {
    const pugi::xml_attribute attr = node.attribute(attribute);
    if (!attr) {
      if (required) fail(node, attribute, "is missing");
      return {};
    }
    std::istringstream in(attr.value());
    std::vector<double> values;
    std::string token;
    while (in >> token) {
      double v = 0.0;
      const char* begin = token.data();
      if (*begin == '+') ++begin;
      const auto [end, ec] = std::from_chars(begin, token.data() + token.size(), v);
      if (ec != std::errc() || end != token.data() + token.size() || !std::isfinite(v)) {
        fail(node, attribute, "'" + token + "' is not a number");
      }
      values.push_back(v);
    }
    if (values.size() != count) {
      fail(node, attribute, "expected " + std::to_string(count) + " numbers, found " + std::to_string(values.size()));
    }
    return values;
  }

  Eigen::Vector3d point(const pugi::xml_node& node, const char* attribute) const {
    const auto v = numbers(node, attribute, 3);
    return {v[0], v[1], v[2]};
  }

  std::string text(const pugi::xml_node& node, const char* attribute, bool required) const {
    const pugi::xml_attribute attr = node.attribute(attribute);
    if (!attr && required) fail(node, attribute, "is missing");
    return attr.value();
  }

  PhantomDefinition phantom(const pugi::xml_node& node) const {
    PhantomDefinition phantom;
    const pugi::xml_node description = node.child("Description");
    phantom.name = description.attribute("Name").value();
    phantom.type = description.attribute("Type").value();
    phantom.version = description.attribute("Version").value();
    phantom.wiring_version = description.attribute("WiringVersion").value();
    phantom.institution = description.attribute("Institution").value();
    const pugi::xml_node geometry = node.child("Geometry");
    for (const pugi::xml_node pattern : geometry.children("Pattern")) {
      PhantomPattern p;
      p.type = text(pattern, "Type", true);
      for (const pugi::xml_node wire : pattern.children("Wire")) {
        p.wires.push_back({text(wire, "Name", true), point(wire, "EndPointFront"), point(wire, "EndPointBack")});
      }
      if (p.type == "NWire" && p.wires.size() != 3) {
        fail(pattern, "", "an NWire pattern needs 3 wires, found " + std::to_string(p.wires.size()));
      }
      phantom.patterns.push_back(std::move(p));
    }
    for (const pugi::xml_node landmark : geometry.child("Landmarks").children("Landmark")) {
      phantom.landmarks.push_back({text(landmark, "Name", true), point(landmark, "Position")});
    }
    return phantom;
  }

  CoordinateDefinition transform(const pugi::xml_node& node) const {
    CoordinateDefinition def;
    def.from = text(node, "From", true);
    def.to = text(node, "To", true);
    const auto m = numbers(node, "Matrix", 16);
    for (int i = 0; i < 16; ++i) def.to_T_from(i / 4, i % 4) = m[static_cast<std::size_t>(i)];
    const auto error = numbers(node, "Error", 1, false);
    if (!error.empty()) def.error = error[0];
    def.date = node.attribute("Date").value();
    return def;
  }

  SegmentationParameters segmentation(const pugi::xml_node& node) const {
    SegmentationParameters s;
    for (const pugi::xml_attribute attr : node.attributes()) s.attributes.emplace_back(attr.name(), attr.value());
    const auto number = [&](const char* name) -> std::optional<double> {
      const auto v = numbers(node, name, 1, false);
      return v.empty() ? std::nullopt : std::optional<double>(v[0]);
    };
    const auto radians = [&](const char* name) -> std::optional<double> {
      const auto v = number(name);
      return v ? std::optional<double>(*v * std::numbers::pi / 180.0) : std::nullopt;
    };
    const auto pair = [&](const char* name) -> std::optional<std::array<int, 2>> {
      const auto v = numbers(node, name, 2, false);
      if (v.empty()) return std::nullopt;
      if (v[0] != std::round(v[0]) || v[1] != std::round(v[1])) fail(node, name, "needs whole pixel numbers");
      return std::array<int, 2>{static_cast<int>(v[0]), static_cast<int>(v[1])};
    };
    s.approximate_spacing_mm_per_pixel = number("ApproximateSpacingMmPerPixel");
    s.morphological_opening_circle_radius_mm = number("MorphologicalOpeningCircleRadiusMm");
    s.morphological_opening_bar_size_mm = number("MorphologicalOpeningBarSizeMm");
    s.max_line_pair_distance_error_percent = number("MaxLinePairDistanceErrorPercent");
    s.angle_tolerance = radians("AngleToleranceDegrees");
    s.max_angle_difference = radians("MaxAngleDifferenceDegrees");
    s.min_theta = radians("MinThetaDegrees");
    s.max_theta = radians("MaxThetaDegrees");
    s.max_line_shift_mm = number("MaxLineShiftMm");
    s.threshold_image_percent = number("ThresholdImagePercent");
    s.collinear_points_max_distance_from_line_mm = number("CollinearPointsMaxDistanceFromLineMm");
    s.clip_rectangle_origin_px = pair("ClipRectangleOrigin");
    s.clip_rectangle_size_px = pair("ClipRectangleSize");
    if (const pugi::xml_attribute attr = node.attribute("UseOriginalImageIntensityForDotIntensityScore")) {
      const std::string v = attr.value();
      if (v == "TRUE" || v == "true" || v == "True") {
        s.use_original_image_intensity_for_dot_intensity_score = true;
      } else if (v == "FALSE" || v == "false" || v == "False") {
        s.use_original_image_intensity_for_dot_intensity_score = false;
      } else {
        fail(node, "UseOriginalImageIntensityForDotIntensityScore", "'" + v + "' is not TRUE or FALSE");
      }
    }
    if (const auto n = number("NumberOfMaximumFiducialPointCandidates")) {
      if (*n != std::round(*n) || *n < 1)
        fail(node, "NumberOfMaximumFiducialPointCandidates", "needs a positive count");
      s.number_of_maximum_fiducial_point_candidates = static_cast<int>(*n);
    }
    return s;
  }

 private:
  std::string source_;
};

// The Segmentation element sits at the top level in PLUS 2.x files and inside
// vtkPlusUsImagingParameters/processor elements in others: take the first anywhere.
pugi::xml_node findFirst(const pugi::xml_node& root, const char* name) {
  return root.find_node([name](const pugi::xml_node& n) { return std::string_view(n.name()) == name; });
}

}  // namespace

const PhantomDefinition& DeviceSetConfiguration::requirePhantom() const {
  if (!phantom) {
    throw FormatError("'" + source +
                      "' has no PhantomDefinition element: use a device set made for phantom calibration (fCal)");
  }
  return *phantom;
}

std::optional<CoordinateDefinition> DeviceSetConfiguration::findTransform(std::string_view from,
                                                                          std::string_view to) const {
  for (const auto& def : coordinate_definitions) {
    if (def.from == from && def.to == to) return def;
  }
  return std::nullopt;
}

DeviceSetConfiguration parseDeviceSet(std::string_view xml, const std::string& source) {
  pugi::xml_document doc;
  const pugi::xml_parse_result result = doc.load_buffer(xml.data(), xml.size());
  if (!result) {
    throw FormatError("'" + source + "' is not well-formed XML: " + result.description() + " at byte " +
                      std::to_string(result.offset));
  }
  const pugi::xml_node root = doc.child("PlusConfiguration");
  if (!root) {
    throw FormatError("'" + source + "' is not a PLUS device set: its root element is <" +
                      std::string(doc.document_element().name()) + ">, not <PlusConfiguration>");
  }
  const Parser parser(source);
  DeviceSetConfiguration config;
  config.source = source;
  const pugi::xml_node device_set = root.child("DataCollection").child("DeviceSet");
  config.name = device_set.attribute("Name").value();
  config.description = device_set.attribute("Description").value();
  if (const pugi::xml_node phantom = root.child("PhantomDefinition")) config.phantom = parser.phantom(phantom);
  for (const pugi::xml_node t : root.child("CoordinateDefinitions").children("Transform")) {
    config.coordinate_definitions.push_back(parser.transform(t));
  }
  if (const pugi::xml_node segmentation = findFirst(root, "Segmentation")) {
    config.segmentation = parser.segmentation(segmentation);
  }
  return config;
}

DeviceSetConfiguration readDeviceSet(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError("cannot open device set '" + path.string() + "': check the path and permissions");
  std::ostringstream text;
  text << in.rdbuf();
  return parseDeviceSet(text.str(), path.string());
}

}  // namespace mrsns::io
