// `info` and `convert` for landmark files (.mrk.json, .fcsv, .csv).
#include <sstream>

#include "file_kinds.h"
#include "mrsns/io/landmarks_io.h"

namespace mrsns::cli {

Report summarizeLandmarks(const std::filesystem::path& path) {
  const io::LandmarksReadResult read = io::readLandmarksFile(path);
  Report report;
  auto& j = report.json;
  j["file"] = path.string();
  j["kind"] = "landmarks";
  j["format"] = read.info.format;
  j["name"] = read.landmarks.name;
  j["coordinate_system_read"] = read.info.coordinate_system;
  j["coordinate_system"] = "LPS";
  if (!read.info.markup_type.empty()) j["markup_type"] = read.info.markup_type;
  if (read.info.markups_in_file > 1) j["markups_in_file"] = read.info.markups_in_file;
  j["count"] = read.landmarks.size();
  j["points"] = Json::array();
  std::ostringstream t;
  t << path.string() << ": landmarks (" << read.info.format << ", " << read.landmarks.size() << " points, file in "
    << read.info.coordinate_system << ", shown in LPS mm)\n";
  for (const auto& p : read.landmarks.points) {
    j["points"].push_back({{"label", p.label},
                           {"position", {p.position.x(), p.position.y(), p.position.z()}},
                           {"selected", p.selected},
                           {"visible", p.visible},
                           {"locked", p.locked},
                           {"description", p.description}});
    t << "  " << (p.label.empty() ? std::string("(no label)") : p.label) << ": " << p.position.x() << ", "
      << p.position.y() << ", " << p.position.z() << "\n";
  }
  report.text = t.str();
  return report;
}

Report convertLandmarks(const std::filesystem::path& in, const std::filesystem::path& out,
                        const ConvertOptions& /*options*/) {
  const io::LandmarksReadResult read = io::readLandmarksFile(in);
  io::writeLandmarks(read.landmarks, out);
  Report report;
  report.json["file"] = in.string();
  report.json["kind"] = "landmarks";
  report.json["written"] = out.string();
  report.json["count"] = read.landmarks.size();
  report.json["coordinate_system_read"] = read.info.coordinate_system;
  report.json["coordinate_system_written"] = "LPS";
  report.text = "wrote " + out.string() + " (" + std::to_string(read.landmarks.size()) + " points, LPS)\n";
  return report;
}

}  // namespace mrsns::cli
