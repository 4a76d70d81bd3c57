#include "mrsns/io/landmarks_io.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "io_text.h"
#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/io/file_names.h"

namespace mrsns::io {
namespace {

using detail::kMarkupsSchema;
using detail::quoted;


std::string lower(std::string s) {
  return toLower(std::move(s));
}

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return {};
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}


std::string slurp(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError("cannot open landmark file " + quoted(path) + ": check that it exists and is readable");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::optional<double> parseNumber(const std::string& text) {
  const std::string t = trim(text);
  if (t.empty()) return std::nullopt;
  double value = 0.0;
  const char* begin = t.data();
  if (*begin == '+') ++begin;
  const auto [ptr, ec] = std::from_chars(begin, t.data() + t.size(), value);
  if (ec != std::errc() || ptr != t.data() + t.size() || !std::isfinite(value)) return std::nullopt;
  return value;
}

/// Splits one CSV line; fields may be double-quoted with "" as an escaped quote
/// (Slicer 4.11+ quotes labels and descriptions that hold commas).
std::vector<std::string> splitCsv(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  bool in_quotes = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (in_quotes) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        field += '"';
        ++i;
      } else if (c == '"') {
        in_quotes = false;
      } else {
        field += c;
      }
    } else if (c == '"') {
      in_quotes = true;
    } else if (c == ',') {
      fields.push_back(field);
      field.clear();
    } else if (c != '\r' && c != '\n') {
      field += c;
    }
  }
  fields.push_back(field);
  return fields;
}

std::vector<std::string> splitWhitespace(const std::string& line) {
  std::istringstream ss(line);
  std::vector<std::string> out;
  std::string token;
  while (ss >> token) out.push_back(token);
  return out;
}

std::string csvField(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) out += (c == '"') ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

bool flag(const std::string& field, bool fallback) {
  const auto v = parseNumber(field);
  return v ? *v != 0.0 : fallback;
}

/// Converts in place from the declared system to LPS.
void toLps(LandmarkSet& set, const std::string& coordinate_system) {
  if (coordinate_system != "RAS") return;
  for (auto& p : set.points) {
    p.position.x() = -p.position.x();
    p.position.y() = -p.position.y();
  }
}

std::string normalizeSystem(const std::string& raw, const std::filesystem::path& path) {
  const std::string s = trim(raw);
  const std::string u = lower(s);
  // Slicer's legacy numeric codes: 0 = RAS, 1 = LPS (2 = IJK cannot be placed without the volume).
  if (u == "lps" || u == "1") return "LPS";
  if (u == "ras" || u == "0") return "RAS";
  throw UnsupportedError("landmark file " + quoted(path) + " declares coordinate system '" + s +
                         "': only LPS and RAS are supported; re-export it from Slicer in LPS or RAS");
}

// ---------------------------------------------------------------------------------------------------------------
LandmarksReadResult readMarkupsJson(const std::filesystem::path& path) {
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(slurp(path));
  } catch (const nlohmann::json::parse_error& e) {
    throw FormatError("markups file " + quoted(path) + " is not valid JSON (" + e.what() +
                      "): save it again from Slicer");
  }
  if (!doc.is_object() || !doc.contains("markups") || !doc["markups"].is_array() || doc["markups"].empty()) {
    throw FormatError("markups file " + quoted(path) +
                      " has no \"markups\" list: expected a Slicer markups JSON (markups-schema-v1.0.x)");
  }
  LandmarksReadResult result;
  result.info.format = "mrk.json";
  result.info.markups_in_file = static_cast<int>(doc["markups"].size());
  if (result.info.markups_in_file > 1) {
    logger()->warn("markups file '{}' holds {} markups; reading only the first", path.string(),
                   result.info.markups_in_file);
  }
  const auto& markup = doc["markups"][0];
  if (!markup.is_object()) throw FormatError("markups file " + quoted(path) + ": markups[0] is not an object");
  result.info.markup_type = markup.value("type", std::string("Fiducial"));
  if (markup.contains("coordinateSystem") && markup["coordinateSystem"].is_string()) {
    result.info.coordinate_system = normalizeSystem(markup["coordinateSystem"].get<std::string>(), path);
  } else {
    // The schema's default when the field is absent.
    result.info.coordinate_system = "LPS";
  }
  if (markup.contains("coordinateUnits") && markup["coordinateUnits"].is_string() &&
      markup["coordinateUnits"].get<std::string>() != "mm") {
    throw UnsupportedError("markups file " + quoted(path) + " uses units '" +
                           markup["coordinateUnits"].get<std::string>() + "': only mm is supported");
  }
  if (!markup.contains("controlPoints") || !markup["controlPoints"].is_array() || markup["controlPoints"].empty()) {
    throw FormatError("markups file " + quoted(path) + " has no control points: place points in Slicer and save again");
  }
  result.landmarks.name = markup.value("name", path.filename().string());
  std::size_t index = 0;
  for (const auto& cp : markup["controlPoints"]) {
    ++index;
    const std::string status = cp.value("positionStatus", std::string("defined"));
    if (!cp.contains("position")) {
      if (status != "defined") continue;  // a placeholder point not placed yet
      throw FormatError("markups file " + quoted(path) + ": control point " + std::to_string(index) +
                        " has no position");
    }
    const auto& pos = cp["position"];
    if (!pos.is_array() || pos.size() != 3 || !pos[0].is_number() || !pos[1].is_number() || !pos[2].is_number()) {
      throw FormatError("markups file " + quoted(path) + ": control point " + std::to_string(index) +
                        " position is not an array of 3 numbers");
    }
    Landmark p;
    p.position = Eigen::Vector3d(pos[0].get<double>(), pos[1].get<double>(), pos[2].get<double>());
    if (!p.position.allFinite()) {
      throw FormatError("markups file " + quoted(path) + ": control point " + std::to_string(index) +
                        " has a non-finite position");
    }
    p.label = cp.value("label", std::string());
    p.description = cp.value("description", std::string());
    p.selected = cp.value("selected", true);
    p.visible = cp.value("visibility", true);
    p.locked = cp.value("locked", false);
    result.landmarks.points.push_back(std::move(p));
  }
  if (result.landmarks.points.empty()) {
    throw FormatError("markups file " + quoted(path) + " has no placed control points");
  }
  toLps(result.landmarks, result.info.coordinate_system);
  return result;
}

