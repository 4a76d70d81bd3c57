// `info` and `convert` for transform files (.tfm, .h5, .mat, 4x4 .txt).
#include <Eigen/Geometry>
#include <cmath>
#include <numbers>
#include <sstream>

#include "file_kinds.h"
#include "mrsns/core/error.h"
#include "mrsns/io/transform_io.h"

namespace mrsns::cli {

namespace {

Json transformRowsJson(const Eigen::Matrix4d& m) {
  Json rows = Json::array();
  for (int r = 0; r < 4; ++r) rows.push_back({m(r, 0), m(r, 1), m(r, 2), m(r, 3)});
  return rows;
}

void printTransformRows(std::ostringstream& t, const Eigen::Matrix4d& m) {
  for (int r = 0; r < 4; ++r) t << "    " << m(r, 0) << " " << m(r, 1) << " " << m(r, 2) << " " << m(r, 3) << "\n";
}

}  // namespace

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
    // `matrix` is the file's raw T; `child_to_parent` what a file named ChildToParent means (io/transform_io.h).
    j["convention"] = file.format == "matrix-text"
                          ? "plain 4x4 matrix: the file's ChildToParent (parent_T_child, LPS mm) as written"
                          : "ITK: maps points of the parent space to the child space (the inverse of the file's "
                            "ChildToParent), LPS mm";
    j["matrix"] = transformRowsJson(file.matrix);
    const Eigen::Vector3d translation = file.matrix.topRightCorner<3, 1>();
    j["translation_mm"] = {translation.x(), translation.y(), translation.z()};
    j["translation_norm_mm"] = translation.norm();
    j["orthonormality_error"] = file.orthonormality_error;
    t << "  matrix (" << j["convention"].get<std::string>() << "):\n";
    printTransformRows(t, file.matrix);
    try {
      const Eigen::Matrix4d child_to_parent = io::readChildToParent(path);
      j["child_to_parent"] = transformRowsJson(child_to_parent);
      j["slicer_to_parent_ras"] = transformRowsJson(io::flipRasLps(child_to_parent));
      t << "  ChildToParent (parent_T_child, LPS mm; 3D Slicer's ToParent is this in RAS):\n";
      printTransformRows(t, child_to_parent);
    } catch (const FormatError& e) {  // a singular ITK matrix: no inverse, shown as it is
      j["child_to_parent"] = nullptr;
      t << "  no ChildToParent: " << e.what() << "\n";
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
  // The same node in another format: .tfm -> .txt writes the plain parent_T_child the .tfm's inverse stands for.
  const Eigen::Matrix4d child_to_parent = io::readChildToParent(in);
  io::writeChildToParent(child_to_parent, out);
  Report report;
  report.json["file"] = in.string();
  report.json["kind"] = "transform";
  report.json["written"] = out.string();
  report.json["child_to_parent"] = transformRowsJson(child_to_parent);
  report.text = "wrote " + out.string() + " (the same ChildToParent transform, in that format's convention)\n";
  return report;
}

}  // namespace mrsns::cli
