#pragma once
// Directional descriptive statistics of repeated estimates of one rigid
// calibration, as reported in paper 000 (HMD hand-eye calibration), Section
// 2.7 and Section 3.3, Tables 1 and 2: for each axis of the estimated
// orthonormal basis (the x, y and z columns of the rotation) the circular
// variance and circular standard deviation, the "axis deviations" (angle of
// each estimate's axis from the mean direction, degrees, mean +- std), and the
// "axis offsets" (translation components, mean +- std).
//
// The paper cites the standard definitions (Mardia and Jupp, Directional
// Statistics, 2000, Sec. 9.2 for the sphere, 2.3 for the circle); with unit
// vectors x_1..x_n:
//   resultant          S = sum_i x_i
//   mean direction     m = S / |S|
//   mean resultant length  Rbar = |S| / n           in [0, 1]
//   circular variance  V = 1 - Rbar                 (0 = all identical)
//   circular std       sigma = sqrt(-2 ln Rbar)     (radians)
// Table 1 is consistent with these (3.18e-6 -> sqrt(-2 ln(1 - 3.18e-6)) =
// 2.52e-3). For concentrated data 1 - Rbar is far below 1 and subtracting it
// from 1 loses digits, so V is computed as mean_i |x_i - m|^2 / 2, which equals
// 1 - Rbar exactly (Rbar = mean_i m.x_i) without cancellation, and sigma with
// log1p. Linear standard deviations use the sample (n - 1) form; they are 0 for
// a single estimate.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstddef>
#include <span>
#include <vector>

namespace mrsns {

/// Statistics of a set of directions (unit vectors) on the sphere.
struct AxisStatistics {
  Eigen::Vector3d mean_direction = Eigen::Vector3d::UnitX();
  double mean_resultant_length = 1.0;  // Rbar
  double circular_variance = 0.0;      // 1 - Rbar
  double circular_std = 0.0;           // sqrt(-2 ln Rbar), radians
  double circular_std_deg = 0.0;
  /// Angle of each direction from mean_direction (degrees), in input order.
  std::vector<double> deviations_deg;
  double deviation_mean_deg = 0.0;
  double deviation_std_deg = 0.0;
};

/// Directional statistics of the given directions (each normalised first). Throws
/// InvalidArgumentError on empty input or a zero/non-finite vector, ComputationError when the
/// directions cancel out (Rbar ~ 0: no mean direction exists).
AxisStatistics directionalStatistics(std::span<const Eigen::Vector3d> directions);

/// Tables 1-2 of paper 000 for a set of estimates of one transform.
struct TransformDispersion {
  std::size_t count = 0;
  /// Statistics of the x, y and z columns of the rotations (index 0, 1, 2).
  std::array<AxisStatistics, 3> axes;
  /// Translation ("axis offsets", mm): per component mean and sample std.
  Eigen::Vector3d offset_mean = Eigen::Vector3d::Zero();
  Eigen::Vector3d offset_std = Eigen::Vector3d::Zero();
  /// Length of each translation (mm): mean and sample std.
  double offset_norm_mean = 0.0;
  double offset_norm_std = 0.0;
  /// Distance of each translation from offset_mean (mm): mean and sample std.
  double offset_distance_mean = 0.0;
  double offset_distance_std = 0.0;
};

/// Dispersion of repeated estimates of one calibration. Throws InvalidArgumentError on empty
/// input or non-finite matrices.
TransformDispersion transformDispersion(std::span<const Eigen::Isometry3d> estimates);

}  // namespace mrsns
