#include "mrsns/ultrasound/calibration_config.h"

#include <chrono>
#include <ctime>
#include <filesystem>
#include <iomanip>
#include <pugixml.hpp>
#include <sstream>

#include "mrsns/core/error.h"

namespace mrsns::ultrasound {

void writeCoordinateDefinition(const std::filesystem::path& input, const std::filesystem::path& output,
                               const std::string& from, const std::string& to, const Eigen::Matrix4d& to_T_from,
                               double error_mm) {
  pugi::xml_document doc;
  const auto parsed = doc.load_file(input.c_str(), pugi::parse_default | pugi::parse_comments);
  if (!parsed) {
    if (!std::filesystem::exists(input)) throw FileError(input.string() + ": cannot open the configuration file");
    throw FormatError(input.string() + ": not valid XML (" + parsed.description() + ")");
  }
  auto root = doc.child("PlusConfiguration");
  if (!root) throw FormatError(input.string() + ": no PlusConfiguration element; is this a PLUS device-set file?");
  auto defs = root.child("CoordinateDefinitions");
  if (!defs) defs = root.append_child("CoordinateDefinitions");
  pugi::xml_node node;
  for (auto t : defs.children("Transform")) {
    if (from == t.attribute("From").value() && to == t.attribute("To").value()) node = t;
  }
  if (!node) {
    node = defs.append_child("Transform");
    node.append_attribute("From") = from.c_str();
    node.append_attribute("To") = to.c_str();
  }
  std::ostringstream m;
  m << std::setprecision(9);
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) m << (r == 0 && c == 0 ? "" : " ") << to_T_from(r, c);
  }
  const auto set = [&](const char* name, const std::string& value) {
    auto a = node.attribute(name);
    if (!a) a = node.append_attribute(name);
    a = value.c_str();
  };
  set("Matrix", m.str());
  std::ostringstream e;
  e << std::setprecision(6) << error_mm;
  set("Error", e.str());
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&now, &tm);
  std::ostringstream date;
  date << std::put_time(&tm, "%m%d%y_%H%M%S");
  set("Date", date.str());
  const auto tmp = output.string() + ".tmp";
  if (!doc.save_file(tmp.c_str(), "  ")) throw FileError(output.string() + ": cannot write the configuration file");
  std::filesystem::rename(tmp, output);
}

Eigen::Matrix4d readPlusImageToProbe(const std::filesystem::path& results) {
  pugi::xml_document doc;
  const auto parsed = doc.load_file(results.c_str());
  if (!parsed) {
    if (!std::filesystem::exists(results)) throw FileError(results.string() + ": cannot open the results file");
    throw FormatError(results.string() + ": not valid XML (" + parsed.description() + ")");
  }
  for (auto t : doc.child("ProbeCalibrationResult").child("CalibrationResults").children("Transform")) {
    if (std::string("Image") != t.attribute("From").value() || std::string("Probe") != t.attribute("To").value()) {
      continue;
    }
    std::istringstream s(t.attribute("Matrix").value());
    Eigen::Matrix4d m;
    for (int i = 0; i < 16; ++i) {
      if (!(s >> m(i / 4, i % 4))) {
        throw FormatError(results.string() + ": the ImageToProbe Matrix does not hold 16 numbers");
      }
    }
    return m;
  }
  throw FormatError(results.string() +
                    ": no ProbeCalibrationResult/CalibrationResults/Transform From=\"Image\" To=\"Probe\"");
}

}  // namespace mrsns::ultrasound
