#pragma once
// A triangle surface mesh in one named frame, in millimetres.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace mrsns {

/// Vertices (one row per vertex, mm), triangles (one row per face, indices
/// into vertices, counter-clockwise seen from outside) and optional per-vertex
/// normals and scalars. `frame` names the coordinate frame of the vertices
/// (e.g. "CT", "Reference"); empty when unknown.
struct TriangleMesh {
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> vertices;
  Eigen::Matrix<std::int32_t, Eigen::Dynamic, 3, Eigen::RowMajor> faces;
  /// Unit vertex normals, same row count as vertices, or empty.
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> normals;
  /// Optional per-vertex colour, RGB in [0, 1], same row count as vertices, or empty.
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> colors;
  std::string name;
  std::string frame;

  [[nodiscard]] Eigen::Index vertexCount() const { return vertices.rows(); }
  [[nodiscard]] Eigen::Index faceCount() const { return faces.rows(); }
  [[nodiscard]] bool empty() const { return vertices.rows() == 0 || faces.rows() == 0; }
};

}  // namespace mrsns
