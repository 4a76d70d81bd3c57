// Rotation and pose averaging (paper 001, Eq. 18-20): exactness on trivial sets, invariance,
// optimality conditions, robustness of the L1 mean, and input validation.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/rotation_average.h"
#include "mrsns/core/units.h"

namespace mrsns {
namespace {

constexpr RotationMeanMethod kAllMethods[] = {RotationMeanMethod::kRiemannianL2, RotationMeanMethod::kChordalL2,
                                              RotationMeanMethod::kRiemannianL1};

Eigen::Vector3d gaussian3(std::mt19937& rng, double sigma) {
  std::normal_distribution<double> n(0.0, sigma);
  return {n(rng), n(rng), n(rng)};
}

Eigen::Matrix3d randomRotationGaussianAxis(std::mt19937& rng) {
  std::uniform_real_distribution<double> angle(0.0, kPi);
  return so3Exp(angle(rng) * gaussian3(rng, 1.0).normalized());
}

// Rotations scattered around `center` by isotropic tangent noise of `sigma` radians per axis.
std::vector<Eigen::Matrix3d> cluster(std::mt19937& rng, const Eigen::Matrix3d& center, double sigma, int n) {
  std::vector<Eigen::Matrix3d> out;
  for (int i = 0; i < n; ++i) out.push_back(center * so3Exp(gaussian3(rng, sigma)));
  return out;
}

RotationAverageOptions withMethod(RotationMeanMethod method) {
  RotationAverageOptions o;
  o.method = method;
  o.max_iterations = 2000;
  return o;
}

TEST(RotationAverage, EmptyInputThrows) {
  for (RotationMeanMethod m : kAllMethods) {
    EXPECT_THROW(averageRotations({}, withMethod(m)), InvalidArgumentError);
  }
  EXPECT_THROW(averagePoses({}), InvalidArgumentError);
}

TEST(RotationAverage, IdenticalRotationsAverageToThemselves) {
  std::mt19937 rng(11);
  const std::vector<Eigen::Matrix3d> specials = {Eigen::Matrix3d::Identity(), so3Exp(Eigen::Vector3d(1e-9, 0, 0)),
                                                 so3Exp((kPi - 1e-6) * Eigen::Vector3d(0, 0.6, 0.8)),
                                                 Eigen::Vector3d(1, -1, -1).asDiagonal().toDenseMatrix(),
                                                 randomRotationGaussianAxis(rng)};
  for (const Eigen::Matrix3d& R : specials) {
    const std::vector<Eigen::Matrix3d> same(7, R);
    for (RotationMeanMethod m : kAllMethods) {
      const RotationAverageResult r = averageRotations(same, withMethod(m));
      EXPECT_LT((r.mean - R).cwiseAbs().maxCoeff(), 1e-12) << static_cast<int>(m);
      EXPECT_TRUE(r.converged);
      EXPECT_LT(r.max_angle, 1e-12);
      EXPECT_EQ(r.residual_angles.size(), same.size());
    }
  }
}

TEST(RotationAverage, MeanIsInvariantToLeftAndRightMultiplication) {
  std::mt19937 rng(12);
  const std::vector<Eigen::Matrix3d> rotations = cluster(rng, randomRotationGaussianAxis(rng), 0.3, 20);
  for (const Eigen::Matrix3d& R0 : {randomRotationGaussianAxis(rng), Eigen::Vector3d(-1, -1, 1).asDiagonal().toDenseMatrix(),
                                    so3Exp((kPi - 1e-6) * Eigen::Vector3d::UnitX())}) {
    std::vector<Eigen::Matrix3d> left;
    std::vector<Eigen::Matrix3d> right;
    for (const Eigen::Matrix3d& R : rotations) {
      left.push_back(R0 * R);
      right.push_back(R * R0);
    }
    for (RotationMeanMethod m : kAllMethods) {
      const RotationAverageResult base = averageRotations(rotations, withMethod(m));
      ASSERT_TRUE(base.converged);
      EXPECT_LT(rotationAngleBetween(averageRotations(left, withMethod(m)).mean, R0 * base.mean), 1e-9);
      EXPECT_LT(rotationAngleBetween(averageRotations(right, withMethod(m)).mean, base.mean * R0), 1e-9);
    }
  }
}

TEST(RotationAverage, KarcherMeanZeroesTheTangentResidualSum) {
  // First-order optimality of Eq. 20: sum_i Log(Rbar^T R_i) = 0.
  std::mt19937 rng(13);
  const std::vector<Eigen::Matrix3d> rotations = cluster(rng, randomRotationGaussianAxis(rng), 0.5, 30);
  const RotationAverageResult r = averageRotations(rotations);
  ASSERT_TRUE(r.converged);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const Eigen::Matrix3d& R : rotations) sum += so3Log(r.mean.transpose() * R);
  EXPECT_LT(sum.norm(), 1e-10);
  // And it is a minimum: moving away increases the cost of Eq. 20.
  const auto cost = [&](const Eigen::Matrix3d& M) {
    double c = 0.0;
    for (const Eigen::Matrix3d& R : rotations) c += so3Log(R.transpose() * M).squaredNorm();
    return c;
  };
  for (int i = 0; i < 10; ++i) EXPECT_GT(cost(r.mean * so3Exp(gaussian3(rng, 1e-3))), cost(r.mean));
}

TEST(RotationAverage, TwoRotationsAverageToTheGeodesicMidpoint) {
  std::mt19937 rng(14);
  for (int i = 0; i < 20; ++i) {
    const Eigen::Matrix3d a = randomRotationGaussianAxis(rng);
    const Eigen::Matrix3d b = a * so3Exp((kPi - 0.1) * gaussian3(rng, 1.0).normalized() * (i + 1) / 20.0);
    const Eigen::Matrix3d midpoint = slerp(a, b, 0.5);
    for (RotationMeanMethod m : {RotationMeanMethod::kRiemannianL2, RotationMeanMethod::kChordalL2}) {
      EXPECT_LT(rotationAngleBetween(averageRotations(std::vector{a, b}, withMethod(m)).mean, midpoint), 1e-12);
    }
  }
}

TEST(RotationAverage, WeightsActLikeRepetitions) {
  // Rotations about one axis commute, so the weighted Karcher mean is the weighted mean angle.
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  const std::vector<Eigen::Matrix3d> pair = {so3Exp(0.0 * z), so3Exp(0.8 * z)};
  const std::vector<double> w = {3.0, 1.0};
  EXPECT_LT(rotationAngleBetween(averageRotations(pair, {}, w).mean, so3Exp(0.2 * z)), 1e-12);
  const std::vector<double> only_second = {0.0, 2.0};
  EXPECT_LT(rotationAngleBetween(averageRotations(pair, {}, only_second).mean, pair[1]), 1e-12);

  std::mt19937 rng(15);
  const std::vector<Eigen::Matrix3d> rotations = cluster(rng, randomRotationGaussianAxis(rng), 0.4, 5);
  const std::vector<double> counts = {1, 2, 3, 1, 2};
  std::vector<Eigen::Matrix3d> repeated;
  for (std::size_t i = 0; i < rotations.size(); ++i) {
    for (int k = 0; k < static_cast<int>(counts[i]); ++k) repeated.push_back(rotations[i]);
  }
  for (RotationMeanMethod m : kAllMethods) {
    EXPECT_LT(rotationAngleBetween(averageRotations(rotations, withMethod(m), counts).mean,
                                   averageRotations(repeated, withMethod(m)).mean),
              1e-9)
        << static_cast<int>(m);
  }
}

TEST(RotationAverage, L1MeanResistsAnOutlierThatDragsTheL2Mean) {
  // Ten estimates with 0.01 rad noise and one 1.5 rad blunder (a swapped axis, say). The
  // Karcher mean moves by about 1.5 / 11 = 0.14 rad, the chordal mean (which weighs the
  // blunder by its chord, sin 1.5 rather than 1.5) by about sin(1.5) / 11 = 0.09 rad; the
  // geodesic median stays within the noise.
  const double sigma = 0.01;
  std::mt19937 rng(16);
  for (int trial = 0; trial < 10; ++trial) {
    const Eigen::Matrix3d truth = randomRotationGaussianAxis(rng);
    std::vector<Eigen::Matrix3d> rotations = cluster(rng, truth, sigma, 10);
    rotations.push_back(truth * so3Exp(1.5 * gaussian3(rng, 1.0).normalized()));
    const RotationAverageResult l1 = averageRotations(rotations, withMethod(RotationMeanMethod::kRiemannianL1));
    const RotationAverageResult l2 = averageRotations(rotations, withMethod(RotationMeanMethod::kRiemannianL2));
    const RotationAverageResult chordal = averageRotations(rotations, withMethod(RotationMeanMethod::kChordalL2));
    EXPECT_TRUE(l1.converged);
    EXPECT_LT(rotationAngleBetween(l1.mean, truth), 3.0 * sigma);
    EXPECT_GT(rotationAngleBetween(l2.mean, truth), 0.1);
    EXPECT_GT(rotationAngleBetween(chordal.mean, truth), 0.06);
    EXPECT_NEAR(l1.max_angle, rotationAngleBetween(l1.mean, rotations.back()), 1e-12);
  }
}

TEST(RotationAverage, ChordalAndKarcherAgreeForConcentratedData) {
  // They differ at third order in the spread; with sigma = 0.05 that is far below the
  // statistical error sigma / sqrt(n) of either.
  const double sigma = 0.05;
  std::mt19937 rng(17);
  const Eigen::Matrix3d truth = randomRotationGaussianAxis(rng);
  const std::vector<Eigen::Matrix3d> rotations = cluster(rng, truth, sigma, 20);
  const Eigen::Matrix3d karcher = averageRotations(rotations).mean;
  const Eigen::Matrix3d chordal = averageRotations(rotations, withMethod(RotationMeanMethod::kChordalL2)).mean;
  EXPECT_LT(rotationAngleBetween(karcher, chordal), sigma * sigma);
  EXPECT_LT(rotationAngleBetween(karcher, truth), 5.0 * std::sqrt(3.0) * sigma / std::sqrt(20.0));
}

TEST(RotationAverage, SpreadReportsResidualAngles) {
  const Eigen::Vector3d x = Eigen::Vector3d::UnitX();
  const std::vector<Eigen::Matrix3d> rotations = {so3Exp(0.1 * x), so3Exp(-0.1 * x), so3Exp(0.3 * x), so3Exp(-0.3 * x)};
  const RotationAverageResult r = averageRotations(rotations);
  EXPECT_LT(rotationAngle(r.mean), 1e-14);
  ASSERT_EQ(r.residual_angles.size(), 4u);
  EXPECT_NEAR(r.residual_angles[2], 0.3, 1e-14);
  EXPECT_NEAR(r.max_angle, 0.3, 1e-14);
  EXPECT_NEAR(r.rms_angle, std::sqrt((0.01 + 0.01 + 0.09 + 0.09) / 4.0), 1e-14);
}

TEST(RotationAverage, IterationLimitIsReportedAsNotConverged) {
  std::mt19937 rng(18);
  const std::vector<Eigen::Matrix3d> rotations = cluster(rng, randomRotationGaussianAxis(rng), 0.6, 10);
  RotationAverageOptions o;
  o.max_iterations = 1;
  const RotationAverageResult r = averageRotations(rotations, o);
  EXPECT_EQ(r.iterations, 1);
  EXPECT_FALSE(r.converged);
  EXPECT_TRUE(averageRotations(rotations).converged);
}

TEST(RotationAverage, PoseAverageOfFourViewsUsesMeanTranslation) {
  // Eq. 18-20: four calibrations (front, left, right, ground).
  std::mt19937 rng(19);
  const Eigen::Matrix3d truth = randomRotationGaussianAxis(rng);
  const std::vector<Eigen::Vector3d> translations = {{10, 0, 0}, {0, 10, 0}, {-10, 0, 0}, {0, -10, 4}};
  std::vector<Eigen::Isometry3d> poses;
  for (const Eigen::Vector3d& t : translations) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = truth * so3Exp(gaussian3(rng, 0.02));
    T.translation() = t;
    poses.push_back(T);
  }
  const PoseAverageResult r = averagePoses(poses);
  EXPECT_TRUE(r.mean.translation().isApprox(Eigen::Vector3d(0, 0, 1), 1e-14));
  std::vector<Eigen::Matrix3d> rotations;
  for (const auto& T : poses) rotations.emplace_back(T.linear());
  EXPECT_LT(rotationAngleBetween(r.mean.linear(), averageRotations(rotations).mean), 1e-14);
  ASSERT_EQ(r.translation_residuals.size(), 4u);
  EXPECT_NEAR(r.translation_residuals[3], std::sqrt(100.0 + 9.0), 1e-12);
  EXPECT_NEAR(r.translation_max, std::sqrt(109.0), 1e-12);
  EXPECT_TRUE(isRigid(r.mean.matrix(), 1e-12));

