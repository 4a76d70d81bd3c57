// Directional statistics of repeated calibrations (paper 000, Tables 1-2).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include "mrsns/core/directional_stats.h"
#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/units.h"

namespace mrsns {
namespace {

constexpr double kDegPerRad = 180.0 / kPi;

Eigen::Isometry3d pose(const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = t;
  return T;
}

TEST(DirectionalStats, IdenticalTransformsHaveZeroDispersion) {
  const Eigen::Isometry3d T = pose(so3Exp(Eigen::Vector3d(0.3, -1.2, 2.0)), Eigen::Vector3d(19.74, 76.82, -2.74));
  const std::vector<Eigen::Isometry3d> estimates(10, T);
  const TransformDispersion d = transformDispersion(estimates);
  EXPECT_EQ(d.count, 10u);
  for (int a = 0; a < 3; ++a) {
    const AxisStatistics& s = d.axes[static_cast<std::size_t>(a)];
    EXPECT_TRUE(s.mean_direction.isApprox(T.linear().col(a), 1e-15));
    // Only rounding of the unit columns remains (~1e-16 per component).
    EXPECT_LT(s.circular_variance, 1e-30);
    EXPECT_LT(s.circular_std, 1e-15);
    EXPECT_NEAR(s.mean_resultant_length, 1.0, 1e-15);
    ASSERT_EQ(s.deviations_deg.size(), 10u);
    EXPECT_LT(s.deviation_mean_deg, 1e-13);
  }
  EXPECT_TRUE(d.offset_mean.isApprox(T.translation(), 1e-15));
  EXPECT_LT(d.offset_std.norm(), 1e-12);
  EXPECT_LT(d.offset_distance_mean, 1e-12);
}

TEST(DirectionalStats, SymmetricConeHasKnownResultant) {
  // Four directions at angle alpha around z: m = z, Rbar = cos(alpha) exactly.
  for (double alpha : {1e-4, 0.01, 0.5, 1.2}) {
    std::vector<Eigen::Vector3d> dirs;
    for (int k = 0; k < 4; ++k) {
      const double az = k * kPi / 2.0;
      dirs.emplace_back(std::sin(alpha) * std::cos(az), std::sin(alpha) * std::sin(az), std::cos(alpha));
    }
    const AxisStatistics s = directionalStatistics(dirs);
    EXPECT_TRUE(s.mean_direction.isApprox(Eigen::Vector3d::UnitZ(), 1e-14));
    // 1 - cos(alpha) written without cancellation, so the reference keeps its digits at 1e-4.
    const double one_minus_cos = 2.0 * std::pow(std::sin(alpha / 2.0), 2);
    EXPECT_NEAR(s.circular_variance / one_minus_cos, 1.0, 1e-12) << alpha;
    EXPECT_NEAR(s.mean_resultant_length, std::cos(alpha), 1e-15);
    EXPECT_NEAR(s.circular_std / std::sqrt(-2.0 * std::log1p(-one_minus_cos)), 1.0, 1e-12);
    EXPECT_NEAR(s.circular_std_deg, s.circular_std * kDegPerRad, 1e-12);
    for (double dev : s.deviations_deg) EXPECT_NEAR(dev, alpha * kDegPerRad, 1e-10);
    EXPECT_NEAR(s.deviation_std_deg, 0.0, 1e-10);
  }
}

TEST(DirectionalStats, DefinitionsReproduceTables1And2OfPaper000) {
  // Each table lists the circular var and std per axis, both with three significant digits.
  // Computing sqrt(-2 ln(1 - var)) from the printed var reproduces the printed std to within
  // one unit of its last digit (the var is itself rounded, and Table 1 appears truncated:
  // 6.25e-7 gives 1.118e-3, printed 1.11e-3).
  struct Row {
    double variance;
    double std;
    double last_digit;
  };
  const Row rows[] = {{3.18e-6, 2.52e-3, 1e-5}, {4.18e-6, 2.89e-3, 1e-5}, {6.25e-7, 1.11e-3, 1e-5},
                      {2.60e-3, 7.22e-2, 1e-4}, {3.31e-3, 8.14e-2, 1e-4}, {2.69e-3, 7.34e-2, 1e-4}};
  for (const Row& row : rows) {
    const double alpha = std::acos(1.0 - row.variance);
    const std::vector<Eigen::Vector3d> dirs = {{std::sin(alpha), 0.0, std::cos(alpha)},
                                               {-std::sin(alpha), 0.0, std::cos(alpha)}};
    const AxisStatistics s = directionalStatistics(dirs);
    EXPECT_NEAR(s.circular_variance, row.variance, 1e-9 * row.variance + 1e-15);
    EXPECT_NEAR(s.circular_std, row.std, row.last_digit) << row.variance;
  }
}

TEST(DirectionalStats, GaussianTangentNoiseGivesExpectedCircularStd) {
  // R_i = Exp(w_i) R0 with w_i ~ N(0, sigma^2 I). An axis is tilted by the two components of
  // w_i orthogonal to it, so its angle theta_i is Rayleigh(sigma): E[1 - cos theta] = sigma^2
  // (+ O(sigma^4)), hence circular variance ~ sigma^2 and circular std ~ sigma sqrt(2).
  // 1 - cos theta ~ sigma^2 chi2_2 / 2 has sd sigma^2, so the variance estimate has relative
  // sd 1/sqrt(n) and the circular std 1/(2 sqrt(n)); the mean-direction fit biases the
  // variance by -sigma^2/n. Tolerance: 5 sd plus the bias.
  const double sigma = 0.01;
  const int n = 4000;
  std::mt19937 rng(21);
  std::normal_distribution<double> noise(0.0, sigma);
  const Eigen::Matrix3d R0 = so3Exp(Eigen::Vector3d(0.4, 0.2, -0.9));
  std::vector<Eigen::Isometry3d> estimates;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d w(noise(rng), noise(rng), noise(rng));
    estimates.push_back(pose(so3Exp(w) * R0, Eigen::Vector3d::Zero()));
  }
  const TransformDispersion d = transformDispersion(estimates);
  const double expected_std = sigma * std::sqrt(2.0);
  const double tolerance = expected_std * (5.0 / (2.0 * std::sqrt(n)) + 1.0 / n);
  // Rayleigh(sigma) deviations: mean sigma sqrt(pi/2), sd sigma sqrt((4 - pi)/2).
  const double rayleigh_mean = sigma * std::sqrt(kPi / 2.0);
  const double rayleigh_sd = sigma * std::sqrt((4.0 - kPi) / 2.0);
  for (int a = 0; a < 3; ++a) {
    const AxisStatistics& s = d.axes[static_cast<std::size_t>(a)];
    EXPECT_NEAR(s.circular_std, expected_std, tolerance) << "axis " << a;
    EXPECT_NEAR(s.circular_variance, sigma * sigma, sigma * sigma * (5.0 / std::sqrt(n) + 1.0 / n));
    EXPECT_LT(std::acos(std::min(1.0, s.mean_direction.dot(R0.col(a)))), 5.0 * sigma * std::sqrt(2.0 / n));
    EXPECT_NEAR(s.deviation_mean_deg, rayleigh_mean * kDegPerRad, 5.0 * rayleigh_sd / std::sqrt(n) * kDegPerRad);
    // Relative sd of a sample std is sqrt((kurtosis - 1) / (4 n)), Rayleigh kurtosis 3.245: 1.2%.
    EXPECT_NEAR(s.deviation_std_deg, rayleigh_sd * kDegPerRad, 5.0 * std::sqrt(2.245 / (4.0 * n)) * rayleigh_sd * kDegPerRad);
  }
}

TEST(DirectionalStats, DispersionIsInvariantToAFixedRotation) {
  std::mt19937 rng(22);
  std::normal_distribution<double> noise(0.0, 0.05);
  std::vector<Eigen::Isometry3d> estimates;
  std::vector<Eigen::Isometry3d> rotated;
  const Eigen::Matrix3d R0 = so3Exp(Eigen::Vector3d(2.0, -0.5, 1.0));
  for (int i = 0; i < 50; ++i) {
    const Eigen::Isometry3d T = pose(so3Exp(Eigen::Vector3d(noise(rng), noise(rng), noise(rng))),
                                     Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
    estimates.push_back(T);
    rotated.push_back(pose(R0, Eigen::Vector3d::Zero()) * T);
  }
  const TransformDispersion a = transformDispersion(estimates);
  const TransformDispersion b = transformDispersion(rotated);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_NEAR(a.axes[k].circular_variance, b.axes[k].circular_variance, 1e-12);
    EXPECT_TRUE((R0 * a.axes[k].mean_direction).isApprox(b.axes[k].mean_direction, 1e-12));
  }
  EXPECT_NEAR(a.offset_distance_mean, b.offset_distance_mean, 1e-12);
}

TEST(DirectionalStats, OffsetsUseSampleMeanAndStd) {
  std::vector<Eigen::Isometry3d> estimates;
  for (double x : {1.0, 2.0, 3.0, 4.0}) estimates.push_back(pose(Eigen::Matrix3d::Identity(), {x, -x, 5.0}));
  const TransformDispersion d = transformDispersion(estimates);
  EXPECT_TRUE(d.offset_mean.isApprox(Eigen::Vector3d(2.5, -2.5, 5.0)));
  const double sd = std::sqrt((2.25 + 0.25 + 0.25 + 2.25) / 3.0);
  EXPECT_NEAR(d.offset_std.x(), sd, 1e-14);
  EXPECT_NEAR(d.offset_std.y(), sd, 1e-14);
  EXPECT_EQ(d.offset_std.z(), 0.0);
  // Distances from the mean: sqrt(2) * {1.5, 0.5, 0.5, 1.5}.
  EXPECT_NEAR(d.offset_distance_mean, std::sqrt(2.0), 1e-14);
  EXPECT_NEAR(d.offset_distance_std, std::sqrt(2.0) * std::sqrt(4 * 0.25 / 3.0), 1e-14);
  // Lengths: sqrt(2 x^2 + 25) for x = 1..4.
  double norm_sum = 0.0;
  for (double x : {1.0, 2.0, 3.0, 4.0}) norm_sum += std::sqrt(2.0 * x * x + 25.0);
  EXPECT_NEAR(d.offset_norm_mean, norm_sum / 4.0, 1e-13);
  EXPECT_GT(d.offset_norm_std, 0.0);

  const TransformDispersion single = transformDispersion(std::vector{estimates[0]});
  EXPECT_EQ(single.offset_std.norm(), 0.0);
}

TEST(DirectionalStats, DegenerateInputIsRefused) {
  EXPECT_THROW(transformDispersion({}), InvalidArgumentError);
  EXPECT_THROW(directionalStatistics({}), InvalidArgumentError);
  EXPECT_THROW(directionalStatistics(std::vector<Eigen::Vector3d>{Eigen::Vector3d::UnitX(), Eigen::Vector3d::Zero()}),
               InvalidArgumentError);
  EXPECT_THROW(directionalStatistics(std::vector<Eigen::Vector3d>{Eigen::Vector3d::UnitX(), Eigen::Vector3d(-1, 0, 0)}),
               ComputationError);
  std::vector<Eigen::Isometry3d> estimates(3, Eigen::Isometry3d::Identity());
  estimates[1].translation().y() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(transformDispersion(estimates), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns
