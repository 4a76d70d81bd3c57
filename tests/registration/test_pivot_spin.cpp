// Pivot and spin calibration on synthetic poses with a stated noise model:
// marker positions carry isotropic Gaussian noise of 0.25 mm 3D RMS (the
// simulator's default; Polaris Vega is specified at 0.35 mm) and marker
// orientations 0.1 deg RMS per axis.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/registration/pivot_calibration.h"
#include "mrsns/registration/spin_calibration.h"

namespace mrsns::registration {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

struct PivotScene {
  Eigen::Vector3d tip_marker{12.0, -4.0, 160.0};
  Eigen::Vector3d pivot_tracker{50.0, 20.0, -1200.0};
};

// Poses of a tool pivoting about its tip: tilt up to max_tilt in a cone
// around a base orientation, plus a spin about the shaft.
std::vector<Eigen::Isometry3d> pivotPoses(const PivotScene& scene, int count, double max_tilt, double sigma3d_mm,
                                          double sigma_rot, std::mt19937& rng, bool one_axis = false) {
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<Eigen::Isometry3d> poses;
  const Eigen::Matrix3d base = so3Exp(Eigen::Vector3d(0.3, -0.2, 0.1));
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d tilt = one_axis ? Eigen::Vector3d(max_tilt * uniform(rng), 0, 0)
                                          : Eigen::Vector3d(max_tilt * uniform(rng), max_tilt * uniform(rng), 0.0);
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = so3Exp(tilt) * base;
    pose.translation() = scene.pivot_tracker - pose.linear() * scene.tip_marker;
    // Noise: orientation then position (independent per axis, sigma3d/sqrt(3) each).
    pose.linear() = so3Exp(sigma_rot * Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng))) * pose.linear();
    pose.translation() += sigma3d_mm / std::sqrt(3.0) * Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng));
    poses.push_back(pose);
  }
  return poses;
}

TEST(PivotCalibration, ExactPosesRecoverTipAndPivot) {
  std::mt19937 rng(1);
  PivotScene scene;
  const auto poses = pivotPoses(scene, 50, 30 * kDeg, 0.0, 0.0, rng);
  const auto result = calibratePivot(poses);
  EXPECT_LT((result.tip_marker - scene.tip_marker).norm(), 1e-8);
  EXPECT_LT((result.pivot_tracker - scene.pivot_tracker).norm(), 1e-8);
  EXPECT_LT(result.rms_mm, 1e-8);
  EXPECT_EQ(result.inlier_count, 50);
  EXPECT_GT(result.rotation_range, 20 * kDeg);
}

TEST(PivotCalibration, NoisyPosesGiveTipWithinNoiseAndRmsMatchesNoise) {
  // The residual of each pose combines position noise (0.25 mm 3D RMS) and
  // the orientation noise on the tip's lever arm: 0.1 deg per axis moves the
  // tip by |tip| * 0.1 deg * sqrt(2) RMS (two axes perpendicular to it).
  // With 900 equations the RMS itself scatters by ~3%.
  std::mt19937 rng(2);
  PivotScene scene;
  const double sigma3d = 0.25;
  const double sigma_rot = 0.1 * kDeg;
  const auto poses = pivotPoses(scene, 300, 30 * kDeg, sigma3d, sigma_rot, rng);
  const auto result = calibratePivot(poses);
  EXPECT_LT((result.tip_marker - scene.tip_marker).norm(), 0.3);
  const double expected_rms = std::hypot(sigma3d, scene.tip_marker.norm() * sigma_rot * std::sqrt(2.0));
  EXPECT_NEAR(result.rms_mm, expected_rms, 0.1 * expected_rms);
}

TEST(PivotCalibration, RobustVariantRejectsFivePercentOutliers) {
  std::mt19937 rng(3);
  PivotScene scene;
  auto poses = pivotPoses(scene, 200, 30 * kDeg, 0.25, 0.0, rng);
  // 5% of the poses: the tip slipped out of the divot by 5-15 mm.
  std::uniform_real_distribution<double> slip(5.0, 15.0);
  std::vector<int> outliers;
  for (int i = 0; i < 200; i += 20) {
    poses[static_cast<std::size_t>(i)].translation() += Eigen::Vector3d(slip(rng), -slip(rng), slip(rng));
    outliers.push_back(i);
  }
  PivotOptions plain;
  const auto naive = calibratePivot(poses, plain);
  PivotOptions robust;
  robust.robust = true;
  const auto result = calibratePivot(poses, robust);
  EXPECT_LT((result.tip_marker - scene.tip_marker).norm(), 0.3);
  for (int i : outliers) EXPECT_FALSE(result.inliers[static_cast<std::size_t>(i)]) << i;
  EXPECT_EQ(result.inlier_count, 190);
  EXPECT_GT((naive.tip_marker - scene.tip_marker).norm(), (result.tip_marker - scene.tip_marker).norm());
}

