// `info` and `convert` for transform files (.tfm, .h5, .mat, 4x4 .txt).
#include <Eigen/Geometry>
#include <cmath>
#include <numbers>
#include <sstream>

#include "file_kinds.h"
#include "mrsns/io/transform_io.h"

namespace mrsns::cli {

Report summarizeTransform(const std::filesystem::path& path) {
  const io::TransformFile file = io::readTransformFile(path);
  Report report;
  auto& j = report.json;
  j["file"] = path.string();
  j["kind"] = "transform";
  j["format"] = file.format;
  j["components"] = file.components;
  j["linear"] = file.linear;
  j["is_rigid"] = file.rigid;
  std::ostringstream t;
  t << path.string() << ": transform (" << file.format << ")\n";
  for (const auto& c : file.components) t << "  component: " << c << "\n";
  if (file.linear) {
    j["convention"] = file.format == "matrix-text"
                          ? "the matrix as written in the file"
                          : "ITK: maps points of the fixed (parent) space to the moving (child) space, LPS mm";
    j["matrix"] = Json::array();
    for (int r = 0; r < 4; ++r) {
      j["matrix"].push_back({file.matrix(r, 0), file.matrix(r, 1), file.matrix(r, 2), file.matrix(r, 3)});
    }
    const Eigen::Vector3d translation = file.matrix.topRightCorner<3, 1>();
    j["translation_mm"] = {translation.x(), translation.y(), translation.z()};
    j["translation_norm_mm"] = translation.norm();
    j["orthonormality_error"] = file.orthonormality_error;
    t << "  matrix (" << j["convention"].get<std::string>() << "):\n";
    for (int r = 0; r < 4; ++r) {
      t << "    " << file.matrix(r, 0) << " " << file.matrix(r, 1) << " " << file.matrix(r, 2) << " "
        << file.matrix(r, 3) << "\n";
    }
    if (file.rigid) {
      const Eigen::AngleAxisd aa(Eigen::Matrix3d(file.matrix.topLeftCorner<3, 3>()));
      const double angle_deg = aa.angle() * 180.0 / std::numbers::pi;
      j["rotation_angle_deg"] = angle_deg;
      j["rotation_axis"] = {aa.axis().x(), aa.axis().y(), aa.axis().z()};
      t << "  rigid: rotation " << angle_deg << " deg, translation " << translation.norm() << " mm\n";
    } else {
      j["rotation_angle_deg"] = nullptr;
      t << "  not rigid (||R^T R - I|| = " << file.orthonormality_error << ")\n";
    }
  } else {
    j["matrix"] = nullptr;
    t << "  non-linear: no matrix\n";
  }
  report.text = t.str();
  return report;
}

Report convertTransform(const std::filesystem::path& in, const std::filesystem::path& out,
                        const ConvertOptions& /*options*/) {
  const Eigen::Matrix4d matrix = io::readLinearTransform(in);
  io::writeTransformFile(matrix, out);
  Report report;
  report.json["file"] = in.string();
  report.json["kind"] = "transform";
  report.json["written"] = out.string();
  report.text = "wrote " + out.string() + " (same transform, same convention)\n";
  return report;
}

}  // namespace mrsns::cli
