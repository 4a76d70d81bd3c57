#include "mrsns/hmd/tremor_compensation.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

#include "mrsns/core/error.h"

namespace mrsns::hmd {
namespace {

// Indices of the k nearest other samples (brute force: a hold yields a few hundred samples).
std::vector<int> nearestNeighbours(std::span<const Eigen::Vector3d> points, std::size_t i, int k) {
  std::vector<int> order(points.size());
  std::iota(order.begin(), order.end(), 0);
  order.erase(order.begin() + static_cast<std::ptrdiff_t>(i));
  std::partial_sort(order.begin(), order.begin() + k, order.end(), [&](int a, int b) {
    return (points[static_cast<std::size_t>(a)] - points[i]).squaredNorm() <
           (points[static_cast<std::size_t>(b)] - points[i]).squaredNorm();
  });
  order.resize(static_cast<std::size_t>(k));
  return order;
}

// Normal of the local plane through the point and its neighbours (smallest principal axis).
Eigen::Vector3d pcaNormal(std::span<const Eigen::Vector3d> points, std::size_t i, const std::vector<int>& nbrs) {
  Eigen::Vector3d mean = points[i];
  for (int j : nbrs) mean += points[static_cast<std::size_t>(j)];
  mean /= static_cast<double>(nbrs.size() + 1);
  Eigen::Matrix3d cov = (points[i] - mean) * (points[i] - mean).transpose();
  for (int j : nbrs) {
    const Eigen::Vector3d d = points[static_cast<std::size_t>(j)] - mean;
    cov += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  return eig.eigenvectors().col(0);
}

}  // namespace

TremorCompensationResult compensateTremor(std::span<const Eigen::Vector3d> samples, const TremorOptions& options) {
  if (options.k_close < 2) {
    throw InvalidArgumentError("compensateTremor: k_close is " + std::to_string(options.k_close) +
                               "; it needs at least 2 neighbours (the paper uses 4)");
  }
  if (!(options.omega > 0.0)) {
    throw InvalidArgumentError("compensateTremor: omega must be positive (the outlier weight of Eq. 14)");
  }
  const std::size_t n = samples.size();
  if (n < static_cast<std::size_t>(options.k_close) + 1) {
    throw InvalidArgumentError("compensateTremor: " + std::to_string(n) + " samples for a fiducial; at least " +
                               std::to_string(options.k_close + 1) +
                               " are needed (hold the cube still longer while recording)");
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!samples[i].allFinite()) {
      throw InvalidArgumentError("compensateTremor: sample " + std::to_string(i) + " is not finite");
    }
  }
  const int k = options.k_close;
  TremorCompensationResult r;
  r.raw_mean = Eigen::Vector3d::Zero();
  for (const auto& p : samples) r.raw_mean += p;
  r.raw_mean /= static_cast<double>(n);

  std::vector<std::vector<int>> nbrs(n);
  std::vector<Eigen::Vector3d> normals(n);
  for (std::size_t i = 0; i < n; ++i) {
    nbrs[i] = nearestNeighbours(samples, i, k);
    normals[i] = pcaNormal(samples, i, nbrs[i]);
  }
  r.curvature.assign(n, 0.0);
  r.distance_mm.assign(n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    double sum = 0.0;
    for (int jj : nbrs[i]) {
      const auto j = static_cast<std::size_t>(jj);
      const Eigen::Vector3d v = samples[j] - samples[i];
      const double len = v.norm();
      // Duplicate samples (a tracker repeating a frame) carry no shape information.
      if (len < 1e-12) continue;
      const double cos_beta = std::min(1.0, std::abs(normals[i].dot(normals[j])));
      const double sin_beta = std::sqrt(std::max(0.0, 1.0 - cos_beta * cos_beta));
      const double cos_alpha = std::min(1.0, std::abs(normals[i].dot(v) / len));
      // Keep sin(alpha) away from 0 so a neighbour along the normal does not explode the mean.
      const double sin_alpha = std::max(1e-3, std::sqrt(std::max(0.0, 1.0 - cos_alpha * cos_alpha)));
      sum += -sin_beta / (len * sin_alpha);
    }
    r.curvature[i] = sum / k;
    r.distance_mm[i] = (samples[i] - r.raw_mean).norm();
  }
  r.mean_curvature = std::accumulate(r.curvature.begin(), r.curvature.end(), 0.0) / static_cast<double>(n);
  r.mean_distance_mm = std::accumulate(r.distance_mm.begin(), r.distance_mm.end(), 0.0) / static_cast<double>(n);

  r.kept.assign(n, true);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    if (r.distance_mm[i] > options.omega * r.mean_distance_mm && r.curvature[i] > r.mean_curvature) {
      r.kept[i] = false;
      continue;
    }
    sum += samples[i];
    ++r.kept_count;
  }
  // The filter cannot drop everything (the nearest sample to the mean is below the mean distance),
  // but guard anyway.
  r.centre = r.kept_count > 0 ? Eigen::Vector3d(sum / r.kept_count) : r.raw_mean;
  double spread = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    if (r.kept[i]) spread += (samples[i] - r.centre).squaredNorm();
  }
  r.kept_spread_mm = r.kept_count > 0 ? std::sqrt(spread / r.kept_count) : 0.0;
  return r;
}

ViewCalibrationResult calibrateViewWithTremorCompensation(std::span<const std::vector<Eigen::Vector3d>> samples_tracker,
                                                          std::span<const Eigen::Vector3d> fiducial_hololens,
                                                          const TremorOptions& tremor,
                                                          const CubeCalibrationOptions& cube) {
  if (samples_tracker.size() != fiducial_hololens.size()) {
    throw InvalidArgumentError("calibrateViewWithTremorCompensation: sample sets for " +
                               std::to_string(samples_tracker.size()) + " fiducials but " +
                               std::to_string(fiducial_hololens.size()) +
                               " hologram fiducials; give one sample set per fiducial");
  }
  ViewCalibrationResult out;
  for (const auto& set : samples_tracker) {
    const auto c = compensateTremor(set, tremor);
    out.fiducial_tracker.push_back(c.centre);
    out.dropped_samples.push_back(static_cast<int>(set.size()) - c.kept_count);
  }
  out.calibration = calibrateCube(out.fiducial_tracker, fiducial_hololens, cube);
  return out;
}

}  // namespace mrsns::hmd
