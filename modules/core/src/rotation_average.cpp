#include "mrsns/core/rotation_average.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"

namespace mrsns {
namespace {

// Above this many inputs the O(n^2) medoid start of the Weiszfeld iteration is replaced by the
// chordal mean.
constexpr std::size_t kMaxMedoidInputs = 256;

std::vector<double> checkedWeights(std::size_t n, std::span<const double> weights, const char* where) {
  if (weights.empty()) return std::vector<double>(n, 1.0);
  if (weights.size() != n) {
    throw InvalidArgumentError(std::string(where) + ": " + std::to_string(weights.size()) + " weights given for " +
                               std::to_string(n) + " inputs; pass one weight per input or none");
  }
  double total = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(weights[i]) || weights[i] < 0.0) {
      throw InvalidArgumentError(std::string(where) + ": weight " + std::to_string(i) +
                                 " is negative or not finite; weights must be finite and >= 0");
    }
    total += weights[i];
  }
  if (total <= 0.0) throw InvalidArgumentError(std::string(where) + ": all weights are zero");
  return {weights.begin(), weights.end()};
}

// Inputs closer than this to SO(3) are used as given; others (within the caller's tolerance)
// are projected first, so that Log and the optimality conditions hold to full precision.
constexpr double kExactOrthonormality = 1e-12;

// Returns the deviation |R^T R - I|_max of a finite, proper rotation; throws otherwise.
double checkRotation(const Eigen::Matrix3d& R, std::size_t i, double tol, const char* where) {
  if (!R.allFinite()) {
    throw InvalidArgumentError(std::string(where) + ": rotation " + std::to_string(i) + " contains NaN or infinity");
  }
  const double deviation = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (deviation > tol || R.determinant() <= 0.0) {
    throw InvalidArgumentError(std::string(where) + ": rotation " + std::to_string(i) +
                               " is not a proper orthonormal matrix within " + std::to_string(tol) +
                               "; orthonormalize it (nearestRotation) first or raise orthonormality_tolerance");
  }
  return deviation;
}

// Projection onto SO(3) that tolerates a singular or reflected sum (widely spread inputs):
// the sign fix picks the nearest proper rotation.
Eigen::Matrix3d projectToRotation(const Eigen::Matrix3d& M) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

Eigen::Matrix3d chordalMean(std::span<const Eigen::Matrix3d> rotations, const std::vector<double>& w) {
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < rotations.size(); ++i) sum += w[i] * rotations[i];
  return projectToRotation(sum);
}

// The input with the smallest weighted sum of geodesic distances to the others: a start for
// Weiszfeld that a single gross outlier cannot drag away, unlike the chordal mean.
Eigen::Matrix3d medoid(std::span<const Eigen::Matrix3d> rotations, const std::vector<double>& w) {
  double best = std::numeric_limits<double>::infinity();
  std::size_t best_i = 0;
  for (std::size_t i = 0; i < rotations.size(); ++i) {
    double cost = 0.0;
    for (std::size_t j = 0; j < rotations.size(); ++j) cost += w[j] * rotationAngleBetween(rotations[i], rotations[j]);
    if (cost < best) {
      best = cost;
      best_i = i;
    }
  }
  return rotations[best_i];
}

void iterateKarcher(std::span<const Eigen::Matrix3d> rotations, const std::vector<double>& w,
                    const RotationAverageOptions& options, RotationAverageResult& result) {
  double total = 0.0;
  for (double wi : w) total += wi;
  Eigen::Matrix3d R = result.mean;
  for (int it = 1; it <= options.max_iterations; ++it) {
    Eigen::Vector3d step = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < rotations.size(); ++i) step += w[i] * so3Log(R.transpose() * rotations[i]);
    step /= total;
    R = R * so3Exp(step);
    result.iterations = it;
    if (step.norm() < options.step_tolerance) {
      result.converged = true;
      break;
    }
  }
  result.mean = projectToRotation(R);
}

