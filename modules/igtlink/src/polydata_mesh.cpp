#include "mrsns/igtlink/polydata_mesh.h"

#include "mrsns/core/error.h"

namespace mrsns::igtlink {

PolyDataContent polyDataFromMesh(const TriangleMesh& mesh) {
  PolyDataContent p;
  p.points = mesh.vertices;
  const auto nv = static_cast<std::int64_t>(mesh.vertices.rows());
  p.polygons.offsets.resize(static_cast<std::size_t>(mesh.faces.rows()) + 1);
  p.polygons.indices.resize(static_cast<std::size_t>(mesh.faces.rows()) * 3);
  p.polygons.offsets[0] = 0;
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    for (int k = 0; k < 3; ++k) {
      const std::int32_t i = mesh.faces(f, k);
      if (i < 0 || i >= nv) {
        throw InvalidArgumentError("mesh '" + mesh.name + "' face " + std::to_string(f) + " has vertex index " +
                                   std::to_string(i) + " outside [0, " + std::to_string(nv) + ")");
      }
      p.polygons.indices[static_cast<std::size_t>(f) * 3 + static_cast<std::size_t>(k)] = static_cast<std::uint32_t>(i);
    }
    p.polygons.offsets[static_cast<std::size_t>(f) + 1] = static_cast<std::uint32_t>((f + 1) * 3);
  }
  if (mesh.faces.rows() == 0) p.polygons.offsets.clear();
  if (mesh.normals.rows() == mesh.vertices.rows() && mesh.normals.rows() > 0) {
    PolyDataAttribute a;
    a.kind = AttributeKind::kNormal;
    a.name = "Normals";
    a.data = mesh.normals;
    p.attributes.push_back(std::move(a));
  }
  if (mesh.colors.rows() == mesh.vertices.rows() && mesh.colors.rows() > 0) {
    PolyDataAttribute a;
    a.kind = AttributeKind::kRgba;
    a.name = "Colors";
    a.data.resize(mesh.colors.rows(), 4);
    a.data.leftCols(3) = mesh.colors;
    a.data.col(3).setOnes();
    p.attributes.push_back(std::move(a));
  }
  return p;
}

TriangleMesh meshFromPolyData(const PolyDataContent& p) {
  TriangleMesh mesh;
  mesh.vertices = p.points;
  const std::size_t np = static_cast<std::size_t>(p.points.rows());
  std::vector<std::int32_t> tris;
  const auto check = [np](std::uint32_t i, std::string_view what) {
    if (i >= np) {
      throw FormatError("POLYDATA " + std::string(what) + " index " + std::to_string(i) + " is beyond the " +
                        std::to_string(np) + " points");
    }
    return static_cast<std::int32_t>(i);
  };
  tris.reserve(p.polygons.indices.size());
  for (std::size_t c = 0; c < p.polygons.size(); ++c) {
    const auto cell = p.polygons.cell(c);
    if (cell.size() < 3) throw FormatError("POLYDATA polygon " + std::to_string(c) + " has fewer than 3 corners");
    for (std::size_t k = 1; k + 1 < cell.size(); ++k) {  // fan from the first corner
      tris.push_back(check(cell[0], "polygon"));
      tris.push_back(check(cell[k], "polygon"));
      tris.push_back(check(cell[k + 1], "polygon"));
    }
  }
  for (std::size_t c = 0; c < p.triangle_strips.size(); ++c) {
    const auto cell = p.triangle_strips.cell(c);
    if (cell.size() < 3) throw FormatError("POLYDATA triangle strip " + std::to_string(c) + " has fewer than 3 points");
    for (std::size_t k = 0; k + 2 < cell.size(); ++k) {
      // Every other triangle of a strip is flipped to keep a consistent winding.
      const bool odd = (k % 2) == 1;
      tris.push_back(check(cell[k], "strip"));
      tris.push_back(check(cell[odd ? k + 2 : k + 1], "strip"));
      tris.push_back(check(cell[odd ? k + 1 : k + 2], "strip"));
    }
  }
  mesh.faces.resize(static_cast<Eigen::Index>(tris.size() / 3), 3);
  std::copy(tris.begin(), tris.end(), mesh.faces.data());
  for (const auto& a : p.attributes) {
    if (a.cell_data || a.data.rows() != p.points.rows()) continue;
    if (a.kind == AttributeKind::kNormal && mesh.normals.rows() == 0) mesh.normals = a.data;
    if (a.kind == AttributeKind::kRgba && mesh.colors.rows() == 0) mesh.colors = a.data.leftCols(3);
  }
  return mesh;
}

}  // namespace mrsns::igtlink
