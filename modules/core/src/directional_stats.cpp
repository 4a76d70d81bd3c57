#include "mrsns/core/directional_stats.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "mrsns/core/error.h"

namespace mrsns {
namespace {

constexpr double kRadToDeg = 180.0 / std::numbers::pi;

// Below this mean resultant length the mean direction is dominated by rounding.
constexpr double kMinResultant = 1e-9;

struct MeanStd {
  double mean = 0.0;
  double std = 0.0;
};

MeanStd meanStd(const std::vector<double>& values) {
  MeanStd out;
  if (values.empty()) return out;
  for (double v : values) out.mean += v;
  out.mean /= static_cast<double>(values.size());
  if (values.size() < 2) return out;
  double ss = 0.0;
  for (double v : values) ss += (v - out.mean) * (v - out.mean);
  out.std = std::sqrt(ss / static_cast<double>(values.size() - 1));
  return out;
}

}  // namespace

AxisStatistics directionalStatistics(std::span<const Eigen::Vector3d> directions) {
  if (directions.empty()) throw InvalidArgumentError("directionalStatistics: no directions given");
  std::vector<Eigen::Vector3d> unit;
  unit.reserve(directions.size());
  Eigen::Vector3d resultant = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < directions.size(); ++i) {
    const double n = directions[i].norm();
    if (!std::isfinite(n) || n == 0.0) {
      throw InvalidArgumentError("directionalStatistics: direction " + std::to_string(i) +
                                 " is zero or not finite; pass non-zero direction vectors");
    }
    unit.push_back(directions[i] / n);
    resultant += unit.back();
  }
  const double count = static_cast<double>(unit.size());
  if (resultant.norm() / count < kMinResultant) {
    throw ComputationError(
        "directionalStatistics: the directions cancel out (mean resultant length ~ 0), so they have no mean "
        "direction; the estimates are spread over the whole sphere");
  }

  AxisStatistics out;
  out.mean_direction = resultant.normalized();
  double half_chord_sq = 0.0;  // sum |x_i - m|^2 / 2 = sum (1 - cos theta_i)
  out.deviations_deg.reserve(unit.size());
  for (const Eigen::Vector3d& x : unit) {
    half_chord_sq += 0.5 * (x - out.mean_direction).squaredNorm();
    const double angle = std::atan2(x.cross(out.mean_direction).norm(), x.dot(out.mean_direction));
    out.deviations_deg.push_back(angle * kRadToDeg);
  }
  out.circular_variance = std::clamp(half_chord_sq / count, 0.0, 1.0);
  out.mean_resultant_length = 1.0 - out.circular_variance;
  out.circular_std = std::sqrt(-2.0 * std::log1p(-out.circular_variance));
  out.circular_std_deg = out.circular_std * kRadToDeg;
  const MeanStd dev = meanStd(out.deviations_deg);
  out.deviation_mean_deg = dev.mean;
  out.deviation_std_deg = dev.std;
  return out;
}

TransformDispersion transformDispersion(std::span<const Eigen::Isometry3d> estimates) {
  if (estimates.empty()) throw InvalidArgumentError("transformDispersion: no estimates given");
  TransformDispersion out;
  out.count = estimates.size();
  std::array<std::vector<Eigen::Vector3d>, 3> columns;
  std::array<std::vector<double>, 3> offsets;
  for (std::size_t i = 0; i < estimates.size(); ++i) {
    if (!estimates[i].matrix().allFinite()) {
      throw InvalidArgumentError("transformDispersion: estimate " + std::to_string(i) + " contains NaN or infinity");
    }
    for (int a = 0; a < 3; ++a) {
      columns[static_cast<std::size_t>(a)].push_back(estimates[i].linear().col(a));
      offsets[static_cast<std::size_t>(a)].push_back(estimates[i].translation()(a));
    }
  }
  for (int a = 0; a < 3; ++a) {
    const auto k = static_cast<std::size_t>(a);
    out.axes[k] = directionalStatistics(columns[k]);
    const MeanStd o = meanStd(offsets[k]);
    out.offset_mean(a) = o.mean;
    out.offset_std(a) = o.std;
  }
  std::vector<double> norms;
  std::vector<double> distances;
  norms.reserve(estimates.size());
  distances.reserve(estimates.size());
  for (const Eigen::Isometry3d& T : estimates) {
    norms.push_back(T.translation().norm());
    distances.push_back((T.translation() - out.offset_mean).norm());
  }
  const MeanStd n = meanStd(norms);
  out.offset_norm_mean = n.mean;
  out.offset_norm_std = n.std;
  const MeanStd d = meanStd(distances);
  out.offset_distance_mean = d.mean;
  out.offset_distance_std = d.std;
  return out;
}

}  // namespace mrsns
