// Robot-tracker calibration: synthetic stations with a known flange_T_marker and base_T_tracker, exact and
// with tracker noise; degenerate station sets refused; generated stations are well conditioned.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/robot/robot_tracker_calibration.h"

namespace mrsns::robot {
namespace {

struct Truth {
  Eigen::Isometry3d flange_T_marker = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d base_T_tracker = Eigen::Isometry3d::Identity();
};

Truth makeTruth() {
  Truth t;
  t.flange_T_marker.linear() = so3Exp(Eigen::Vector3d(0.3, -0.2, 1.1));
  t.flange_T_marker.translation() << 40, -25, 90;
  t.base_T_tracker.linear() = so3Exp(Eigen::Vector3d(0.1, 2.0, -0.4));
  t.base_T_tracker.translation() << -300, 1200, 400;
  return t;
}

const Joints kCenter = (Joints() << 0.3, -1.4, 1.6, -1.8, -1.5, 0.4).finished();

// Tracker noise: marker position N(0, sigma^2) per axis, orientation N(0, sigma_rot^2) per axis.
std::vector<Eigen::Isometry3d> observe(const Truth& t, const std::vector<Eigen::Isometry3d>& base_T_flange,
                                       double sigma_mm, double sigma_rad, std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<Eigen::Isometry3d> out;
  for (const auto& b : base_T_flange) {
    Eigen::Isometry3d m = t.base_T_tracker.inverse() * b * t.flange_T_marker;
    m.translation() += sigma_mm * Eigen::Vector3d(n(rng), n(rng), n(rng));
    m.linear() = m.linear() * so3Exp(sigma_rad * Eigen::Vector3d(n(rng), n(rng), n(rng)));
    out.push_back(m);
  }
  return out;
}

TEST(RobotTrackerCalibration, RecoversExactTransforms) {
  const Ur5Kinematics kin;
  const auto poses = generateCalibrationPoses(kin, kCenter);
  ASSERT_EQ(poses.q.size(), 12u);
  const Truth t = makeTruth();
  std::mt19937_64 rng(1);
  const auto markers = observe(t, poses.base_T_flange, 0, 0, rng);
  const auto r = calibrateRobotTracker(poses.base_T_flange, markers);
  EXPECT_LT((r.flange_T_marker.matrix() - t.flange_T_marker.matrix()).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_LT((r.base_T_tracker.matrix() - t.base_T_tracker.matrix()).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_LT(r.translation_rms_mm, 1e-6);
  EXPECT_EQ(r.poses, 12);
  EXPECT_GT(r.axis_spread_rad, 0.3);  // three tilt axes
}

TEST(RobotTrackerCalibration, NoisyStationsGiveErrorsOfTheNoiseScale) {
  // Noise: 0.25 mm per axis (0.43 mm 3D RMS, a polaris-class tracker) and 0.15 deg per axis on the marker.
  const Ur5Kinematics kin;
  CalibrationPoseOptions po;
  po.count = 20;
  const auto poses = generateCalibrationPoses(kin, kCenter, po);
  const Truth t = makeTruth();
  std::mt19937_64 rng(2);
  const double sigma = 0.25, sigma_rot = 0.15 * M_PI / 180;
  const auto markers = observe(t, poses.base_T_flange, sigma, sigma_rot, rng);
  const auto r = calibrateRobotTracker(poses.base_T_flange, markers);
  // Residuals estimate the noise: per-station 3D residual RMS ~ sqrt(3) sigma (a little less: fitted).
  EXPECT_GT(r.translation_rms_mm, 0.5 * std::sqrt(3.0) * sigma);
  EXPECT_LT(r.translation_rms_mm, 1.5 * std::sqrt(3.0) * sigma);
  // Estimates: 20 stations average the noise; lever arms ~1.3 m from tracker to base make base_T_tracker's
  // translation the least certain (rotation error ~ sigma_rot / sqrt(20) * 1300 mm ~ 0.8 mm worst case).
  EXPECT_LT((r.flange_T_marker.translation() - t.flange_T_marker.translation()).norm(), 1.0);
  EXPECT_LT(rotationAngleBetween(r.flange_T_marker.linear(), t.flange_T_marker.linear()), 0.3 * M_PI / 180);
  const double tracker_rotation_error = rotationAngleBetween(r.base_T_tracker.linear(), t.base_T_tracker.linear());
  EXPECT_LT(tracker_rotation_error, 0.2 * M_PI / 180);
  // The tracker origin is ~1.3 m from the stations: its position error is that lever times the rotation
  // error (the two are correlated so the workspace itself stays accurate, checked below), plus the noise.
  double lever = 0;
  for (const auto& m : markers) lever += m.translation().norm() / static_cast<double>(markers.size());
  EXPECT_LT((r.base_T_tracker.translation() - t.base_T_tracker.translation()).norm(),
            tracker_rotation_error * lever + 1.0);
  // The calibrated chain predicts the marker at any station to about the noise.
  for (std::size_t i = 0; i < poses.q.size(); ++i) {
    const auto predicted = r.base_T_tracker.inverse() * poses.base_T_flange[i] * r.flange_T_marker;
    const auto truth = t.base_T_tracker.inverse() * poses.base_T_flange[i] * t.flange_T_marker;
    EXPECT_LT((predicted.translation() - truth.translation()).norm(), 1.0);
  }
}

TEST(RobotTrackerCalibration, RefusesDegenerateStationSets) {
  const Ur5Kinematics kin;
  const Truth t = makeTruth();
  std::mt19937_64 rng(3);
  // Only the last wrist joint turns: every relative rotation is about the flange z axis.
  std::vector<Eigen::Isometry3d> flange;
  for (int k = 0; k < 8; ++k) {
    Joints q = kCenter;
    q[5] += 0.2 * k;
    flange.push_back(kin.forward(q));
  }
  EXPECT_THROW(calibrateRobotTracker(flange, observe(t, flange, 0.1, 0, rng)), InvalidArgumentError);
  // Pure translations: no rotation at all.
  flange.clear();
  for (int k = 0; k < 8; ++k) {
    Eigen::Isometry3d T = kin.forward(kCenter);
    T.translation() += Eigen::Vector3d(10.0 * k, -5.0 * k, 3.0 * (k % 3));
    flange.push_back(T);
  }
  EXPECT_THROW(calibrateRobotTracker(flange, observe(t, flange, 0.1, 0, rng)), InvalidArgumentError);
  // Mismatched and too few.
  EXPECT_THROW(calibrateRobotTracker(flange, {}), InvalidArgumentError);
  flange.resize(3);
  EXPECT_THROW(calibrateRobotTracker(flange, observe(t, flange, 0.1, 0, rng)), InvalidArgumentError);
  try {
    flange.clear();
    for (int k = 0; k < 8; ++k) {
      Joints q = kCenter;
      q[5] += 0.2 * k;
      flange.push_back(kin.forward(q));
    }
    calibrateRobotTracker(flange, observe(t, flange, 0.1, 0, rng));
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("axes"), std::string::npos) << e.what();
  }
}

TEST(RobotTrackerCalibration, GeneratorStaysReachableAndRejectsBadOptions) {
  const Ur5Kinematics kin;
  const auto poses = generateCalibrationPoses(kin, kCenter);
  for (std::size_t i = 0; i < poses.q.size(); ++i) {
    EXPECT_TRUE(withinLimits(poses.q[i], ur5JointLimits()));
    EXPECT_FALSE(kin.singularity(poses.q[i]).any());
    EXPECT_LT((kin.forward(poses.q[i]).matrix() - poses.base_T_flange[i].matrix()).cwiseAbs().maxCoeff(), 1e-9);
    const double tilt = rotationAngleBetween(poses.base_T_flange[i].linear(), kin.forward(kCenter).linear());
    EXPECT_LE(tilt, 0.45 + 1e-9);
  }
  CalibrationPoseOptions o;
  o.count = 2;
  EXPECT_THROW(generateCalibrationPoses(kin, kCenter, o), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::robot
