#pragma once
// Seeded random helpers for the simulated parts of the workflow (the
// patient's pose, digitisation and tracker noise).
#include <Eigen/Geometry>
#include <cstdint>
#include <random>

namespace mrsns::workflow::detail {

class Simulation {
 public:
  explicit Simulation(std::uint64_t seed) : rng_(seed) {}
  /// Isotropic Gaussian with the given 3D RMS (per-axis sigma rms/sqrt(3)).
  Eigen::Vector3d noise(double rms_mm) {
    std::normal_distribution<double> n(0.0, rms_mm / std::sqrt(3.0));
    return {n(rng_), n(rng_), n(rng_)};
  }
  double uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng_); }
  /// A rigid pose: rotation of up to `max_angle` rad about a random axis,
  /// translation uniform in a cube of half-width `half_extent_mm` about `centre`.
  Eigen::Isometry3d pose(double max_angle, const Eigen::Vector3d& centre, double half_extent_mm) {
    Eigen::Vector3d axis(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1));
    if (axis.norm() < 1e-6) axis = Eigen::Vector3d::UnitZ();
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.linear() = Eigen::AngleAxisd(uniform(-max_angle, max_angle), axis.normalized()).toRotationMatrix();
    t.translation() =
        centre + Eigen::Vector3d(uniform(-half_extent_mm, half_extent_mm), uniform(-half_extent_mm, half_extent_mm),
                                 uniform(-half_extent_mm, half_extent_mm));
    return t;
  }
  std::mt19937_64& engine() { return rng_; }

 private:
  std::mt19937_64 rng_;
};

}  // namespace mrsns::workflow::detail