// Weiszfeld with the Vardi-Zhang correction: inputs that coincide with the estimate (residual
// below the floor) are left out of the plain step, and their total weight eta pulls the
// step back, so the iteration neither divides by zero nor stalls on an input that is not
// the median (a plain clamp stops dead on the medoid start).
void iterateWeiszfeld(std::span<const Eigen::Matrix3d> rotations, const std::vector<double>& w,
                      const RotationAverageOptions& options, RotationAverageResult& result) {
  Eigen::Matrix3d R = result.mean;
  const double floor = std::max(options.l1_min_residual, std::numeric_limits<double>::min());
  for (int it = 1; it <= options.max_iterations; ++it) {
    Eigen::Vector3d pull = Eigen::Vector3d::Zero();
    double inverse_sum = 0.0;
    double eta = 0.0;
    for (std::size_t i = 0; i < rotations.size(); ++i) {
      const Eigen::Vector3d v = so3Log(R.transpose() * rotations[i]);
      const double d = v.norm();
      if (d < floor) {
        eta += w[i];
        continue;
      }
      pull += (w[i] / d) * v;
      inverse_sum += w[i] / d;
    }
    Eigen::Vector3d step = Eigen::Vector3d::Zero();
    const double r = pull.norm();
    if (inverse_sum > 0.0 && r > 0.0) step = (1.0 - std::min(1.0, eta / r)) * (pull / inverse_sum);
    R = R * so3Exp(step);
    result.iterations = it;
    if (step.norm() < options.step_tolerance) {
      result.converged = true;
      break;
    }
  }
  result.mean = projectToRotation(R);
}

}  // namespace

RotationAverageResult averageRotations(std::span<const Eigen::Matrix3d> rotations,
                                       const RotationAverageOptions& options, std::span<const double> weights) {
  constexpr const char* kWhere = "averageRotations";
  if (rotations.empty()) throw InvalidArgumentError("averageRotations: no rotations given; pass at least one");
  if (options.max_iterations < 1 || !(options.step_tolerance > 0.0)) {
    throw InvalidArgumentError("averageRotations: max_iterations must be >= 1 and step_tolerance > 0");
  }
  std::vector<Eigen::Matrix3d> projected;
  for (std::size_t i = 0; i < rotations.size(); ++i) {
    if (checkRotation(rotations[i], i, options.orthonormality_tolerance, kWhere) > kExactOrthonormality &&
        projected.empty()) {
      projected.assign(rotations.begin(), rotations.end());
    }
  }
  if (!projected.empty()) {
    for (Eigen::Matrix3d& R : projected) R = projectToRotation(R);
    rotations = projected;
  }
  const std::vector<double> w = checkedWeights(rotations.size(), weights, kWhere);

  RotationAverageResult result;
  switch (options.method) {
    case RotationMeanMethod::kChordalL2:
      result.mean = chordalMean(rotations, w);
      result.converged = true;
      break;
    case RotationMeanMethod::kRiemannianL2:
      result.mean = chordalMean(rotations, w);
      iterateKarcher(rotations, w, options, result);
      break;
    case RotationMeanMethod::kRiemannianL1:
      result.mean = rotations.size() <= kMaxMedoidInputs ? medoid(rotations, w) : chordalMean(rotations, w);
      iterateWeiszfeld(rotations, w, options, result);
      break;
  }

  result.residual_angles.reserve(rotations.size());
  double sum_sq = 0.0;
  for (const Eigen::Matrix3d& R : rotations) {
    const double a = rotationAngleBetween(result.mean, R);
    result.residual_angles.push_back(a);
    sum_sq += a * a;
    result.max_angle = std::max(result.max_angle, a);
  }
  result.rms_angle = std::sqrt(sum_sq / static_cast<double>(rotations.size()));
  return result;
}

PoseAverageResult averagePoses(std::span<const Eigen::Isometry3d> poses, const RotationAverageOptions& options,
                               std::span<const double> weights) {
  if (poses.empty()) throw InvalidArgumentError("averagePoses: no poses given; pass at least one");
  std::vector<Eigen::Matrix3d> rotations;
  rotations.reserve(poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (!poses[i].translation().allFinite()) {
      throw InvalidArgumentError("averagePoses: the translation of pose " + std::to_string(i) +
                                 " contains NaN or infinity");
    }
    rotations.emplace_back(poses[i].linear());
  }
  PoseAverageResult result;
  result.rotation = averageRotations(rotations, options, weights);
  const std::vector<double> w = checkedWeights(poses.size(), weights, "averagePoses");

  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  double total = 0.0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    translation += w[i] * poses[i].translation();
    total += w[i];
  }
  translation /= total;
  result.mean.linear() = result.rotation.mean;
  result.mean.translation() = translation;

  result.translation_residuals.reserve(poses.size());
  double sum_sq = 0.0;
  for (const Eigen::Isometry3d& T : poses) {
    const double d = (T.translation() - translation).norm();
    result.translation_residuals.push_back(d);
    sum_sq += d * d;
    result.translation_max = std::max(result.translation_max, d);
  }
  result.translation_rms = std::sqrt(sum_sq / static_cast<double>(poses.size()));
  return result;
}

}  // namespace mrsns
