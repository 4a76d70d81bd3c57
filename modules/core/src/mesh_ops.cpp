#include "mrsns/core/mesh_ops.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "mrsns/core/error.h"

namespace mrsns {
namespace {

Eigen::Vector3d vertex(const TriangleMesh& mesh, std::int32_t index) {
  return mesh.vertices.row(index).transpose();
}

// Twice the area vector of a face (cross product of two edges).
Eigen::Vector3d faceAreaVector(const TriangleMesh& mesh, Eigen::Index f) {
  const Eigen::Vector3d a = vertex(mesh, mesh.faces(f, 0));
  const Eigen::Vector3d b = vertex(mesh, mesh.faces(f, 1));
  const Eigen::Vector3d c = vertex(mesh, mesh.faces(f, 2));
  return (b - a).cross(c - a);
}

void checkFinite(const PointsN3& m, const std::string& what, const char* field) {
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    if (!m.row(i).allFinite()) {
      std::ostringstream msg;
      msg << what << ": " << field << " row " << i << " is not finite (" << m(i, 0) << ", " << m(i, 1) << ", "
          << m(i, 2) << "); repair or re-export the mesh";
      throw InvalidArgumentError(msg.str());
    }
  }
}

}  // namespace

void validateMesh(const TriangleMesh& mesh, const std::string& what) {
  const Eigen::Index n = mesh.vertexCount();
  checkFinite(mesh.vertices, what, "vertex");
  for (Eigen::Index f = 0; f < mesh.faceCount(); ++f) {
    for (int k = 0; k < 3; ++k) {
      const std::int32_t v = mesh.faces(f, k);
      if (v < 0 || v >= n) {
        std::ostringstream msg;
        msg << what << ": face " << f << " references vertex " << v << " but the mesh has " << n
            << " vertices (valid indices 0.." << n - 1 << "); fix the face indices or reload the file";
        throw InvalidArgumentError(msg.str());
      }
    }
  }
  if (mesh.normals.rows() != 0) {
    if (mesh.normals.rows() != n) {
      throw InvalidArgumentError(what + ": has " + std::to_string(mesh.normals.rows()) + " normals for " +
                                 std::to_string(n) + " vertices; provide one normal per vertex or none");
    }
    checkFinite(mesh.normals, what, "normal");
  }
  if (mesh.colors.rows() != 0) {
    if (mesh.colors.rows() != n) {
      throw InvalidArgumentError(what + ": has " + std::to_string(mesh.colors.rows()) + " colors for " +
                                 std::to_string(n) + " vertices; provide one colour per vertex or none");
    }
    checkFinite(mesh.colors, what, "color");
  }
}

PointsN3 faceNormals(const TriangleMesh& mesh) {
  PointsN3 normals(mesh.faceCount(), 3);
  for (Eigen::Index f = 0; f < mesh.faceCount(); ++f) {
    const Eigen::Vector3d n = faceAreaVector(mesh, f);
    const double len = n.norm();
    normals.row(f) = len > 0.0 ? Eigen::RowVector3d((n / len).transpose()) : Eigen::RowVector3d::Zero();
  }
  return normals;
}

Eigen::VectorXd faceAreas(const TriangleMesh& mesh) {
  Eigen::VectorXd areas(mesh.faceCount());
  for (Eigen::Index f = 0; f < mesh.faceCount(); ++f) areas(f) = 0.5 * faceAreaVector(mesh, f).norm();
  return areas;
}

PointsN3 vertexNormals(const TriangleMesh& mesh) {
  PointsN3 normals = PointsN3::Zero(mesh.vertexCount(), 3);
  for (Eigen::Index f = 0; f < mesh.faceCount(); ++f) {
    // The unnormalised cross product is the normal weighted by twice the area.
    const Eigen::RowVector3d n = faceAreaVector(mesh, f).transpose();
    for (int k = 0; k < 3; ++k) normals.row(mesh.faces(f, k)) += n;
  }
  for (Eigen::Index v = 0; v < normals.rows(); ++v) {
    const double len = normals.row(v).norm();
    if (len > 0.0) normals.row(v) /= len;
  }
  return normals;
}

double surfaceArea(const TriangleMesh& mesh) {
  return faceAreas(mesh).sum();
}