TEST(PivotCalibration, RefusesStaticToolTooFewPosesAndSmallRange) {
  std::mt19937 rng(4);
  PivotScene scene;
  const auto static_poses = pivotPoses(scene, 50, 0.0, 0.25, 0.0, rng);
  EXPECT_THROW(calibratePivot(static_poses), ComputationError);
  const auto few = pivotPoses(scene, 5, 30 * kDeg, 0.0, 0.0, rng);
  EXPECT_THROW(calibratePivot(few), ComputationError);
  const auto small = pivotPoses(scene, 50, 3 * kDeg, 0.25, 0.0, rng);
  try {
    calibratePivot(small);
    FAIL() << "expected ComputationError";
  } catch (const ComputationError& e) {
    EXPECT_NE(std::string(e.what()).find("pivot the tool further"), std::string::npos) << e.what();
  }
}

TEST(PivotCalibration, RefusesRotationAboutOneAxisOnly) {
  std::mt19937 rng(5);
  PivotScene scene;
  const auto poses = pivotPoses(scene, 100, 40 * kDeg, 0.0, 0.0, rng, /*one_axis=*/true);
  PivotOptions options;
  EXPECT_THROW(calibratePivot(poses, options), ComputationError);
  // In the operator's terms, from the coverage, also with tracker noise (which keeps the condition number finite).
  const auto noisy = pivotPoses(scene, 100, 40 * kDeg, 0.25, 0.1 * kDeg, rng, /*one_axis=*/true);
  try {
    calibratePivot(noisy, options);
    FAIL() << "expected ComputationError";
  } catch (const ComputationError& e) {
    EXPECT_NE(std::string(e.what()).find("one direction only"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("two directions"), std::string::npos) << e.what();
  }
}

TEST(PivotCalibration, RefusesNaNPoses) {
  std::mt19937 rng(6);
  PivotScene scene;
  auto poses = pivotPoses(scene, 50, 30 * kDeg, 0.0, 0.0, rng);
  poses[7].translation().x() = std::nan("");
  EXPECT_THROW(calibratePivot(poses), InvalidArgumentError);
}

TEST(PivotCalibration, IsInvariantToTheTrackerFrame) {
  // Property: expressing all poses in another frame moves the pivot point but not the tip.
  std::mt19937 rng(7);
  PivotScene scene;
  const auto poses = pivotPoses(scene, 60, 30 * kDeg, 0.2, 0.0, rng);
  Eigen::Isometry3d other_T_tracker = Eigen::Isometry3d::Identity();
  other_T_tracker.linear() = so3Exp(Eigen::Vector3d(1.0, 0.5, -2.0));
  other_T_tracker.translation() = Eigen::Vector3d(100, -300, 40);
  std::vector<Eigen::Isometry3d> moved;
  for (const auto& p : poses) moved.push_back(other_T_tracker * p);
  const auto a = calibratePivot(poses);
  const auto b = calibratePivot(moved);
  EXPECT_LT((a.tip_marker - b.tip_marker).norm(), 1e-8);
  EXPECT_LT((other_T_tracker * a.pivot_tracker - b.pivot_tracker).norm(), 1e-8);
}

// The live feedback's coverage: a two-axis swing uniform in a +/-30 deg square spans, along any direction
// theta, 60 (|cos theta| + |sin theta|) deg, between 60 and 84.9 (the square's covariance is isotropic, so its
// principal directions are arbitrary); 200 samples reach within ~2 deg of the ends. A one-axis swing spans
// 60 deg in the first and only the orientation noise in the second (0.1 deg RMS per axis: 200 Gaussian
// samples span ~5.5 sigma, 0.55 deg).
TEST(PivotCoverage, TwoAxisSwingCoversBothDirectionsOneAxisOnlyOne) {
  std::mt19937 rng(11);
  PivotScene scene;
  const auto two = pivotCoverage(pivotPoses(scene, 200, 30 * kDeg, 0.25, 0.1 * kDeg, rng));
  EXPECT_EQ(two.poses, 200u);
  EXPECT_GT(two.first_range / kDeg, 56.0);
  EXPECT_LT(two.first_range / kDeg, 86.0);
  EXPECT_GT(two.second_range / kDeg, 56.0);
  EXPECT_LT(two.second_range / kDeg, 86.0);
  const auto one = pivotCoverage(pivotPoses(scene, 200, 30 * kDeg, 0.25, 0.1 * kDeg, rng, /*one_axis=*/true));
  EXPECT_NEAR(one.first_range / kDeg, 60.0, 4.0);
  EXPECT_LT(one.second_range / kDeg, 1.5);
}

TEST(PivotCoverage, IsInvariantToTheTrackerFrameAndZeroWithoutMotion) {
  std::mt19937 rng(12);
  PivotScene scene;
  const auto poses = pivotPoses(scene, 80, 25 * kDeg, 0.2, 0.05 * kDeg, rng);
  Eigen::Isometry3d other_T_tracker = Eigen::Isometry3d::Identity();
  other_T_tracker.linear() = so3Exp(Eigen::Vector3d(-0.7, 1.1, 0.4));
  other_T_tracker.translation() = Eigen::Vector3d(-50, 200, 900);
  std::vector<Eigen::Isometry3d> moved;
  for (const auto& p : poses) moved.push_back(other_T_tracker * p);
  const auto a = pivotCoverage(poses), b = pivotCoverage(moved);
  EXPECT_NEAR(a.first_range, b.first_range, 1e-9);
  EXPECT_NEAR(a.second_range, b.second_range, 1e-9);
  EXPECT_EQ(pivotCoverage({}).first_range, 0.0);
  const std::vector<Eigen::Isometry3d> still(10, poses.front());
  EXPECT_LT(pivotCoverage(still).first_range, 1e-9);
}

std::vector<Eigen::Isometry3d> spinPoses(const Eigen::Vector3d& shaft_marker, int count, double max_angle,
                                         double sigma_rot, std::mt19937& rng) {
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<Eigen::Isometry3d> poses;
  const Eigen::Matrix3d base = so3Exp(Eigen::Vector3d(-0.4, 0.2, 0.9));
  for (int i = 0; i < count; ++i) {
    const double angle = max_angle * i / (count - 1);
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = so3Exp(sigma_rot * Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng))) * base *
                    so3Exp(angle * shaft_marker.normalized());
    pose.translation() = Eigen::Vector3d(10, 20, 30);
    poses.push_back(pose);
  }
  return poses;
}