// ---------------------------------------------------------------------------------------------------------------
/// .fcsv with Slicer's "# ..." header, or a headerless list of "x y z" /
/// "label,x,y,z" lines (as in the statismo hand landmarks).
LandmarksReadResult readPointList(const std::filesystem::path& path, const std::string& format) {
  std::istringstream in(slurp(path));
  LandmarksReadResult result;
  result.info.format = format;
  result.landmarks.name = path.filename().string();
  bool slicer_header = false;
  std::optional<std::string> system;
  std::map<std::string, std::size_t> columns;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const std::string t = trim(line);
    if (t.empty()) continue;
    if (t[0] == '#') {
      const auto eq = t.find('=');
      const std::string key = lower(trim(t.substr(1, eq == std::string::npos ? std::string::npos : eq - 1)));
      const std::string value = eq == std::string::npos ? std::string() : trim(t.substr(eq + 1));
      if (key.rfind("markups fiducial file version", 0) == 0) slicer_header = true;
      if (key == "coordinatesystem") system = normalizeSystem(value, path);
      if (key == "columns") {
        const auto names = splitCsv(value);
        for (std::size_t i = 0; i < names.size(); ++i) columns[lower(trim(names[i]))] = i;
      }
      continue;
    }
    const bool has_comma = t.find(',') != std::string::npos;
    const auto fields = has_comma ? splitCsv(t) : splitWhitespace(t);
    Landmark p;
    auto fail = [&](const std::string& what) {
      return FormatError("landmark file " + quoted(path) + " line " + std::to_string(line_number) + ": " + what);
    };
    if (slicer_header || !columns.empty()) {
      auto col = [&](const std::string& name, std::size_t fallback) {
        const auto it = columns.find(name);
        return it == columns.end() ? fallback : it->second;
      };
      const std::size_t ix = col("x", 1), iy = col("y", 2), iz = col("z", 3);
      if (fields.size() <= std::max({ix, iy, iz})) throw fail("expected id,x,y,z,... (fcsv columns)");
      const auto x = parseNumber(fields[ix]), y = parseNumber(fields[iy]), z = parseNumber(fields[iz]);
      if (!x || !y || !z) throw fail("x, y, z are not finite numbers");
      p.position = Eigen::Vector3d(*x, *y, *z);
      auto text = [&](const std::string& name, std::size_t fallback) {
        const std::size_t i = col(name, fallback);
        return i < fields.size() ? fields[i] : std::string();
      };
      p.visible = flag(text("vis", 8), true);
      p.selected = flag(text("sel", 9), true);
      p.locked = flag(text("lock", 10), false);
      p.label = text("label", 11);
      p.description = text("desc", 12);
    } else {
      // Headerless: "x y z" or "label,x,y,z"; a first row of names is a header.
      std::vector<double> numbers;
      std::string label;
      for (std::size_t i = 0; i < fields.size(); ++i) {
        if (const auto v = parseNumber(fields[i])) {
          numbers.push_back(*v);
        } else if (i == 0) {
          label = trim(fields[i]);
        } else {
          numbers.clear();
          break;
        }
      }
      if (numbers.size() != 3) {
        if (result.landmarks.points.empty() && numbers.empty()) continue;  // column titles
        throw fail("expected 'x y z' or 'label,x,y,z'");
      }
      p.position = Eigen::Vector3d(numbers[0], numbers[1], numbers[2]);
      p.label = label.empty() ? "P-" + std::to_string(result.landmarks.points.size() + 1) : label;
    }
    result.landmarks.points.push_back(std::move(p));
  }
  if (result.landmarks.points.empty()) {
    throw FormatError("landmark file " + quoted(path) + " holds no points");
  }
  if (system) {
    result.info.coordinate_system = *system;
  } else if (slicer_header) {
    // Slicer before 4.11 wrote no CoordinateSystem line and meant RAS.
    result.info.coordinate_system = "RAS";
  } else {
    result.info.coordinate_system = "unspecified";
  }
  toLps(result.landmarks, result.info.coordinate_system);
  return result;
}

