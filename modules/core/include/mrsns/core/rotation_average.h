#pragma once
// Averages of rotations and poses: the multi-view averaging of calibration
// matrices in paper 001 (MR-SNS), Eq. 18-20. Eq. 19 defines the mean as
// argmin_R sum_i d(R_i, R)^2; Eq. 20 picks the Riemannian (geodesic) distance
// d = ||Log(R_i^T R)||, whose minimiser is the Karcher mean, and the mean
// translation is the arithmetic mean of the T_i.
//
// Three choices of d are offered (Hartley, Trumpf, Dai, Li, "Rotation
// averaging", IJCV 2013):
// - Riemannian L2 (Eq. 20, the default): fixed-point iteration in the tangent
//   space, R <- R * Exp(mean_i Log(R^T R_i)), started from the chordal mean.
// - Chordal L2: the rotation closest to sum_i w_i R_i (SVD projection); closed
//   form, equal to the Karcher mean to second order for concentrated data.
// - Riemannian L1 (geodesic median): Weiszfeld iteration in the tangent space
//   (Hartley, Aftab, Trumpf, CVPR 2011), robust to outlying estimates.
// All three are invariant to left and right multiplication of the inputs by a
// fixed rotation.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <span>
#include <vector>

namespace mrsns {

enum class RotationMeanMethod {
  kRiemannianL2,  // Karcher mean, Eq. 20 of paper 001
  kChordalL2,     // SVD projection of the (weighted) sum of matrices
  kRiemannianL1,  // geodesic median by Weiszfeld's algorithm
};

struct RotationAverageOptions {
  RotationMeanMethod method = RotationMeanMethod::kRiemannianL2;
  /// Iteration limit of the Riemannian methods.
  int max_iterations = 200;
  /// The iteration stops when its tangent step is shorter than this (radians).
  double step_tolerance = 1e-12;
  /// Weiszfeld only: inputs closer than this (radians) to the current estimate count as
  /// coinciding with it (Vardi-Zhang step) instead of dividing by a zero distance.
  double l1_min_residual = 1e-12;
  /// Inputs whose max |R^T R - I| exceeds this are refused; inputs within it (e.g. matrices
  /// printed with few digits) are projected onto SO(3) before averaging.
  double orthonormality_tolerance = 1e-3;
};

struct RotationAverageResult {
  Eigen::Matrix3d mean = Eigen::Matrix3d::Identity();
  /// Iterations of the tangent-space update (0 for the closed-form chordal mean).
  int iterations = 0;
  /// False when the iteration limit was reached before the step fell below tolerance.
  bool converged = false;
  /// Geodesic angle of each input from the mean (radians), in input order.
  std::vector<double> residual_angles;
  /// Unweighted RMS and maximum of residual_angles (radians).
  double rms_angle = 0.0;
  double max_angle = 0.0;
};

/// Mean of the rotations by the method in options, with optional non-negative weights (empty
/// = equal weights; otherwise one per rotation, not all zero). Throws InvalidArgumentError on
/// empty input, a non-finite or non-orthonormal rotation, or bad weights.
RotationAverageResult averageRotations(std::span<const Eigen::Matrix3d> rotations,
                                       const RotationAverageOptions& options = {},
                                       std::span<const double> weights = {});

struct PoseAverageResult {
  /// Mean rotation (as chosen by the options) and weighted mean translation (Eq. 20 and the
  /// line after it in paper 001).
  Eigen::Isometry3d mean = Eigen::Isometry3d::Identity();
  RotationAverageResult rotation;
  /// Distance of each input's translation from the mean translation (mm), in input order.
  std::vector<double> translation_residuals;
  double translation_rms = 0.0;
  double translation_max = 0.0;
};

/// Average of rigid transforms that estimate the same calibration (Eq. 18-20 of paper 001).
/// Same validation as averageRotations.
PoseAverageResult averagePoses(std::span<const Eigen::Isometry3d> poses, const RotationAverageOptions& options = {},
                               std::span<const double> weights = {});

}  // namespace mrsns
