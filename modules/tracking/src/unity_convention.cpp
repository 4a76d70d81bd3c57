#include "mrsns/tracking/unity_convention.h"

namespace mrsns::tracking {
namespace {

const Eigen::Matrix3d& flipX() {
  static const Eigen::Matrix3d f = Eigen::Vector3d(-1.0, 1.0, 1.0).asDiagonal();
  return f;
}

Eigen::Matrix4d convert(const Eigen::Matrix4d& m, double scale) {
  Eigen::Matrix4d out = Eigen::Matrix4d::Identity();
  out.block<3, 3>(0, 0) = flipX() * m.block<3, 3>(0, 0) * flipX();
  out.block<3, 1>(0, 3) = scale * (flipX() * m.block<3, 1>(0, 3));
  return out;
}

TriangleMesh convertMesh(const TriangleMesh& mesh, double scale) {
  TriangleMesh out = mesh;
  out.vertices.col(0) *= -scale;
  out.vertices.col(1) *= scale;
  out.vertices.col(2) *= scale;
  if (out.normals.rows() > 0) out.normals.col(0) *= -1.0;
  if (out.faces.rows() > 0) out.faces.col(1).swap(out.faces.col(2));
  return out;
}

}  // namespace

Eigen::Matrix4d transformToUnity(const Eigen::Matrix4d& a_T_b) {
  return convert(a_T_b, kUnityMetresPerMm);
}
Eigen::Matrix4d transformFromUnity(const Eigen::Matrix4d& a_T_b_unity) {
  return convert(a_T_b_unity, 1.0 / kUnityMetresPerMm);
}
TriangleMesh meshToUnity(const TriangleMesh& mesh) {
  return convertMesh(mesh, kUnityMetresPerMm);
}
TriangleMesh meshFromUnity(const TriangleMesh& mesh_unity) {
  return convertMesh(mesh_unity, 1.0 / kUnityMetresPerMm);
}

}  // namespace mrsns::tracking