  const std::vector<double> w = {0, 0, 0, 1};
  EXPECT_TRUE(averagePoses(poses, {}, w).mean.isApprox(poses[3], 1e-12));
}

TEST(RotationAverage, InvalidInputsAreRefused) {
  const std::vector<Eigen::Matrix3d> good = {Eigen::Matrix3d::Identity(), so3Exp(Eigen::Vector3d(0.1, 0, 0))};
  std::vector<Eigen::Matrix3d> bad = good;
  bad[1](0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(averageRotations(bad), InvalidArgumentError);
  bad = good;
  bad[1] *= 1.01;  // scaled, not orthonormal
  EXPECT_THROW(averageRotations(bad), InvalidArgumentError);
  // Slightly off (as printed with 6 digits) is accepted and projected onto SO(3) first.
  bad = good;
  bad[1] *= 1.0 + 1e-6;
  const RotationAverageResult r = averageRotations(bad);
  EXPECT_LT((r.mean.transpose() * r.mean - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_NEAR(r.max_angle, 0.05, 1e-12);
  RotationAverageOptions strict;
  strict.orthonormality_tolerance = 1e-9;
  EXPECT_THROW(averageRotations(bad, strict), InvalidArgumentError);
  bad = good;
  bad[1] = -bad[1];  // reflection
  EXPECT_THROW(averageRotations(bad), InvalidArgumentError);

  EXPECT_THROW(averageRotations(good, {}, std::vector<double>{1.0}), InvalidArgumentError);
  EXPECT_THROW(averageRotations(good, {}, std::vector<double>{1.0, -1.0}), InvalidArgumentError);
  EXPECT_THROW(averageRotations(good, {}, std::vector<double>{0.0, 0.0}), InvalidArgumentError);
  EXPECT_THROW(averageRotations(good, {}, std::vector<double>{1.0, std::nan("")}), InvalidArgumentError);

  std::vector<Eigen::Isometry3d> poses(2, Eigen::Isometry3d::Identity());
  poses[0].translation().x() = std::numeric_limits<double>::infinity();
  EXPECT_THROW(averagePoses(poses), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns
