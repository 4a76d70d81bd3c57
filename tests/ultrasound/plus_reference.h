#pragma once
// PLUS's reference result for the fCal 3-NWire recording
// (FreehandCalibration3NWires.results.xml): its ImageToProbe, error figures
// and the wire points it segmented in every validation frame.
#include <Eigen/Core>
#include <filesystem>
#include <map>
#include <pugixml.hpp>
#include <sstream>
#include <string>
#include <vector>

namespace mrsns::test {

struct PlusReference {
  Eigen::Matrix4d image_to_probe = Eigen::Matrix4d::Identity();
  double validation_mean_mm = 0.0, validation_std_mm = 0.0, calibration_mean_mm = 0.0, calibration_std_mm = 0.0;
  /// Validation (calibration) frame index -> its 9 wire points (px), when PLUS segmented it.
  std::map<int, std::vector<Eigen::Vector2d>> validation_points, calibration_points;
};

inline PlusReference readPlusReference(const std::filesystem::path& path) {
  pugi::xml_document doc;
  if (!doc.load_file(path.c_str())) throw std::runtime_error("cannot parse " + path.string());
  PlusReference ref;
  const auto root = doc.child("ProbeCalibrationResult");
  std::istringstream m(root.child("CalibrationResults").child("Transform").attribute("Matrix").value());
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) m >> ref.image_to_probe(r, c);
  }
  const auto stats = root.child("ErrorReport").child("ReprojectionError3DStatistics");
  ref.validation_mean_mm = stats.attribute("ValidationMeanMm").as_double();
  ref.validation_std_mm = stats.attribute("ValidationStdDevMm").as_double();
  ref.calibration_mean_mm = stats.attribute("CalibrationMeanMm").as_double();
  ref.calibration_std_mm = stats.attribute("CalibrationStdDevMm").as_double();
  const auto readPoints = [&](const char* element, std::map<int, std::vector<Eigen::Vector2d>>& out) {
    for (const auto frame : root.child("ErrorReport").child(element).children("Frame")) {
      std::vector<Eigen::Vector2d> points;
      for (const auto p : frame.child("SegmentedPoints").children("Point")) {
        std::istringstream s(p.attribute("Position").value());
        double x = 0, y = 0;
        s >> x >> y;
        points.emplace_back(x, y);
      }
      if (!points.empty()) out[frame.attribute("Index").as_int()] = points;
    }
  };
  readPoints("ValidationData", ref.validation_points);
  readPoints("CalibrationData", ref.calibration_points);
  return ref;
}

}  // namespace mrsns::test