double signedVolume(const TriangleMesh& mesh) {
  // Sum of signed tetrahedra against a reference point; using the centroid of
  // the bounds instead of the origin keeps cancellation small for meshes far
  // from the origin (CT coordinates).
  const Eigen::AlignedBox3d box = boundingBox(mesh);
  const Eigen::Vector3d ref = box.isEmpty() ? Eigen::Vector3d::Zero() : Eigen::Vector3d(box.center());
  double six_volume = 0.0;
  for (Eigen::Index f = 0; f < mesh.faceCount(); ++f) {
    const Eigen::Vector3d a = vertex(mesh, mesh.faces(f, 0)) - ref;
    const Eigen::Vector3d b = vertex(mesh, mesh.faces(f, 1)) - ref;
    const Eigen::Vector3d c = vertex(mesh, mesh.faces(f, 2)) - ref;
    six_volume += a.dot(b.cross(c));
  }
  return six_volume / 6.0;
}

bool isClosed(const TriangleMesh& mesh) {
  if (mesh.empty()) return false;
  // Half-edges bucketed by start vertex (CSR): finding an edge's twin scans
  // one vertex's few half-edges, O(faces) overall with no sort or hash.
  const auto nv = static_cast<std::size_t>(mesh.vertexCount());
  const auto m = static_cast<std::size_t>(mesh.faceCount());
  auto head = [&](std::size_t slot) { return static_cast<std::size_t>(mesh.faces(slot / 3, slot % 3)); };
  auto tail = [&](std::size_t slot) { return static_cast<std::size_t>(mesh.faces(slot / 3, (slot % 3 + 1) % 3)); };
  std::vector<std::size_t> start(nv + 1, 0);
  for (std::size_t slot = 0; slot < 3 * m; ++slot) ++start[head(slot) + 1];
  for (std::size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
  std::vector<std::size_t> fill(start.begin(), start.end() - 1);
  std::vector<std::size_t> slots(3 * m);
  for (std::size_t slot = 0; slot < 3 * m; ++slot) slots[fill[head(slot)]++] = slot;
  auto count = [&](std::size_t from, std::size_t to) {
    int n = 0;
    for (std::size_t i = start[from]; i < start[from + 1]; ++i) n += tail(slots[i]) == to ? 1 : 0;
    return n;
  };
  for (std::size_t slot = 0; slot < 3 * m; ++slot) {
    const std::size_t a = head(slot);
    const std::size_t b = tail(slot);
    if (a == b || count(a, b) != 1 || count(b, a) != 1) return false;
  }
  return true;
}

Eigen::AlignedBox3d boundingBox(const TriangleMesh& mesh) {
  Eigen::AlignedBox3d box;  // default-constructed box is empty
  for (Eigen::Index v = 0; v < mesh.vertexCount(); ++v) box.extend(mesh.vertices.row(v).transpose());
  return box;
}

Eigen::Vector3d vertexCentroid(const TriangleMesh& mesh) {
  if (mesh.vertexCount() == 0) {
    throw InvalidArgumentError("vertexCentroid: mesh '" + mesh.name + "' has no vertices; load a non-empty mesh");
  }
  return mesh.vertices.colwise().mean().transpose();
}

Eigen::Vector3d surfaceCentroid(const TriangleMesh& mesh) {
  Eigen::Vector3d weighted = Eigen::Vector3d::Zero();
  double total = 0.0;
  for (Eigen::Index f = 0; f < mesh.faceCount(); ++f) {
    const double area = 0.5 * faceAreaVector(mesh, f).norm();
    const Eigen::Vector3d center =
        (vertex(mesh, mesh.faces(f, 0)) + vertex(mesh, mesh.faces(f, 1)) + vertex(mesh, mesh.faces(f, 2))) / 3.0;
    weighted += area * center;
    total += area;
  }
  if (!(total > 0.0)) {
    throw InvalidArgumentError("surfaceCentroid: mesh '" + mesh.name +
                               "' has zero surface area; use vertexCentroid for point-like meshes");
  }
  return weighted / total;
}

TriangleMesh transformMesh(const TriangleMesh& mesh, const Eigen::Isometry3d& to_T_from, const std::string& to_frame) {
  TriangleMesh out = mesh;
  const Eigen::Matrix3d rotation = to_T_from.linear();
  const Eigen::Vector3d translation = to_T_from.translation();
  // Row-major N x 3: p' = p R^T + t^T for all rows at once.
  out.vertices = (mesh.vertices * rotation.transpose()).rowwise() + translation.transpose();
  if (mesh.normals.rows() != 0) out.normals = mesh.normals * rotation.transpose();
  if (!to_frame.empty()) out.frame = to_frame;
  return out;
}

TriangleMesh mergeMeshes(std::span<const TriangleMesh> meshes) {
  TriangleMesh out;
  Eigen::Index nv = 0;
  Eigen::Index nf = 0;
  bool all_normals = !meshes.empty();
  bool all_colors = !meshes.empty();
  for (const TriangleMesh& m : meshes) {
    nv += m.vertexCount();
    nf += m.faceCount();
    all_normals = all_normals && m.normals.rows() == m.vertexCount();
    all_colors = all_colors && m.colors.rows() == m.vertexCount();
    if (!m.frame.empty()) {
      if (out.frame.empty()) {
        out.frame = m.frame;
      } else if (out.frame != m.frame) {
        throw FrameError("mergeMeshes: meshes are in different frames ('" + out.frame + "' and '" + m.frame +
                         "'); transform them into one frame first");
      }
    }
  }
  if (nv > std::numeric_limits<std::int32_t>::max()) {
    throw InvalidArgumentError("mergeMeshes: the merged mesh would have " + std::to_string(nv) +
                               " vertices, more than 32-bit face indices can address; merge fewer meshes");
  }
  out.vertices.resize(nv, 3);
  out.faces.resize(nf, 3);
  if (all_normals) out.normals.resize(nv, 3);
  if (all_colors) out.colors.resize(nv, 3);
  Eigen::Index v0 = 0;
  Eigen::Index f0 = 0;
  for (const TriangleMesh& m : meshes) {
    out.vertices.middleRows(v0, m.vertexCount()) = m.vertices;
    if (all_normals) out.normals.middleRows(v0, m.vertexCount()) = m.normals;
    if (all_colors) out.colors.middleRows(v0, m.vertexCount()) = m.colors;
    out.faces.middleRows(f0, m.faceCount()) = m.faces.array() + static_cast<std::int32_t>(v0);
    v0 += m.vertexCount();
    f0 += m.faceCount();
  }
  if (meshes.size() == 1) out.name = meshes.front().name;
  return out;
}

CleanMeshResult cleanMesh(const TriangleMesh& mesh, const CleanMeshOptions& options) {
  validateMesh(mesh, "cleanMesh input '" + mesh.name + "'");
  CleanMeshResult result;
  std::vector<Eigen::Index> kept_faces;
  kept_faces.reserve(static_cast<std::size_t>(mesh.faceCount()));
  for (Eigen::Index f = 0; f < mesh.faceCount(); ++f) {
    const auto a = mesh.faces(f, 0);
    const auto b = mesh.faces(f, 1);
    const auto c = mesh.faces(f, 2);
    if (a == b || b == c || a == c) continue;
    const double area = 0.5 * faceAreaVector(mesh, f).norm();
    if (!(area > options.min_face_area)) continue;
    kept_faces.push_back(f);
  }
  result.removed_faces = mesh.faceCount() - static_cast<Eigen::Index>(kept_faces.size());

  result.old_to_new.assign(static_cast<std::size_t>(mesh.vertexCount()), -1);
  for (const Eigen::Index f : kept_faces) {
    for (int k = 0; k < 3; ++k) result.old_to_new[static_cast<std::size_t>(mesh.faces(f, k))] = 0;
  }
  std::int32_t next = 0;
  for (auto& index : result.old_to_new) {
    if (index == 0) index = next++;
  }
  result.removed_vertices = mesh.vertexCount() - next;

  TriangleMesh& out = result.mesh;
  out.name = mesh.name;
  out.frame = mesh.frame;
  out.vertices.resize(next, 3);
  if (mesh.normals.rows() != 0) out.normals.resize(next, 3);
  if (mesh.colors.rows() != 0) out.colors.resize(next, 3);
  for (Eigen::Index v = 0; v < mesh.vertexCount(); ++v) {
    const std::int32_t nv = result.old_to_new[static_cast<std::size_t>(v)];
    if (nv < 0) continue;
    out.vertices.row(nv) = mesh.vertices.row(v);
    if (mesh.normals.rows() != 0) out.normals.row(nv) = mesh.normals.row(v);
    if (mesh.colors.rows() != 0) out.colors.row(nv) = mesh.colors.row(v);
  }
  out.faces.resize(static_cast<Eigen::Index>(kept_faces.size()), 3);
  for (std::size_t i = 0; i < kept_faces.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      out.faces(static_cast<Eigen::Index>(i), k) =
          result.old_to_new[static_cast<std::size_t>(mesh.faces(kept_faces[i], k))];
    }
  }
  return result;
}

}  // namespace mrsns