std::ofstream openForWriting(const std::filesystem::path& path) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw FileError("cannot write landmark file " + quoted(path) + ": check the folder exists and is writable");
  out << std::setprecision(17);
  return out;
}

void finish(std::ofstream& out, const std::filesystem::path& path) {
  out.flush();
  if (!out) throw FileError("writing landmark file " + quoted(path) + " failed (disk full?)");
}

}  // namespace

LandmarksReadResult readLandmarksFile(const std::filesystem::path& path) {
  const std::string name = lower(path.filename().string());
  if (endsWith(name, ".json")) return readMarkupsJson(path);
  if (endsWith(name, ".fcsv")) return readPointList(path, "fcsv");
  if (endsWith(name, ".csv") || endsWith(name, ".txt")) return readPointList(path, "csv");
  throw UnsupportedError("landmark file " + quoted(path) +
                         " has an unknown extension: use .mrk.json, .fcsv, .csv or .txt");
}

LandmarkSet readLandmarks(const std::filesystem::path& path) {
  return readLandmarksFile(path).landmarks;
}

void writeMarkupsJson(const LandmarkSet& landmarks, const std::filesystem::path& path) {
  nlohmann::ordered_json points = nlohmann::ordered_json::array();
  int id = 0;
  for (const auto& p : landmarks.points) {
    nlohmann::ordered_json cp;
    cp["id"] = std::to_string(++id);
    cp["label"] = p.label;
    cp["description"] = p.description;
    cp["associatedNodeID"] = "";
    cp["position"] = {p.position.x(), p.position.y(), p.position.z()};
    cp["orientation"] = {-1.0, -0.0, -0.0, -0.0, -1.0, -0.0, 0.0, 0.0, 1.0};
    cp["selected"] = p.selected;
    cp["locked"] = p.locked;
    cp["visibility"] = p.visible;
    cp["positionStatus"] = "defined";
    points.push_back(std::move(cp));
  }
  nlohmann::ordered_json markup;
  markup["type"] = "Fiducial";
  markup["coordinateSystem"] = "LPS";
  markup["coordinateUnits"] = "mm";
  markup["locked"] = false;
  markup["fixedNumberOfControlPoints"] = false;
  markup["labelFormat"] = "%N-%d";
  markup["lastUsedControlPointNumber"] = id;
  markup["controlPoints"] = std::move(points);
  markup["measurements"] = nlohmann::ordered_json::array();
  nlohmann::ordered_json doc;
  doc["@schema"] = kMarkupsSchema;
  doc["markups"] = nlohmann::ordered_json::array({std::move(markup)});
  auto out = openForWriting(path);
  out << doc.dump(4) << '\n';
  finish(out, path);
}

void writeFcsv(const LandmarkSet& landmarks, const std::filesystem::path& path) {
  auto out = openForWriting(path);
  out << "# Markups fiducial file version = 4.11\n"
         "# CoordinateSystem = LPS\n"
         "# columns = id,x,y,z,ow,ox,oy,oz,vis,sel,lock,label,desc,associatedNodeID\n";
  int id = 0;
  for (const auto& p : landmarks.points) {
    out << "vtkMRMLMarkupsFiducialNode_" << id++ << ',' << p.position.x() << ',' << p.position.y() << ','
        << p.position.z() << ",0,0,0,1," << int(p.visible) << ',' << int(p.selected) << ',' << int(p.locked) << ','
        << csvField(p.label) << ',' << csvField(p.description) << ",\n";
  }
  finish(out, path);
}

void writeLandmarksCsv(const LandmarkSet& landmarks, const std::filesystem::path& path) {
  auto out = openForWriting(path);
  for (const auto& p : landmarks.points) {
    out << csvField(p.label) << ',' << p.position.x() << ',' << p.position.y() << ',' << p.position.z() << '\n';
  }
  finish(out, path);
}

void writeLandmarks(const LandmarkSet& landmarks, const std::filesystem::path& path) {
  const std::string name = lower(path.filename().string());
  if (endsWith(name, ".json")) return writeMarkupsJson(landmarks, path);
  if (endsWith(name, ".fcsv")) return writeFcsv(landmarks, path);
  if (endsWith(name, ".csv")) return writeLandmarksCsv(landmarks, path);
  throw UnsupportedError("cannot write landmarks to " + quoted(path) + ": use .mrk.json, .fcsv or .csv");
}

}  // namespace mrsns::io
