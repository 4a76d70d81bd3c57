#include "mrsns/io/screw_path_io.h"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>

#include "io_text.h"
#include "mrsns/core/error.h"
#include "mrsns/core/log.h"

namespace mrsns::io {
namespace {

using detail::kMarkupsSchema;
using detail::quoted;



std::string upper(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::toupper(c); });
  return s;
}

Eigen::Vector3d position(const nlohmann::json& cp, const std::filesystem::path& path, const std::string& where) {
  if (!cp.is_object() || !cp.contains("position")) {
    throw FormatError("line markups file " + quoted(path) + ": " + where + " has no position");
  }
  const auto& p = cp["position"];
  if (!p.is_array() || p.size() != 3 || !p[0].is_number() || !p[1].is_number() || !p[2].is_number()) {
    throw FormatError("line markups file " + quoted(path) + ": " + where + " position is not an array of 3 numbers");
  }
  const Eigen::Vector3d v(p[0].get<double>(), p[1].get<double>(), p[2].get<double>());
  if (!v.allFinite()) throw FormatError("line markups file " + quoted(path) + ": " + where + " is not finite");
  return v;
}

}  // namespace

std::vector<MarkupsLine> readMarkupsLines(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError("cannot open line markups file " + quoted(path) + ": check that it exists and is readable");
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw FormatError("line markups file " + quoted(path) + " is not valid JSON (" + e.what() +
                      "): save it again from Slicer");
  }
  if (!doc.is_object() || !doc.contains("markups") || !doc["markups"].is_array()) {
    throw FormatError("line markups file " + quoted(path) +
                      " has no \"markups\" list: expected a Slicer markups JSON (markups-schema-v1.0.x)");
  }
  std::vector<MarkupsLine> lines;
  int index = 0;
  for (const auto& markup : doc["markups"]) {
    ++index;
    const std::string where = "markup " + std::to_string(index);
    if (!markup.is_object())
      throw FormatError("line markups file " + quoted(path) + ": " + where + " is not an object");
    const std::string type = markup.value("type", std::string("Fiducial"));
    if (type != "Line") {
      logger()->info("line markups file '{}': skipping {} of type {}", path.string(), where, type);
      continue;
    }
    const std::string system = upper(markup.value("coordinateSystem", std::string("LPS")));
    if (system != "LPS" && system != "RAS") {
      throw UnsupportedError("line markups file " + quoted(path) + ": " + where + " uses coordinate system '" + system +
                             "': only LPS and RAS are supported");
    }
    if (markup.value("coordinateUnits", std::string("mm")) != "mm") {
      throw UnsupportedError("line markups file " + quoted(path) + ": " + where + " is not in mm");
    }
    std::vector<const nlohmann::json*> placed;
    if (markup.contains("controlPoints") && markup["controlPoints"].is_array()) {
      for (const auto& cp : markup["controlPoints"]) {
        if (cp.is_object() && cp.value("positionStatus", std::string("defined")) == "defined") placed.push_back(&cp);
      }
    }
    if (placed.size() != 2) {
      throw FormatError("line markups file " + quoted(path) + ": " + where + " (a Line) has " +
                        std::to_string(placed.size()) + " placed control points instead of 2: place entry and target");
    }
    MarkupsLine line;
    line.name = markup.value("name", std::string("Line-") + std::to_string(lines.size() + 1));
    line.start = position(*placed[0], path, where + " point 1");
    line.end = position(*placed[1], path, where + " point 2");
    if (system == "RAS") {
      line.start.head<2>() = -line.start.head<2>();
      line.end.head<2>() = -line.end.head<2>();
    }
    line.description = markup.value("description", placed[0]->value("description", std::string()));
    lines.push_back(std::move(line));
  }
  if (lines.empty()) {
    throw FormatError("line markups file " + quoted(path) + " holds no markup of type Line: draw the paths as lines");
  }
  return lines;
}

void writeMarkupsLines(const std::vector<MarkupsLine>& lines, const std::filesystem::path& path) {
  nlohmann::ordered_json markups = nlohmann::ordered_json::array();
  for (const auto& line : lines) {
    if (!line.start.allFinite() || !line.end.allFinite()) {
      throw InvalidArgumentError("cannot write line '" + line.name + "' to " + quoted(path) +
                                 ": its points are not finite");
    }
    nlohmann::ordered_json points = nlohmann::ordered_json::array();
    const Eigen::Vector3d ends[2] = {line.start, line.end};
    for (int i = 0; i < 2; ++i) {
      nlohmann::ordered_json cp;
      cp["id"] = std::to_string(i + 1);
      cp["label"] = line.name + (i == 0 ? "-entry" : "-target");
      // The description also goes on the first point: Slicer shows and keeps control point descriptions.
      cp["description"] = i == 0 ? line.description : std::string();
      cp["associatedNodeID"] = "";
      cp["position"] = {ends[i].x(), ends[i].y(), ends[i].z()};
      cp["orientation"] = {-1.0, -0.0, -0.0, -0.0, -1.0, -0.0, 0.0, 0.0, 1.0};
      cp["selected"] = true;
      cp["locked"] = false;
      cp["visibility"] = true;
      cp["positionStatus"] = "defined";
      points.push_back(std::move(cp));
    }
    nlohmann::ordered_json markup;
    markup["type"] = "Line";
    markup["name"] = line.name;
    markup["description"] = line.description;
    markup["coordinateSystem"] = "LPS";
    markup["coordinateUnits"] = "mm";
    markup["locked"] = false;
    markup["fixedNumberOfControlPoints"] = false;
    markup["labelFormat"] = "%N-%d";
    markup["lastUsedControlPointNumber"] = 2;
    markup["controlPoints"] = std::move(points);
    markup["measurements"] =
        nlohmann::ordered_json::array({nlohmann::ordered_json{{"name", "length"},
                                                              {"enabled", true},
                                                              {"value", (line.end - line.start).norm()},
                                                              {"units", "mm"},
                                                              {"printFormat", "%-#4.4g%s"}}});
    markups.push_back(std::move(markup));
  }
  nlohmann::ordered_json doc;
  doc["@schema"] = kMarkupsSchema;
  doc["markups"] = std::move(markups);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out)
    throw FileError("cannot write line markups file " + quoted(path) + ": check the folder exists and is writable");
  out << std::setprecision(17) << doc.dump(4) << '\n';
  out.flush();
  if (!out) throw FileError("writing line markups file " + quoted(path) + " failed (disk full?)");
}

}  // namespace mrsns::io
