#include "mrsns/registration/paired_point.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

#include "mrsns/core/error.h"

namespace mrsns::registration {
namespace {

struct Fit {
  Eigen::Matrix3d rotation;
  Eigen::Vector3d translation;
  double scale;
};

// Umeyama's closed form over the points with use[i] set.
Fit solve(std::span<const Eigen::Vector3d> moving, std::span<const Eigen::Vector3d> fixed, const std::vector<bool>& use,
          bool estimate_scale) {
  Eigen::Vector3d mean_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d mean_f = Eigen::Vector3d::Zero();
  double n = 0.0;
  for (std::size_t i = 0; i < moving.size(); ++i) {
    if (!use[i]) continue;
    mean_m += moving[i];
    mean_f += fixed[i];
    n += 1.0;
  }
  mean_m /= n;
  mean_f /= n;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  double var_m = 0.0;
  for (std::size_t i = 0; i < moving.size(); ++i) {
    if (!use[i]) continue;
    const Eigen::Vector3d dm = moving[i] - mean_m;
    cov += (fixed[i] - mean_f) * dm.transpose();
    var_m += dm.squaredNorm();
  }
  cov /= n;
  var_m /= n;
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Vector3d d = Eigen::Vector3d::Ones();
  // A reflection would fit coplanar or noisy points better; a rigid body cannot reflect.
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0) d(2) = -1.0;
  Fit fit;
  fit.rotation = svd.matrixU() * d.asDiagonal() * svd.matrixV().transpose();
  fit.scale = estimate_scale ? svd.singularValues().dot(d) / var_m : 1.0;
  fit.translation = mean_f - fit.scale * fit.rotation * mean_m;
  return fit;
}

// Principal axes (columns) and RMS distances from each axis of a point set.
void principalAxes(std::span<const Eigen::Vector3d> points, Eigen::Vector3d& centroid, Eigen::Matrix3d& axes,
                   Eigen::Vector3d& rms_from_axis, Eigen::Vector3d& singular) {
  centroid.setZero();
  for (const auto& p : points) centroid += p;
  centroid /= static_cast<double>(points.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& p : points) scatter += (p - centroid) * (p - centroid).transpose();
  scatter /= static_cast<double>(points.size());
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(scatter, Eigen::ComputeFullU);
  axes = svd.matrixU();
  singular = svd.singularValues().cwiseMax(0.0).cwiseSqrt();  // RMS extent along each axis
  // Mean squared distance from axis k = total variance minus the variance along k.
  const double total = singular.squaredNorm();
  for (int k = 0; k < 3; ++k) rms_from_axis(k) = std::sqrt(std::max(0.0, total - singular(k) * singular(k)));
}

}  // namespace

double expectedFreRms(int point_count, double fle_rms_mm) {
  if (point_count < 3) return 0.0;
  return fle_rms_mm * std::sqrt(1.0 - 2.0 / point_count);
}

double predictTreRms(std::span<const Eigen::Vector3d> moving, const Eigen::Vector3d& target, double fle_rms_mm) {
  if (moving.size() < 3) throw ComputationError("TRE prediction needs at least 3 fiducials");
  Eigen::Vector3d centroid, rms_from_axis, singular;
  Eigen::Matrix3d axes;
  principalAxes(moving, centroid, axes, rms_from_axis, singular);
  const Eigen::Vector3d r = target - centroid;
  double sum = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double along = r.dot(axes.col(k));
    const double d_sq = std::max(0.0, r.squaredNorm() - along * along);
    const double f_sq = rms_from_axis(k) * rms_from_axis(k);
    if (f_sq <= 0.0) throw ComputationError("TRE prediction: the fiducials are collinear");
    sum += d_sq / f_sq;
  }
  const double n = static_cast<double>(moving.size());
  return std::sqrt(fle_rms_mm * fle_rms_mm / n * (1.0 + sum / 3.0));
}

