// `info` and `convert` for triangle meshes (.stl, .vtp, .vtk, .obj, .ply).
#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <sstream>
#include <utility>

#include "file_kinds.h"
#include "mrsns/io/mesh_io.h"

namespace mrsns::cli {
namespace {

struct MeshMeasures {
  double area_mm2 = 0.0;
  double signed_volume_mm3 = 0.0;
  bool closed = false;
  std::size_t boundary_edges = 0;
};

/// Area, and the enclosed volume by the divergence theorem, which only means
/// something when every edge is shared by exactly two faces (closed).
MeshMeasures measure(const TriangleMesh& mesh) {
  MeshMeasures m;
  std::map<std::pair<int, int>, int> edge_use;
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    const Eigen::Vector3d a = mesh.vertices.row(mesh.faces(f, 0));
    const Eigen::Vector3d b = mesh.vertices.row(mesh.faces(f, 1));
    const Eigen::Vector3d c = mesh.vertices.row(mesh.faces(f, 2));
    m.area_mm2 += 0.5 * (b - a).cross(c - a).norm();
    m.signed_volume_mm3 += a.dot(b.cross(c)) / 6.0;
    for (int k = 0; k < 3; ++k) {
      const int u = mesh.faces(f, k), v = mesh.faces(f, (k + 1) % 3);
      ++edge_use[{std::min(u, v), std::max(u, v)}];
    }
  }
  m.closed = !edge_use.empty();
  for (const auto& [edge, count] : edge_use) {
    if (count != 2) {
      m.closed = false;
      if (count == 1) ++m.boundary_edges;
    }
  }
  return m;
}

}  // namespace

Report summarizeMesh(const std::filesystem::path& path) {
  const TriangleMesh mesh = io::readMesh(path);
  const MeshMeasures m = measure(mesh);
  Report report;
  auto& j = report.json;
  j["file"] = path.string();
  j["kind"] = "mesh";
  j["format"] = io::meshFormatName(io::meshFormatFromPath(path));
  j["vertices"] = mesh.vertexCount();
  j["faces"] = mesh.faceCount();
  const Eigen::RowVector3d lo = mesh.vertices.colwise().minCoeff();
  const Eigen::RowVector3d hi = mesh.vertices.colwise().maxCoeff();
  j["bounds_mm"] = {{"min", {lo.x(), lo.y(), lo.z()}}, {"max", {hi.x(), hi.y(), hi.z()}}};
  j["size_mm"] = {hi.x() - lo.x(), hi.y() - lo.y(), hi.z() - lo.z()};
  j["surface_area_mm2"] = m.area_mm2;
  j["closed"] = m.closed;
  j["boundary_edges"] = m.boundary_edges;
  if (m.closed) {
    j["volume_ml"] = std::abs(m.signed_volume_mm3) / 1000.0;
    j["outward_oriented"] = m.signed_volume_mm3 > 0.0;
  } else {
    j["volume_ml"] = nullptr;
  }
  j["has_normals"] = mesh.normals.rows() == mesh.vertexCount() && mesh.vertexCount() > 0;
  j["has_colors"] = mesh.colors.rows() == mesh.vertexCount() && mesh.vertexCount() > 0;

  std::ostringstream t;
  t << path.string() << ": mesh (" << j["format"].get<std::string>() << ")\n"
    << "  vertices: " << mesh.vertexCount() << ", faces: " << mesh.faceCount() << "\n"
    << "  bounds (mm): [" << lo.x() << ", " << lo.y() << ", " << lo.z() << "] - [" << hi.x() << ", " << hi.y() << ", "
    << hi.z() << "]\n"
    << "  surface area: " << m.area_mm2 << " mm^2\n";
  if (m.closed) {
    t << "  closed, volume: " << std::abs(m.signed_volume_mm3) / 1000.0 << " ml\n";
  } else {
    t << "  open (" << m.boundary_edges << " boundary edges): no volume\n";
  }
  t << "  normals: " << (j["has_normals"].get<bool>() ? "yes" : "no")
    << ", colours: " << (j["has_colors"].get<bool>() ? "yes" : "no") << "\n";
  report.text = t.str();
  return report;
}

Report convertMesh(const std::filesystem::path& in, const std::filesystem::path& out, const ConvertOptions& options) {
  const TriangleMesh mesh = io::readMesh(in);
  io::MeshWriteOptions write;
  write.compress = options.compress;
  io::writeMesh(mesh, out, write);
  Report report;
  report.json["file"] = in.string();
  report.json["kind"] = "mesh";
  report.json["written"] = out.string();
  report.json["format"] = io::meshFormatName(io::meshFormatFromPath(out));
  report.json["vertices"] = mesh.vertexCount();
  report.json["faces"] = mesh.faceCount();
  report.text = "wrote " + out.string() + " (" + std::to_string(mesh.vertexCount()) + " vertices, " +
                std::to_string(mesh.faceCount()) + " faces)\n";
  return report;
}

}  // namespace mrsns::cli
