// `info` for PLUS device-set configurations.
#include <sstream>

#include "file_kinds.h"
#include "mrsns/io/device_set.h"

namespace mrsns::cli {
namespace {

Json vector3(const Eigen::Vector3d& v) {
  return Json::array({v.x(), v.y(), v.z()});
}

Json optional(const std::optional<double>& value) {
  return value ? Json(*value) : Json(nullptr);
}

Json optional(const std::optional<std::array<int, 2>>& value) {
  if (!value) return nullptr;
  Json pair = Json::array();
  for (const int v : *value) pair.push_back(v);
  return pair;
}

}  // namespace

Report summarizeDeviceSet(const std::filesystem::path& path) {
  const io::DeviceSetConfiguration config = io::readDeviceSet(path);
  Report report;
  Json& j = report.json;
  std::ostringstream text;
  j["file"] = path.string();
  j["kind"] = "device-set";
  j["name"] = config.name;
  j["description"] = config.description;
  text << path.string() << ": PLUS device set \"" << config.name << "\"\n";

  if (config.phantom) {
    const auto& p = *config.phantom;
    Json patterns = Json::array();
    for (const auto& pattern : p.patterns) {
      Json wires = Json::array();
      for (const auto& w : pattern.wires) {
        wires.push_back({{"name", w.name}, {"front", vector3(w.end_point_front)}, {"back", vector3(w.end_point_back)}});
      }
      patterns.push_back({{"type", pattern.type}, {"wires", wires}});
    }
    Json landmarks = Json::array();
    for (const auto& l : p.landmarks)
      landmarks.push_back({{"name", l.name}, {"position", vector3(l.position_phantom)}});
    j["phantom"] = {{"name", p.name},       {"type", p.type},         {"version", p.version},
                    {"patterns", patterns}, {"wires", p.wireCount()}, {"landmarks", landmarks}};
    text << "Phantom: " << p.name << " (" << p.type << " " << p.version << "), " << p.patterns.size() << " patterns, "
         << p.wireCount() << " wires, " << p.landmarks.size() << " landmarks\n";
  } else {
    j["phantom"] = nullptr;
    text << "Phantom: none defined\n";
  }

  Json definitions = Json::array();
  text << "Coordinate definitions:" << (config.coordinate_definitions.empty() ? " none" : "") << "\n";
  for (const auto& def : config.coordinate_definitions) {
    Json matrix = Json::array();
    for (int r = 0; r < 4; ++r) {
      matrix.push_back(
          Json::array({def.to_T_from(r, 0), def.to_T_from(r, 1), def.to_T_from(r, 2), def.to_T_from(r, 3)}));
    }
    definitions.push_back({{"name", def.name()},
                           {"from", def.from},
                           {"to", def.to},
                           {"matrix", matrix},
                           {"error", optional(def.error)},
                           {"date", def.date}});
    text << "  " << def.name() << (def.error ? " (error " + std::to_string(*def.error) + ")" : std::string()) << "\n";
  }
  j["coordinate_definitions"] = definitions;

  if (config.segmentation) {
    const auto& s = *config.segmentation;
    Json attributes = Json::object();
    for (const auto& [key, value] : s.attributes) attributes[key] = value;
    j["segmentation"] = {{"approximate_spacing_mm_per_pixel", optional(s.approximate_spacing_mm_per_pixel)},
                         {"morphological_opening_circle_radius_mm", optional(s.morphological_opening_circle_radius_mm)},
                         {"max_line_pair_distance_error_percent", optional(s.max_line_pair_distance_error_percent)},
                         {"clip_rectangle_origin_px", optional(s.clip_rectangle_origin_px)},
                         {"clip_rectangle_size_px", optional(s.clip_rectangle_size_px)},
                         {"attributes", attributes}};
    text << "Segmentation parameters:\n";
    for (const auto& [key, value] : s.attributes) text << "  " << key << " = " << value << "\n";
  } else {
    j["segmentation"] = nullptr;
    text << "Segmentation parameters: none\n";
  }
  report.text = text.str();
  return report;
}

}  // namespace mrsns::cli