PairedPointResult registerPairedPoints(std::span<const Eigen::Vector3d> moving, std::span<const Eigen::Vector3d> fixed,
                                       const PairedPointOptions& options) {
  if (moving.size() != fixed.size()) {
    throw InvalidArgumentError("paired-point registration: " + std::to_string(moving.size()) + " moving points but " +
                               std::to_string(fixed.size()) +
                               " fixed points; both lists must name the same landmarks in the same order");
  }
  for (std::size_t i = 0; i < moving.size(); ++i) {
    if (!moving[i].allFinite() || !fixed[i].allFinite()) {
      throw InvalidArgumentError("paired-point registration: point " + std::to_string(i + 1) +
                                 " has a NaN or infinite coordinate; re-digitise or remove it");
    }
  }
  const auto n = moving.size();
  if (n < 3) {
    throw ComputationError("paired-point registration needs at least 3 point pairs, got " + std::to_string(n) +
                           ": digitise more landmarks");
  }
  PairedPointResult result;
  Eigen::Vector3d centroid, singular;
  Eigen::Matrix3d axes;
  principalAxes(moving, centroid, axes, result.principal_rms_mm, singular);
  for (const auto& set : {moving, fixed}) {
    Eigen::Vector3d c, rms, s;
    Eigen::Matrix3d ax;
    principalAxes(set, c, ax, rms, s);
    if (s(0) <= 0.0 || s(1) < options.min_collinearity_ratio * s(0)) {
      throw ComputationError(
          "paired-point registration: the landmarks are (nearly) collinear, which leaves the rotation about their "
          "line undetermined; add a landmark off that line");
    }
  }
  std::vector<bool> all(n, true);
  const Fit fit = solve(moving, fixed, all, options.estimate_scale);
  result.rotation = fit.rotation;
  result.translation = fit.translation;
  result.scale = fit.scale;
  result.fixed_T_moving.linear() = fit.scale * fit.rotation;
  result.fixed_T_moving.translation() = fit.translation;
  double sum_sq = 0.0;
  result.fre_mm.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    result.fre_mm[i] = (result.fixed_T_moving * moving[i] - fixed[i]).norm();
    sum_sq += result.fre_mm[i] * result.fre_mm[i];
  }
  result.fre_rms_mm = std::sqrt(sum_sq / static_cast<double>(n));
  result.fle_rms_estimate_mm = n > 2 ? result.fre_rms_mm / std::sqrt(1.0 - 2.0 / static_cast<double>(n)) : 0.0;

  if (options.leave_one_out && n >= 4) {
    result.leave_one_out_mm.resize(n);
    std::vector<std::pair<double, int>> suspects;
    for (std::size_t i = 0; i < n; ++i) {
      std::vector<bool> use(n, true);
      use[i] = false;
      std::vector<Eigen::Vector3d> others;
      for (std::size_t j = 0; j < n; ++j) {
        if (j != i) others.push_back(moving[j]);
      }
      Eigen::Vector3d c, rms, s;
      Eigen::Matrix3d ax;
      principalAxes(others, c, ax, rms, s);
      if (s(1) < options.min_collinearity_ratio * s(0)) {
        result.leave_one_out_mm[i] = std::numeric_limits<double>::quiet_NaN();
        continue;  // the rest are collinear: this point cannot be checked
      }
      const Fit loo = solve(moving, fixed, use, options.estimate_scale);
      const Eigen::Vector3d mapped = loo.scale * loo.rotation * moving[i] + loo.translation;
      const double error = (mapped - fixed[i]).norm();
      result.leave_one_out_mm[i] = error;
      // FLE of the other points, from their own FRE.
      double others_sq = 0.0;
      for (std::size_t j = 0; j < n; ++j) {
        if (j == i) continue;
        others_sq += (loo.scale * loo.rotation * moving[j] + loo.translation - fixed[j]).squaredNorm();
      }
      const double m = static_cast<double>(n - 1);
      const double fle_others = m > 2.0 ? std::sqrt(others_sq / m / (1.0 - 2.0 / m)) : 0.0;
      // The left-out point's own FLE adds to the TRE of the others' registration.
      const double expected = std::hypot(predictTreRms(others, moving[i], fle_others), fle_others);
      if (error > options.outlier_factor * expected && error > options.outlier_min_error_mm) {
        suspects.emplace_back(error, static_cast<int>(i));
      }
    }
    std::sort(suspects.rbegin(), suspects.rend());
    for (const auto& s : suspects) result.suspect_points.push_back(s.second);
  }
  return result;
}

}  // namespace mrsns::registration
