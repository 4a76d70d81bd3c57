#pragma once
// Spin calibration: the tool is rotated about its own shaft with the tip in a
// divot; the shaft direction in the marker frame is the common rotation axis
// of the relative rotations marker_0_T_marker_i.
#include <Eigen/Geometry>
#include <span>
#include <vector>

namespace mrsns::registration {

struct SpinOptions {
  int min_poses = 10;
  /// Smallest spin accepted (largest relative rotation angle), radians.
  double min_spin_angle = 30.0 * 3.14159265358979323846 / 180.0;
};

struct SpinResult {
  /// Unit shaft direction in the marker frame. Its sign is chosen to point
  /// from the marker origin towards `tip_marker` when a tip is given, else
  /// towards positive z.
  Eigen::Vector3d shaft_marker = Eigen::Vector3d::UnitZ();
  /// Largest relative rotation angle covered, radians.
  double spin_angle = 0.0;
  /// RMS angle between each pose's own rotation axis and the shaft, radians
  /// (the tool wobbling off its axis raises it).
  double axis_rms_angle = 0.0;
  /// Ratio of the two smallest singular values of the axis system: large is
  /// well determined; near 1 means no single axis (not a spin).
  double axis_distinctness = 0.0;
};

/// The tool tip's frame from a pivot and a spin calibration, as marker_T_tip
/// (PLUS's convention): origin at the tip, z along the shaft pointing away
/// from the marker (points ahead of the tip have positive z), x the marker's x
/// made perpendicular to the shaft (its y when the shaft lies along its x).
/// Throws InvalidArgumentError for a zero shaft.
Eigen::Isometry3d tipFrame(const Eigen::Vector3d& tip_marker, const Eigen::Vector3d& shaft_marker);

/// Throws ComputationError when the tool did not spin enough or not about
/// one axis.
SpinResult calibrateSpin(std::span<const Eigen::Isometry3d> tracker_T_marker, const SpinOptions& options = {},
                         const Eigen::Vector3d* tip_marker = nullptr);

}  // namespace mrsns::registration
