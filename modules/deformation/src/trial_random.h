#pragma once
// Random rigid errors of the simulated protocol (calibration, tracking).
#include <Eigen/Geometry>
#include <cmath>
#include <numbers>
#include <random>

namespace mrsns::deformation::detail {

inline constexpr double kDeg = std::numbers::pi / 180.0;

/// A rigid error: translation with `translation_rms_mm` 3D RMS, rotation
/// about a random axis by N(0, rotation_deg).
inline Eigen::Isometry3d randomRigid(std::mt19937_64& rng, double translation_rms_mm, double rotation_deg) {
  std::normal_distribution<double> n(0.0, 1.0);
  const double s = translation_rms_mm / std::sqrt(3.0);
  Eigen::Vector3d axis(n(rng), n(rng), n(rng));
  axis.normalize();
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = Eigen::AngleAxisd(rotation_deg * kDeg * n(rng), axis).toRotationMatrix();
  t.translation() = Eigen::Vector3d(s * n(rng), s * n(rng), s * n(rng));
  return t;
}

}  // namespace mrsns::deformation::detail
