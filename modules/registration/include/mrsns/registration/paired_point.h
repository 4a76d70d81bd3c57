#pragma once
// Paired-point (landmark) registration: the rigid (optionally isotropically
// scaled) transform that best maps `moving` points onto their `fixed`
// partners in the least-squares sense (Horn 1987 / Umeyama 1991), with the
// quality figures users need to trust it: fiducial registration error (FRE)
// overall and per point, the fiducial localisation error (FLE) it implies,
// target registration error (TRE) predicted at any target (Fitzpatrick and
// West 2001), and leave-one-out errors that single out a wrong point.
#include <Eigen/Geometry>
#include <optional>
#include <span>
#include <vector>

namespace mrsns::registration {

struct PairedPointOptions {
  /// Also estimate an isotropic scale (similarity transform).
  bool estimate_scale = false;
  /// Refuse point sets whose second principal extent is below this fraction
  /// of the first (points on a line leave the rotation about it free).
  double min_collinearity_ratio = 1e-3;
  /// Compute leave-one-out errors (needs >= 4 points).
  bool leave_one_out = true;
  /// A point is flagged when its leave-one-out error exceeds this many times
  /// the TRE predicted at it (from the FLE of the other points) and at
  /// least `outlier_min_error_mm`.
  double outlier_factor = 3.0;
  double outlier_min_error_mm = 1.0;
};

struct PairedPointResult {
  /// Maps moving points to fixed: fixed ~= scale * R * moving + t. With
  /// estimate_scale the linear part holds scale * R (so this is an affine
  /// similarity, not an isometry); use `rotation` and `scale` separately.
  Eigen::Affine3d fixed_T_moving = Eigen::Affine3d::Identity();
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  double scale = 1.0;
  /// RMS fiducial registration error, mm.
  double fre_rms_mm = 0.0;
  /// |fixed_T_moving * moving_i - fixed_i| per point, mm.
  std::vector<double> fre_mm;
  /// FLE implied by the FRE: FRE_rms / sqrt(1 - 2/N) (isotropic FLE model).
  double fle_rms_estimate_mm = 0.0;
  /// Error at point i when it is left out of the registration (mm); empty
  /// when not computed.
  std::vector<double> leave_one_out_mm;
  /// Points whose leave-one-out error is implausible (likely mislabelled or
  /// mislocalised), worst first.
  std::vector<int> suspect_points;
  /// Principal extents (RMS distance from the principal axes) of the moving
  /// points, largest first, mm: small values mean a poor configuration.
  Eigen::Vector3d principal_rms_mm = Eigen::Vector3d::Zero();
};

/// Throws InvalidArgumentError for mismatched counts or NaN/inf, and
/// ComputationError for fewer than 3 points or (nearly) collinear points.
PairedPointResult registerPairedPoints(std::span<const Eigen::Vector3d> moving, std::span<const Eigen::Vector3d> fixed,
                                       const PairedPointOptions& options = {});

/// Fitzpatrick-West prediction of the RMS TRE at `target` (in the moving
/// frame) for fiducials `moving` localised with RMS error `fle_rms_mm`:
///   TRE^2 = FLE^2 / N * (1 + 1/3 * sum_k d_k^2 / f_k^2)
/// where d_k is the target's distance from principal axis k of the fiducial
/// configuration and f_k the fiducials' RMS distance from that axis.
double predictTreRms(std::span<const Eigen::Vector3d> moving, const Eigen::Vector3d& target, double fle_rms_mm);

/// Expected RMS FRE for N fiducials with RMS localisation error FLE:
/// FRE^2 = (1 - 2/N) FLE^2.
double expectedFreRms(int point_count, double fle_rms_mm);

}  // namespace mrsns::registration
