#pragma once
// The Unity convention for HMD clients (HoloLens apps built with Unity):
// left-handed axes and metres, where MR-SNS, OpenIGTLink and Slicer are
// right-handed and in millimetres.
//
// The conversion is one fixed linear map on points, applied to meshes and
// transforms alike so that a converted transform moves a converted mesh
// exactly as the original transform moves the original mesh:
//
//   p_unity = s * F * p_mm,   F = diag(-1, 1, 1) (flip x),   s = 0.001 m/mm
//
// - Transform a_T_b = [R t; 0 1]  ->  [F R F, s F t; 0 1]
//   (F R F is again a rotation, det +1; conjugation keeps the chain order:
//   unity(a_T_b * b_T_c) = unity(a_T_b) * unity(b_T_c)).
// - Mesh: vertices -> s F v, normals -> F n, and each triangle's winding is
//   reversed (i0, i2, i1) because the mirror flips handedness: without it
//   Unity's back-face culling would hide the outside of every model.
#include <Eigen/Core>

#include "mrsns/core/mesh.h"

namespace mrsns::tracking {

inline constexpr double kUnityMetresPerMm = 0.001;

/// a_T_b in MR-SNS (right-handed, mm) -> Unity (left-handed, m).
Eigen::Matrix4d transformToUnity(const Eigen::Matrix4d& a_T_b);
/// Inverse of transformToUnity.
Eigen::Matrix4d transformFromUnity(const Eigen::Matrix4d& a_T_b_unity);
/// Mesh in MR-SNS convention -> Unity (vertices, normals, winding; colours kept).
TriangleMesh meshToUnity(const TriangleMesh& mesh);
/// Inverse of meshToUnity.
TriangleMesh meshFromUnity(const TriangleMesh& mesh_unity);

}  // namespace mrsns::tracking
