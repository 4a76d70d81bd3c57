// Pointer tip, digitisation and RANSAC fit of the ideal checkerboard grid.
// Noise model: digitised corners carry isotropic Gaussian noise of 0.5 mm 3D
// RMS (tip placement plus tracker), plus one gross outlier (a corner touched
// 6 mm off) where stated.
#include <gtest/gtest.h>

#include <random>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/hmd/checkerboard_grid.h"

namespace mrsns::hmd {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

Eigen::Isometry3d boardTGrid() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = so3Exp(Eigen::Vector3d(0.1, -0.05, 0.4));
  T.translation() = Eigen::Vector3d(-60, 40, 3);
  return T;
}

std::vector<Eigen::Vector3d> digitised(const CheckerboardSpec& spec, double rms_3d, std::mt19937& rng) {
  std::normal_distribution<double> g(0.0, rms_3d / std::sqrt(3.0));
  std::vector<Eigen::Vector3d> pts;
  for (const auto& c : idealGridCorners(spec))
    pts.push_back(boardTGrid() * c + Eigen::Vector3d(g(rng), g(rng), g(rng)));
  return pts;
}

TEST(CheckerboardGrid, IdealGridIsRowMajor) {
  const auto g = idealGridCorners({3, 5, 40.0});
  ASSERT_EQ(g.size(), 15u);
  EXPECT_TRUE(g[1].isApprox(Eigen::Vector3d(40, 0, 0)));
  EXPECT_TRUE(g[5].isApprox(Eigen::Vector3d(0, 40, 0)));
  EXPECT_THROW(idealGridCorners({1, 5, 40.0}), InvalidArgumentError);
  EXPECT_THROW(idealGridCorners({3, 5, 0.0}), InvalidArgumentError);
}

TEST(CheckerboardGrid, ExactCornersGiveExactPose) {
  std::mt19937 rng(1);
  const CheckerboardSpec spec{3, 5, 40.0};
  const auto r = fitCheckerboardGrid(digitised(spec, 0.0, rng), spec);
  EXPECT_LT(rotationAngleBetween(r.board_T_grid.linear(), boardTGrid().linear()), 1e-9);
  EXPECT_LT((r.board_T_grid.translation() - boardTGrid().translation()).norm(), 1e-9);
  EXPECT_LT(r.rms_mm, 1e-9);
  EXPECT_NEAR(r.row_column_angle_deg, 90.0, 1e-6);
  EXPECT_NEAR(r.mean_spacing_mm, 40.0, 1e-9);
}

// 0.5 mm noise on 15 corners over 160 x 80 mm: the fitted corners move by about
// 0.5 / sqrt(15) ~ 0.13 mm RMS; every corner of the fit within 4x that (0.6 mm), the outlier
// rejected, the inlier RMS close to the noise (0.5 * sqrt(1 - 6/45) = 0.47 mm expected).
TEST(CheckerboardGrid, NoisyCornersWithOutlier) {
  std::mt19937 rng(5);
  const CheckerboardSpec spec{3, 5, 40.0};
  for (int trial = 0; trial < 20; ++trial) {
    auto pts = digitised(spec, 0.5, rng);
    pts[7] += Eigen::Vector3d(6.0, 0.0, 0.0);
    const auto r = fitCheckerboardGrid(pts, spec);
    EXPECT_FALSE(r.inliers[7]);
    EXPECT_EQ(r.inlier_count, 14);
    EXPECT_GT(r.residuals_mm[7], 4.0);
    EXPECT_LT(r.rms_mm, 1.0);
    double worst = 0.0;
    for (const auto& c : idealGridCorners(spec))
      worst = std::max(worst, (r.board_T_grid * c - boardTGrid() * c).norm());
    EXPECT_LT(worst, 0.6);
    EXPECT_NEAR(r.row_column_angle_deg, 90.0, 1.5);
  }
}

TEST(CheckerboardGrid, WrongCountOrSquareSizeIsRefused) {
  std::mt19937 rng(2);
  const CheckerboardSpec spec{3, 5, 40.0};
  auto pts = digitised(spec, 0.3, rng);
  std::vector<Eigen::Vector3d> fewer(pts.begin(), pts.end() - 1);
  EXPECT_THROW(fitCheckerboardGrid(fewer, spec), InvalidArgumentError);
  try {
    fitCheckerboardGrid(pts, CheckerboardSpec{3, 5, 30.0});
    ADD_FAILURE() << "a 40 mm board fitted as 30 mm";
  } catch (const ComputationError& e) {
    EXPECT_NE(std::string(e.what()).find("square size"), std::string::npos) << e.what();
  }
}

// Pivot of a pointer whose tip is 150 mm from its marker: 0.25 mm / 0.1 deg tracker noise is
// accepted; a tip that slips by several mm between poses (non-rigid pointer data) is refused.
TEST(PointerCalibration, RigidAcceptedNonRigidRefused) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> g(0.0, 1.0);
  const Eigen::Vector3d tip(2, -1, 150), divot(10, 20, -1500);
  auto poses = [&](double slip_mm) {
    std::vector<Eigen::Isometry3d> out;
    for (int i = 0; i < 40; ++i) {
      Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
      p.linear() = so3Exp(Eigen::Vector3d(25 * kDeg * u(rng), 25 * kDeg * u(rng), u(rng)));
      const Eigen::Vector3d moved_tip = tip + slip_mm * Eigen::Vector3d(g(rng), g(rng), g(rng));
      p.translation() = divot - p.linear() * moved_tip + 0.15 * Eigen::Vector3d(g(rng), g(rng), g(rng));
      out.push_back(p);
    }
    return out;
  };
  double rms = 0.0;
  const Eigen::Vector3d est = calibratePointerTip(poses(0.0), {}, &rms);
  EXPECT_LT((est - tip).norm(), 0.5);
  EXPECT_LT(rms, 0.5);
  try {
    calibratePointerTip(poses(3.0));
    ADD_FAILURE() << "slipping pointer accepted";
  } catch (const ComputationError& e) {
    EXPECT_NE(std::string(e.what()).find("not rigid"), std::string::npos) << e.what();
  }
  auto sheared = poses(0.0);
  sheared[3].matrix()(0, 1) += 0.2;  // not a rotation
  EXPECT_THROW(calibratePointerTip(sheared), InvalidArgumentError);
  std::vector<Eigen::Isometry3d> board(sheared.size(), Eigen::Isometry3d::Identity());
  EXPECT_THROW(digitiseInBoard(sheared, board, tip), InvalidArgumentError);
  board.pop_back();
  EXPECT_THROW(digitiseInBoard(poses(0.0), board, tip), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::hmd
