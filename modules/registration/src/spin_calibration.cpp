#include "mrsns/registration/spin_calibration.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "mrsns/core/dense_solvers.h"
#include "mrsns/core/error.h"
#include "mrsns/core/format.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/rotation_average.h"

namespace mrsns::registration {

SpinResult calibrateSpin(std::span<const Eigen::Isometry3d> tracker_T_marker, const SpinOptions& options,
                         const Eigen::Vector3d* tip_marker) {
  constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;
  const auto n = tracker_T_marker.size();
  if (static_cast<int>(n) < options.min_poses) {
    throw ComputationError("spin calibration needs at least " + std::to_string(options.min_poses) + " poses, got " +
                           std::to_string(n) + ": record longer while spinning the tool about its shaft");
  }
  std::vector<Eigen::Matrix3d> rotations;
  for (std::size_t i = 0; i < n; ++i) {
    if (!isRigid(tracker_T_marker[i].matrix(), 1e-4)) {
      throw InvalidArgumentError("spin calibration: pose " + std::to_string(i) + " is not a finite rigid transform");
    }
    rotations.push_back(tracker_T_marker[i].linear());
  }
  // Spinning about a shaft fixed in the marker frame gives R_i = R_c * Rot(s, theta_i),
  // so every R_c^T R_i has s as its axis: s spans the null space of (R_c^T R_i - I).
  const Eigen::Matrix3d center = averageRotations(rotations).mean;
  Eigen::MatrixXd a(3 * static_cast<Eigen::Index>(n), 3);
  SpinResult result;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Matrix3d relative = center.transpose() * rotations[i];
    a.block<3, 3>(3 * static_cast<Eigen::Index>(i), 0) = relative - Eigen::Matrix3d::Identity();
    result.spin_angle = std::max(result.spin_angle, rotationAngleBetween(rotations[0], rotations[i]));
  }
  if (result.spin_angle < options.min_spin_angle) {
    throw ComputationError("spin calibration: the tool turned only " + formatFixed(result.spin_angle * kRadToDeg, 1) +
                           " deg (at least " + formatFixed(options.min_spin_angle * kRadToDeg, 1) +
                           " deg needed): spin it further about its shaft");
  }
  const ThinSvd svd = thinSvd(a, SvdVectors::kV);
  const Eigen::VectorXd& s = svd.singular_values;
  result.shaft_marker = svd.v.col(2).normalized();
  result.axis_distinctness = s(2) > 0.0 ? s(1) / s(2) : std::numeric_limits<double>::infinity();
  // A spin about one axis leaves one near-zero singular value; wobble about
  // two axes (or a pivot) leaves none.
  constexpr double kMinDistinctness = 5.0;
  if (result.axis_distinctness < kMinDistinctness) {
    throw ComputationError("spin calibration: the motion is not a rotation about one axis (axis distinctness " +
                           formatGeneral(result.axis_distinctness, 3) +
                           "): keep the tip in the divot and turn the tool about its shaft only");
  }
  const Eigen::Vector3d reference = tip_marker != nullptr ? *tip_marker : Eigen::Vector3d::UnitZ();
  if (result.shaft_marker.dot(reference) < 0.0) result.shaft_marker = -result.shaft_marker;
  double sum_sq = 0.0;
  int counted = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d phi = so3Log(center.transpose() * rotations[i]);
    if (phi.norm() < 5.0 / kRadToDeg) continue;  // the axis of a tiny rotation is noise
    const double cosine = std::min(1.0, std::abs(phi.normalized().dot(result.shaft_marker)));
    const double angle = std::acos(cosine);
    sum_sq += angle * angle;
    ++counted;
  }
  result.axis_rms_angle = counted > 0 ? std::sqrt(sum_sq / counted) : 0.0;
  return result;
}

Eigen::Isometry3d tipFrame(const Eigen::Vector3d& tip_marker, const Eigen::Vector3d& shaft_marker) {
  if (!tip_marker.allFinite()) throw InvalidArgumentError("tip frame: the tip must be a finite point");
  if (!shaft_marker.allFinite() || !(shaft_marker.norm() > 1e-9)) {
    throw InvalidArgumentError("tip frame: the shaft direction must be a finite non-zero vector");
  }
  const Eigen::Vector3d z = shaft_marker.normalized();
  // The marker's x unless the shaft nearly lies along it (then its y), made perpendicular to the shaft.
  const Eigen::Vector3d seed = std::abs(z.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d x = (seed - seed.dot(z) * z).normalized();
  Eigen::Isometry3d marker_T_tip = Eigen::Isometry3d::Identity();
  marker_T_tip.linear().col(0) = x;
  marker_T_tip.linear().col(1) = z.cross(x);
  marker_T_tip.linear().col(2) = z;
  marker_T_tip.translation() = tip_marker;
  return marker_T_tip;
}

}  // namespace mrsns::registration
