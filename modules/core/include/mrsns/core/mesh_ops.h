#pragma once
// Whole-mesh operations on mrsns::TriangleMesh: validation, normals, area,
// volume, bounds, rigid transformation, merging and clean-up.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "mrsns/core/mesh.h"

namespace mrsns {

/// N x 3 row-major points (mm), the layout of TriangleMesh::vertices.
using PointsN3 = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

/// Throws InvalidArgumentError when a face index is out of range, a vertex,
/// normal or colour is NaN/inf, or normals/colors have a row count other than
/// 0 or vertexCount(). `what` names the mesh in the message (e.g. the file).
void validateMesh(const TriangleMesh& mesh, const std::string& what = "mesh");

/// Unit normal of each face from its counter-clockwise winding; a zero row
/// for a degenerate (zero-area) face.
[[nodiscard]] PointsN3 faceNormals(const TriangleMesh& mesh);

/// Area of each face (mm^2).
[[nodiscard]] Eigen::VectorXd faceAreas(const TriangleMesh& mesh);

/// Unit vertex normals, the area-weighted mean of the adjacent face normals;
/// a zero row for a vertex no non-degenerate face uses.
[[nodiscard]] PointsN3 vertexNormals(const TriangleMesh& mesh);

/// Total surface area (mm^2).
[[nodiscard]] double surfaceArea(const TriangleMesh& mesh);

/// Enclosed volume by the divergence theorem (mm^3): positive for a closed
/// mesh wound counter-clockwise seen from outside, negative when inside-out.
/// Meaningless for an open mesh (see isClosed()).
[[nodiscard]] double signedVolume(const TriangleMesh& mesh);

/// True when every edge is shared by exactly two faces in opposite directions
/// (a closed, consistently oriented 2-manifold edge structure).
[[nodiscard]] bool isClosed(const TriangleMesh& mesh);

/// Axis-aligned bounds of the vertices; an empty box for an empty mesh.
[[nodiscard]] Eigen::AlignedBox3d boundingBox(const TriangleMesh& mesh);

/// Mean of the vertices. Throws InvalidArgumentError for a mesh without vertices.
[[nodiscard]] Eigen::Vector3d vertexCentroid(const TriangleMesh& mesh);

/// Area-weighted centroid of the surface (independent of tessellation
/// density). Throws InvalidArgumentError for a mesh with zero area.
[[nodiscard]] Eigen::Vector3d surfaceCentroid(const TriangleMesh& mesh);

/// The mesh with vertices mapped by `to_T_from` and normals rotated. The
/// result's frame is `to_frame` when given, otherwise unchanged.
[[nodiscard]] TriangleMesh transformMesh(const TriangleMesh& mesh, const Eigen::Isometry3d& to_T_from,
                                         const std::string& to_frame = {});

/// Concatenates meshes (face indices shifted). Normals/colors are kept only
/// when every input has them. Throws FrameError when the inputs name
/// different non-empty frames.
[[nodiscard]] TriangleMesh mergeMeshes(std::span<const TriangleMesh> meshes);

struct CleanMeshOptions {
  /// Faces with area <= this (mm^2) are removed, besides faces that repeat a vertex.
  double min_face_area = 0.0;
};

struct CleanMeshResult {
  TriangleMesh mesh;
  Eigen::Index removed_faces = 0;
  Eigen::Index removed_vertices = 0;
  /// For each input vertex its index in `mesh`, or -1 when it was removed.
  std::vector<std::int32_t> old_to_new;
};

/// Removes degenerate faces, then vertices no face references.
[[nodiscard]] CleanMeshResult cleanMesh(const TriangleMesh& mesh, const CleanMeshOptions& options = {});

}  // namespace mrsns
