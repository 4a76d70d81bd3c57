#include "segment_output.h"

#include <cctype>
#include <sstream>

#include "mrsns/io/mesh_io.h"

namespace mrsns::cli {

std::string meshFileName(const std::string& name, const std::string& extension) {
  std::string file = name;
  for (char& c : file) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
  }
  return file + "." + extension;
}

Json vector3Json(const Eigen::Vector3d& v) {
  return Json::array({v.x(), v.y(), v.z()});
}

Json writeLabelMeshes(const registration::LabelMeshingResult& result, const std::filesystem::path& dir,
                      const std::string& extension, std::string& text) {
  Json meshes = Json::array();
  std::ostringstream lines;
  for (const auto& m : result.meshes) {
    const std::filesystem::path file = dir / meshFileName(m.name, extension);
    io::writeMesh(m.mesh, file);
    meshes.push_back(Json{{"label", m.label},
                          {"name", m.name},
                          {"color", vector3Json(m.color)},
                          {"file", file.string()},
                          {"volume_ml", m.mesh_volume_ml},
                          {"voxel_volume_ml", m.voxel_volume_ml},
                          {"volume_tolerance_ml", m.volume_tolerance_ml},
                          {"surface_area_mm2", m.surface_area_mm2},
                          {"voxels", m.voxels},
                          {"triangles", m.mesh.faceCount()},
                          {"triangles_before_decimation", m.triangles_before_decimation},
                          {"closed", m.closed}});
    lines << "  " << m.label << " " << m.name << ": " << m.mesh_volume_ml << " ml (voxels " << m.voxel_volume_ml
          << " ml), " << m.mesh.faceCount() << " triangles" << (m.closed ? "" : ", NOT closed") << " -> "
          << file.string() << "\n";
  }
  text += lines.str();
  return meshes;
}

}  // namespace mrsns::cli
