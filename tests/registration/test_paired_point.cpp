// Paired-point registration against synthetic ground truth. Noise model:
// fiducial localisation error isotropic Gaussian, RMS `fle` in 3D (each axis
// fle / sqrt(3)), on the fixed points only.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/registration/paired_point.h"

namespace mrsns::registration {
namespace {

std::vector<Eigen::Vector3d> fiducials() {
  // Screw heads spread over a cervical-sized region (mm).
  return {{0, 0, 0}, {40, 5, 10}, {-35, 8, 20}, {5, 45, -10}, {10, -40, 15}, {-20, -15, 40}, {25, 30, 35}};
}

Eigen::Isometry3d groundTruth() {
  Eigen::Isometry3d fixed_T_moving = Eigen::Isometry3d::Identity();
  fixed_T_moving.linear() = so3Exp(Eigen::Vector3d(0.4, -1.1, 2.0));
  fixed_T_moving.translation() = Eigen::Vector3d(120, -40, 800);
  return fixed_T_moving;
}

std::vector<Eigen::Vector3d> mapped(const std::vector<Eigen::Vector3d>& points, const Eigen::Isometry3d& t, double fle,
                                    std::mt19937& rng) {
  std::normal_distribution<double> gauss(0.0, fle / std::sqrt(3.0));
  std::vector<Eigen::Vector3d> out;
  for (const auto& p : points) out.push_back(t * p + Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)));
  return out;
}

