#pragma once
// Virtual-physical calibration with the tracked calibration cube (paper 001,
// §II.A, Eq. 2-3). The user lines the physical cube up with its hologram; the
// cube's vertices, digitised once in the cube-marker frame (P_i^Ver), then sit
// at the hologram's fiducials P_i^Hol, which are defined in the HoloLens frame:
//
//   tracker_T_cube * P_i^Ver = tracker_T_hololens * P_i^Hol        (Eq. 2)
//
// tracker_T_hololens (T_Hol^Tra in the paper) is solved two ways from the
// pairs (P_i^Tra = tracker_T_cube * P_i^Ver, P_i^Hol):
// - the affine map by the Direct Linear Transformation (12 parameters, with
//   Hartley normalisation of both point sets), as the paper does: it absorbs
//   anisotropic errors such as the HMD's depth misperception but is not a
//   pose, so its singular values are reported as a deviation from rigidity;
// - the rigid map (Horn/Umeyama through registration::registerPairedPoints),
//   the transform the MR chain (Eq. 1) needs.
#include <Eigen/Geometry>
#include <span>
#include <vector>

namespace mrsns::hmd {

struct CubeCalibrationOptions {
  /// Point sets whose smallest principal extent is below this fraction of the largest are
  /// refused as coplanar (the affine map is then undetermined off the plane).
  double min_planarity_ratio = 0.02;
  /// Second principal extent below this fraction of the largest: collinear.
  double min_collinearity_ratio = 0.02;
};

struct CubeCalibrationResult {
  /// Rigid estimate: p_tracker = tracker_T_hololens * p_hololens.
  Eigen::Isometry3d tracker_T_hololens = Eigen::Isometry3d::Identity();
  /// |tracker_T_hololens * P_i^Hol - P_i^Tra| per pair (the Eq. 3 residual), mm.
  std::vector<double> rigid_residuals_mm;
  double rigid_rms_mm = 0.0;

  /// Affine (DLT) estimate, bottom row [0 0 0 1].
  Eigen::Matrix4d tracker_A_hololens = Eigen::Matrix4d::Identity();
  std::vector<double> affine_residuals_mm;
  double affine_rms_mm = 0.0;
  /// Condition number (largest / smallest singular value) of the normalised 3N x 12 DLT design
  /// matrix: large values mean the fiducials barely span 3D.
  double dlt_condition_number = 0.0;
  /// Singular values of the affine's 3x3 linear part, largest first (1, 1, 1 for a rigid map).
  Eigen::Vector3d affine_singular_values = Eigen::Vector3d::Ones();
  /// max_k |s_k - 1|: scale/shear the affine map needed beyond a rotation.
  double affine_rigidity_deviation = 0.0;
  /// Principal RMS extents of the hologram fiducials, largest first (mm).
  Eigen::Vector3d principal_rms_mm = Eigen::Vector3d::Zero();
};

/// P_i^Tra = tracker_T_cube * P_i^Ver for each cube vertex.
std::vector<Eigen::Vector3d> cubeFiducialsInTracker(const Eigen::Isometry3d& tracker_T_cube,
                                                    std::span<const Eigen::Vector3d> vertex_cube);

/// Cube vertices in the cube-marker frame from stylus digitisation: tip_tracker[i] is the
/// stylus tip (tracker frame) on vertex i while the cube marker was at tracker_T_cube[i]
/// (one pose per tip, or a single pose for all). Throws InvalidArgumentError on count
/// mismatch or non-finite values.
std::vector<Eigen::Vector3d> cubeVerticesFromDigitisation(std::span<const Eigen::Vector3d> tip_tracker,
                                                          std::span<const Eigen::Isometry3d> tracker_T_cube);

/// Solves Eq. 2-3 for tracker_T_hololens from N >= 4 pairs. Throws InvalidArgumentError for
/// fewer than 4 pairs, mismatched counts, non-finite values, or collinear/coplanar points.
CubeCalibrationResult calibrateCube(std::span<const Eigen::Vector3d> fiducial_tracker,
                                    std::span<const Eigen::Vector3d> fiducial_hololens,
                                    const CubeCalibrationOptions& options = {});

/// Principal RMS extents of a point set (square roots of the covariance eigenvalues), largest
/// first, mm.
Eigen::Vector3d principalExtents(std::span<const Eigen::Vector3d> points);

}  // namespace mrsns::hmd
