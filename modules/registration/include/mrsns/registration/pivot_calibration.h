#pragma once
// Pivot calibration of a tracked pointer (paper 000 §2.3): the tool is
// pivoted about its tip held in a divot, so every pose satisfies
//   tracker_T_marker_i * tip_marker = pivot_tracker.
// Solved by linear least squares over all poses (algebraic), optionally
// robustly (RANSAC on minimal subsets, then iteratively reweighted refinement
// of the inliers). Refuses pose sets that cannot determine the tip: too few,
// a static tool, too small a rotation range, or rotation about one axis only.
#include <Eigen/Geometry>
#include <span>
#include <vector>

namespace mrsns::registration {

struct PivotOptions {
  /// Fewest poses accepted.
  int min_poses = 10;
  /// Smallest rotation range accepted: the largest angle between any pose and
  /// the mean orientation, in radians (PLUS and SlicerIGT warn below ~20 deg).
  double min_rotation_range = 10.0 * 3.14159265358979323846 / 180.0;
  /// Refuse when the least-squares system's condition number exceeds this.
  /// It grows as ~2 / (rotation range in rad): ~10 for a 20 deg pivot, ~1000
  /// for a tool lying still with tracker jitter, unbounded for rotation about
  /// one axis only (the tip is then unobservable along that axis).
  double max_condition_number = 200.0;
  /// Robust variant: RANSAC over minimal subsets, then reweighted refinement.
  bool robust = false;
  /// Inlier threshold on the per-pose residual (mm); ~3-4x the tracker's
  /// 3D RMS noise.
  double inlier_threshold_mm = 1.0;
  int ransac_iterations = 200;
  unsigned ransac_seed = 42;
};

struct PivotResult {
  /// Tip position in the marker frame (the tool's calibration), mm.
  Eigen::Vector3d tip_marker = Eigen::Vector3d::Zero();
  /// Pivot point in the tracker (or reference) frame of the input poses, mm.
  Eigen::Vector3d pivot_tracker = Eigen::Vector3d::Zero();
  /// RMS of the per-pose residuals over the inliers, mm.
  double rms_mm = 0.0;
  /// Largest inlier residual, mm.
  double max_residual_mm = 0.0;
  /// |tracker_T_marker_i * tip - pivot| for every pose (outliers included), mm.
  std::vector<double> residuals_mm;
  /// true for poses used in the final fit.
  std::vector<bool> inliers;
  int inlier_count = 0;
  /// Largest angle of any pose from the mean orientation, radians.
  double rotation_range = 0.0;
  /// Condition number of the least-squares system (ratio of extreme singular values).
  double condition_number = 0.0;
};

/// How far a pivoting has gone, for live feedback while it is recorded: the
/// rotation vectors of the poses about their mean orientation, spread along
/// their two principal directions. A pivot needs rotation about two axes
/// (about one only, the tip is unobservable along it): `second_range` stays
/// near the tracker's jitter when the tool is swung in one plane.
struct PivotCoverage {
  std::size_t poses = 0;
  double first_range = 0.0;   ///< extent (max - min) along the direction of largest variance, radians
  double second_range = 0.0;  ///< extent along the direction of second largest variance, radians
};

/// Empty input gives zeros. Cost O(n); meant to be called a few times a
/// second on everything recorded so far.
PivotCoverage pivotCoverage(std::span<const Eigen::Isometry3d> tracker_T_marker);

/// The largest angle between any pose's rotation and their mean (radians, 0
/// for no poses): what calibratePivot checks against min_rotation_range, so a
/// live acquisition can keep recording until it would pass.
double pivotRotationRange(std::span<const Eigen::Isometry3d> tracker_T_marker);

/// Throws InvalidArgumentError for NaN poses, ComputationError for degenerate
/// motion (the message says what to do: pivot more, in two directions, ...):
/// among others when pivotCoverage's second range is below min_rotation_range
/// (a swing in one plane).
PivotResult calibratePivot(std::span<const Eigen::Isometry3d> tracker_T_marker, const PivotOptions& options = {});

}  // namespace mrsns::registration