TEST(PairedPoint, ExactPointsRecoverTransform) {
  std::mt19937 rng(1);
  const auto moving = fiducials();
  const auto fixed = mapped(moving, groundTruth(), 0.0, rng);
  const auto result = registerPairedPoints(moving, fixed);
  EXPECT_LT((result.fixed_T_moving.matrix() - groundTruth().matrix()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT(result.fre_rms_mm, 1e-9);
  EXPECT_TRUE(result.suspect_points.empty());
  EXPECT_NEAR(result.scale, 1.0, 0.0);
}

TEST(PairedPoint, CoplanarThreePointsAreEnoughAndNeverReflect) {
  std::mt19937 rng(2);
  const std::vector<Eigen::Vector3d> moving{{0, 0, 0}, {50, 0, 0}, {0, 30, 0}};
  const auto fixed = mapped(moving, groundTruth(), 0.5, rng);
  const auto result = registerPairedPoints(moving, fixed);
  EXPECT_NEAR(result.rotation.determinant(), 1.0, 1e-12);
}

TEST(PairedPoint, EstimatesIsotropicScale) {
  std::mt19937 rng(3);
  const auto moving = fiducials();
  std::vector<Eigen::Vector3d> fixed;
  for (const auto& p : moving) fixed.push_back(groundTruth() * (1.7 * p));
  PairedPointOptions options;
  options.estimate_scale = true;
  const auto result = registerPairedPoints(moving, fixed, options);
  EXPECT_NEAR(result.scale, 1.7, 1e-12);
  EXPECT_LT((result.rotation - groundTruth().linear()).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(PairedPoint, FreAndTreMatchFitzpatrickPredictionsInMonteCarlo) {
  // E[FRE^2] = (1 - 2/N) FLE^2 and E[TRE^2(r)] from Fitzpatrick-West; the
  // Monte Carlo means of 4000 trials are within a few percent of them (the
  // relative standard error of a mean of squared errors over 4000 trials is
  // ~2%, and the TRE formula is first order in FLE / fiducial spread).
  std::mt19937 rng(4);
  const auto moving = fiducials();
  const double fle = 1.0;
  const Eigen::Vector3d target(10, 10, 80);  // a pedicle beyond the fiducials
  double fre_sq = 0.0;
  double tre_sq = 0.0;
  const int trials = 4000;
  PairedPointOptions options;
  options.leave_one_out = false;
  for (int t = 0; t < trials; ++t) {
    const auto fixed = mapped(moving, groundTruth(), fle, rng);
    const auto result = registerPairedPoints(moving, fixed, options);
    fre_sq += result.fre_rms_mm * result.fre_rms_mm;
    tre_sq += (result.fixed_T_moving * target - groundTruth() * target).squaredNorm();
  }
  const double fre_rms = std::sqrt(fre_sq / trials);
  const double tre_rms = std::sqrt(tre_sq / trials);
  EXPECT_NEAR(fre_rms, expectedFreRms(static_cast<int>(moving.size()), fle), 0.03 * fle);
  const double predicted = predictTreRms(moving, target, fle);
  EXPECT_NEAR(tre_rms, predicted, 0.06 * predicted);
}

TEST(PairedPoint, FleEstimateFromOneRegistrationIsUnbiasedOnAverage) {
  std::mt19937 rng(5);
  const auto moving = fiducials();
  double sum_sq = 0.0;
  for (int t = 0; t < 2000; ++t) {
    const auto r = registerPairedPoints(moving, mapped(moving, groundTruth(), 0.8, rng));
    sum_sq += r.fle_rms_estimate_mm * r.fle_rms_estimate_mm;
  }
  EXPECT_NEAR(std::sqrt(sum_sq / 2000.0), 0.8, 0.03);
}

TEST(PairedPoint, LeaveOneOutFindsASwappedOrMisplacedPoint) {
  std::mt19937 rng(6);
  const auto moving = fiducials();
  auto fixed = mapped(moving, groundTruth(), 0.5, rng);
  fixed[3] += Eigen::Vector3d(6.0, -4.0, 3.0);  // a landmark digitised 8 mm off
  const auto result = registerPairedPoints(moving, fixed);
  ASSERT_FALSE(result.suspect_points.empty());
  EXPECT_EQ(result.suspect_points.front(), 3);
  EXPECT_EQ(result.leave_one_out_mm.size(), moving.size());
  EXPECT_GT(result.leave_one_out_mm[3], 5.0);
}

TEST(PairedPoint, CleanDataRaisesNoSuspectsAtRealisticNoise) {
  std::mt19937 rng(7);
  const auto moving = fiducials();
  int false_alarms = 0;
  for (int t = 0; t < 200; ++t) {
    const auto result = registerPairedPoints(moving, mapped(moving, groundTruth(), 0.5, rng));
    false_alarms += result.suspect_points.empty() ? 0 : 1;
  }
  // 0.5 mm FLE never reaches the 1 mm floor times the 3-sigma factor often.
  EXPECT_LE(false_alarms, 4);
}

TEST(PairedPoint, RefusesMismatchedCountsNaNTooFewAndCollinear) {
  const auto moving = fiducials();
  auto fixed = moving;
  fixed.pop_back();
  EXPECT_THROW(registerPairedPoints(moving, fixed), InvalidArgumentError);
  auto with_nan = moving;
  with_nan[2].y() = std::nan("");
  EXPECT_THROW(registerPairedPoints(moving, with_nan), InvalidArgumentError);
  const std::vector<Eigen::Vector3d> two{{0, 0, 0}, {1, 0, 0}};
  EXPECT_THROW(registerPairedPoints(two, two), ComputationError);
  const std::vector<Eigen::Vector3d> line{{0, 0, 0}, {10, 10, 0}, {20, 20, 0}, {35, 35, 0}};
  try {
    registerPairedPoints(line, line);
    FAIL() << "expected ComputationError";
  } catch (const ComputationError& e) {
    EXPECT_NE(std::string(e.what()).find("collinear"), std::string::npos);
  }
}

TEST(PairedPoint, TrePredictionGrowsWithDistanceFromFiducials) {
  const auto moving = fiducials();
  const double near = predictTreRms(moving, Eigen::Vector3d(5, 5, 10), 1.0);
  const double far = predictTreRms(moving, Eigen::Vector3d(5, 5, 300), 1.0);
  EXPECT_LT(near, far);
  // At the centroid TRE^2 = FLE^2 / N exactly.
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : moving) centroid += p;
  centroid /= static_cast<double>(moving.size());
  EXPECT_NEAR(predictTreRms(moving, centroid, 1.0), 1.0 / std::sqrt(static_cast<double>(moving.size())), 1e-12);
}

}  // namespace
}  // namespace mrsns::registration
