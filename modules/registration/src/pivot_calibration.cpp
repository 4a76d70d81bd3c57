#include "mrsns/registration/pivot_calibration.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <string>

#include "mrsns/core/dense_solvers.h"
#include "mrsns/core/error.h"
#include "mrsns/core/format.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/rotation_average.h"

namespace mrsns::registration {
namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

struct LinearFit {
  Eigen::Vector3d tip_marker;
  Eigen::Vector3d pivot_tracker;
  double condition_number;
};

// Solves [R_i  -I] [tip; pivot] = -t_i in the least-squares sense over the
// poses with use[i] set.
LinearFit solveLinear(std::span<const Eigen::Isometry3d> poses, const std::vector<bool>& use) {
  const auto n = static_cast<Eigen::Index>(std::count(use.begin(), use.end(), true));
  Eigen::MatrixXd a(3 * n, 6);
  Eigen::VectorXd b(3 * n);
  Eigen::Index row = 0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (!use[i]) continue;
    a.block<3, 3>(row, 0) = poses[i].linear();
    a.block<3, 3>(row, 3) = -Eigen::Matrix3d::Identity();
    b.segment<3>(row) = -poses[i].translation();
    row += 3;
  }
  Eigen::VectorXd s;
  const Eigen::VectorXd x = svdLeastSquares(a, b, &s);
  LinearFit fit;
  fit.tip_marker = x.head<3>();
  fit.pivot_tracker = x.tail<3>();
  fit.condition_number = s(s.size() - 1) > 0.0 ? s(0) / s(s.size() - 1) : std::numeric_limits<double>::infinity();
  return fit;
}

std::vector<double> residuals(std::span<const Eigen::Isometry3d> poses, const Eigen::Vector3d& tip,
                              const Eigen::Vector3d& pivot) {
  std::vector<double> r(poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) r[i] = (poses[i] * tip - pivot).norm();
  return r;
}

double rotationRange(std::span<const Eigen::Isometry3d> poses, const std::vector<bool>& use) {
  std::vector<Eigen::Matrix3d> rotations;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (use[i]) rotations.push_back(poses[i].linear());
  }
  RotationAverageOptions options;
  options.method = RotationMeanMethod::kChordalL2;
  return averageRotations(rotations, options).max_angle;
}

}  // namespace

double pivotRotationRange(std::span<const Eigen::Isometry3d> tracker_T_marker) {
  if (tracker_T_marker.empty()) return 0.0;
  return rotationRange(tracker_T_marker, std::vector<bool>(tracker_T_marker.size(), true));
}

PivotResult calibratePivot(std::span<const Eigen::Isometry3d> tracker_T_marker, const PivotOptions& options) {
  const auto n = tracker_T_marker.size();
  for (std::size_t i = 0; i < n; ++i) {
    if (!tracker_T_marker[i].matrix().allFinite() || !isRigid(tracker_T_marker[i].matrix(), 1e-4)) {
      throw InvalidArgumentError("pivot calibration: pose " + std::to_string(i) +
                                 " is not a finite rigid transform; drop frames where the tool was not tracked");
    }
  }
  if (static_cast<int>(n) < options.min_poses) {
    throw ComputationError("pivot calibration needs at least " + std::to_string(options.min_poses) + " poses, got " +
                           std::to_string(n) + ": record longer while pivoting the tool");
  }
  std::vector<bool> use(n, true);
  const double range_all = pivotRotationRange(tracker_T_marker);
  if (range_all < options.min_rotation_range) {
    throw ComputationError("pivot calibration: the tool rotated only " + formatFixed(range_all * kRadToDeg, 1) +
                           " deg (at least " + formatFixed(options.min_rotation_range * kRadToDeg, 1) +
                           " deg needed): pivot the tool further, in two directions, keeping the tip in the divot");
  }
  // Swung in one plane, the tip is unobservable along the swing's axis: say so in the operator's terms before
  // the condition number says it in a numerical analyst's.
  const auto coverage = pivotCoverage(tracker_T_marker);
  if (coverage.second_range < options.min_rotation_range) {
    throw ComputationError("pivot calibration: the tool was pivoted in one direction only (swing " +
                           formatFixed(coverage.first_range * kRadToDeg, 0) + " x " +
                           formatFixed(coverage.second_range * kRadToDeg, 0) +
                           " deg): pivot it in a cone, in two directions, at least " +
                           formatFixed(options.min_rotation_range * kRadToDeg, 0) +
                           " deg each, keeping the tip in the divot");
  }

  if (options.robust) {
    // RANSAC on 3-pose subsets (2 poses determine the tip only when their
    // relative rotation is generic; 3 are far less often degenerate).
    std::mt19937 rng(options.ransac_seed);
    std::uniform_int_distribution<std::size_t> pick(0, n - 1);
    int best_count = -1;
    std::vector<bool> best;
    for (int it = 0; it < options.ransac_iterations; ++it) {
      std::vector<bool> sample(n, false);
      int chosen = 0;
      while (chosen < 3) {
        const auto k = pick(rng);
        if (!sample[k]) {
          sample[k] = true;
          ++chosen;
        }
      }
      const auto fit = solveLinear(tracker_T_marker, sample);
      if (!std::isfinite(fit.condition_number) || fit.condition_number > 1e6) continue;
      const auto r = residuals(tracker_T_marker, fit.tip_marker, fit.pivot_tracker);
      std::vector<bool> inl(n);
      int count = 0;
      for (std::size_t i = 0; i < n; ++i) {
        inl[i] = r[i] <= options.inlier_threshold_mm;
        count += inl[i] ? 1 : 0;
      }
      if (count > best_count) {
        best_count = count;
        best = inl;
      }
    }
    if (best_count < options.min_poses) {
      throw ComputationError("robust pivot calibration: no consistent pivot found (best " +
                             std::to_string(std::max(best_count, 0)) + " of " + std::to_string(n) + " poses within " +
                             formatFixed(options.inlier_threshold_mm, 2) +
                             " mm): check that the tip stayed in the divot, or raise the inlier threshold");
    }
    use = best;
    // Refit on the inliers until the set is stable.
    for (int it = 0; it < 10; ++it) {
      const auto fit = solveLinear(tracker_T_marker, use);
      const auto r = residuals(tracker_T_marker, fit.tip_marker, fit.pivot_tracker);
      std::vector<bool> next(n);
      for (std::size_t i = 0; i < n; ++i) next[i] = r[i] <= options.inlier_threshold_mm;
      if (std::count(next.begin(), next.end(), true) < options.min_poses || next == use) break;
      use = next;
    }
  }

  const auto fit = solveLinear(tracker_T_marker, use);
  PivotResult result;
  result.tip_marker = fit.tip_marker;
  result.pivot_tracker = fit.pivot_tracker;
  result.condition_number = fit.condition_number;
  result.rotation_range = rotationRange(tracker_T_marker, use);
  if (!std::isfinite(fit.condition_number) || fit.condition_number > options.max_condition_number) {
    throw ComputationError(
        "pivot calibration is ill-conditioned (condition number " + formatGeneral(fit.condition_number, 3) +
        "): the poses do not determine the tip (too little rotation, or rotation about one axis only); pivot "
        "the tool by 20 deg or more in two perpendicular directions");
  }
  if (result.rotation_range < options.min_rotation_range) {
    throw ComputationError("pivot calibration: the consistent poses cover only " +
                           formatFixed(result.rotation_range * kRadToDeg, 1) +
                           " deg of rotation: pivot the tool further");
  }
  result.residuals_mm = residuals(tracker_T_marker, fit.tip_marker, fit.pivot_tracker);
  result.inliers = use;
  double sum_sq = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!use[i]) continue;
    ++result.inlier_count;
    sum_sq += result.residuals_mm[i] * result.residuals_mm[i];
    result.max_residual_mm = std::max(result.max_residual_mm, result.residuals_mm[i]);
  }
  result.rms_mm = std::sqrt(sum_sq / result.inlier_count);
  return result;
}

}  // namespace mrsns::registration

namespace mrsns::registration {

PivotCoverage pivotCoverage(std::span<const Eigen::Isometry3d> tracker_T_marker) {
  PivotCoverage c;
  c.poses = tracker_T_marker.size();
  if (c.poses < 2) return c;
  std::vector<Eigen::Matrix3d> rotations;
  rotations.reserve(c.poses);
  for (const auto& p : tracker_T_marker) rotations.push_back(p.linear());
  RotationAverageOptions options;
  options.method = RotationMeanMethod::kChordalL2;
  const Eigen::Matrix3d mean = averageRotations(rotations, options).mean;
  // Rotation vectors in the marker frame about the mean: their principal directions are the swing axes.
  std::vector<Eigen::Vector3d> phi;
  phi.reserve(c.poses);
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const auto& r : rotations) {
    phi.push_back(so3Log(mean.transpose() * r));
    centre += phi.back();
  }
  centre /= static_cast<double>(c.poses);
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& v : phi) scatter += (v - centre) * (v - centre).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter);  // ascending eigenvalues
  auto extent = [&](const Eigen::Vector3d& axis) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const auto& v : phi) {
      lo = std::min(lo, v.dot(axis));
      hi = std::max(hi, v.dot(axis));
    }
    return hi - lo;
  };
  c.first_range = extent(eig.eigenvectors().col(2));
  c.second_range = extent(eig.eigenvectors().col(1));
  return c;
}

}  // namespace mrsns::registration