TEST(SpinCalibration, RecoversShaftAxis) {
  std::mt19937 rng(8);
  const Eigen::Vector3d shaft = Eigen::Vector3d(0.1, -0.2, 1.0).normalized();
  const auto exact = spinPoses(shaft, 40, 180 * kDeg, 0.0, rng);
  const auto result = calibrateSpin(exact);
  EXPECT_LT(std::acos(std::min(1.0, result.shaft_marker.dot(shaft))), 1e-8);
  // With 0.1 deg orientation noise the axis error stays at the noise level.
  const auto noisy = spinPoses(shaft, 60, 180 * kDeg, 0.1 * kDeg, rng);
  const auto noisy_result = calibrateSpin(noisy);
  EXPECT_LT(std::acos(std::min(1.0, noisy_result.shaft_marker.dot(shaft))), 0.2 * kDeg);
  EXPECT_GT(noisy_result.spin_angle, 170 * kDeg);
}

TEST(SpinCalibration, RefusesTooLittleSpinAndNonSpinMotion) {
  std::mt19937 rng(9);
  const auto small = spinPoses(Eigen::Vector3d::UnitZ(), 40, 10 * kDeg, 0.0, rng);
  EXPECT_THROW(calibrateSpin(small), ComputationError);
  // A pivot (rotation about two axes) is not a spin.
  PivotScene scene;
  const auto pivot = pivotPoses(scene, 60, 40 * kDeg, 0.0, 0.0, rng);
  EXPECT_THROW(calibrateSpin(pivot), ComputationError);
}

}  // namespace
}  // namespace mrsns::registration
