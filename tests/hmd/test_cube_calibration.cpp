// Calibration cube (paper 001 Eq. 2-3): synthetic ground truth, noise statistics, bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/hmd/cube_calibration.h"

namespace mrsns::hmd {
namespace {

// The 8 vertices of a 60 mm cube centred at c (hologram frame).
std::vector<Eigen::Vector3d> cubeVertices(const Eigen::Vector3d& c = Eigen::Vector3d(10, -20, 400)) {
  std::vector<Eigen::Vector3d> v;
  for (int i = 0; i < 8; ++i) v.push_back(c + 30.0 * Eigen::Vector3d(i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1));
  return v;
}

Eigen::Isometry3d someTransform(double scale = 1.0) {
  Vector6d xi;
  xi << 120.0, -340.0, 1500.0, 0.4 * scale, -1.1 * scale, 2.0 * scale;
  return se3Exp(xi);
}

std::vector<Eigen::Vector3d> mapPoints(const Eigen::Isometry3d& T, const std::vector<Eigen::Vector3d>& p) {
  std::vector<Eigen::Vector3d> out;
  for (const auto& x : p) out.push_back(T * x);
  return out;
}

TEST(CubeCalibration, ExactDataRecoversRigidAndAffineMaps) {
  const auto hol = cubeVertices();
  const Eigen::Isometry3d tracker_T_hol = someTransform();
  const auto tra = mapPoints(tracker_T_hol, hol);
  const auto r = calibrateCube(tra, hol);
  EXPECT_LT((r.tracker_T_hololens.matrix() - tracker_T_hol.matrix()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((r.tracker_A_hololens - tracker_T_hol.matrix()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT(r.rigid_rms_mm, 1e-9);
  EXPECT_LT(r.affine_rms_mm, 1e-9);
  EXPECT_LT(r.affine_rigidity_deviation, 1e-9);
  ASSERT_EQ(r.rigid_residuals_mm.size(), 8u);
  // A cube is the best-conditioned configuration: after normalisation the DLT is near isotropic.
  EXPECT_LT(r.dlt_condition_number, 5.0);
}

TEST(CubeCalibration, DltRecoversAKnownAffineMapAndReportsItsScale) {
  const auto hol = cubeVertices();
  Eigen::Matrix4d A = someTransform().matrix();
  // 3 % stretch along the hologram's z (a depth-perception scale error).
  A.topLeftCorner<3, 3>() = A.topLeftCorner<3, 3>() * Eigen::Vector3d(1.0, 1.0, 1.03).asDiagonal();
  std::vector<Eigen::Vector3d> tra;
  for (const auto& p : hol) tra.push_back((A * p.homogeneous()).head<3>());
  const auto r = calibrateCube(tra, hol);
  EXPECT_LT((r.tracker_A_hololens - A).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_NEAR(r.affine_singular_values(0), 1.03, 1e-9);
  EXPECT_NEAR(r.affine_rigidity_deviation, 0.03, 1e-9);
  // The rigid map cannot absorb the stretch: residuals of order 0.03 * 30 mm remain.
  EXPECT_GT(r.rigid_rms_mm, 0.3);
  EXPECT_LT(r.affine_rms_mm, 1e-8);
}

// Noise model: isotropic Gaussian, sigma = 0.35 mm per axis on the tracker points (the
// Polaris Vega's accuracy), 8 cube vertices. Theory (Fitzpatrick): E[FRE^2] = (1 - 2/N) FLE^2
// and the error at the centroid has RMS FLE / sqrt(N), with FLE^2 = 3 sigma^2.
TEST(CubeCalibration, NoiseStatisticsMatchTheory) {
  const auto hol = cubeVertices();
  const Eigen::Isometry3d tracker_T_hol = someTransform();
  const auto tra_exact = mapPoints(tracker_T_hol, hol);
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.35);
  const int trials = 400;
  double fre2 = 0.0, centroid2 = 0.0, affine_fre2 = 0.0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : hol) centroid += p / 8.0;
  for (int t = 0; t < trials; ++t) {
    auto tra = tra_exact;
    for (auto& p : tra) p += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    const auto r = calibrateCube(tra, hol);
    fre2 += r.rigid_rms_mm * r.rigid_rms_mm;
    affine_fre2 += r.affine_rms_mm * r.affine_rms_mm;
    centroid2 += (r.tracker_T_hololens * centroid - tracker_T_hol * centroid).squaredNorm();
    EXPECT_LE(r.affine_rms_mm, r.rigid_rms_mm + 1e-12);  // more parameters never fit worse
  }
  const double fle2 = 3.0 * 0.35 * 0.35;
  // 400 trials x 24 residual dof: the relative standard error of the mean square is ~3 %.
  EXPECT_NEAR(fre2 / trials, (1.0 - 2.0 / 8.0) * fle2, 0.12 * (1.0 - 2.0 / 8.0) * fle2);
  EXPECT_NEAR(centroid2 / trials, fle2 / 8.0, 0.2 * fle2 / 8.0);
  // The affine fit has 12 - 6 = 6 more parameters: E[FRE^2] = (3N - 12) / (3N) FLE^2.
  EXPECT_NEAR(affine_fre2 / trials, (24.0 - 12.0) / 24.0 * fle2, 0.15 * (12.0 / 24.0) * fle2);
}

TEST(CubeCalibration, VerticesFromDigitisationRoundTrip) {
  const auto vertex_cube = cubeVertices(Eigen::Vector3d(0, 0, 40));
  std::vector<Eigen::Isometry3d> poses;
  std::vector<Eigen::Vector3d> tips;
  for (int i = 0; i < 8; ++i) {
    poses.push_back(someTransform(0.1 * (i + 1)));
    tips.push_back(poses.back() * vertex_cube[static_cast<std::size_t>(i)]);
  }
  const auto back = cubeVerticesFromDigitisation(tips, poses);
  for (int i = 0; i < 8; ++i)
    EXPECT_LT((back[static_cast<std::size_t>(i)] - vertex_cube[static_cast<std::size_t>(i)]).norm(), 1e-9);
  const auto in_tracker = cubeFiducialsInTracker(poses[0], vertex_cube);
  EXPECT_LT((in_tracker[3] - poses[0] * vertex_cube[3]).norm(), 1e-12);
  EXPECT_THROW(cubeVerticesFromDigitisation(tips, std::span<const Eigen::Isometry3d>(poses).first(2)),
               InvalidArgumentError);
}

TEST(CubeCalibration, RefusesFewerThanFourPoints) {
  const auto hol = cubeVertices();
  const auto tra = mapPoints(someTransform(), hol);
  try {
    calibrateCube(std::span<const Eigen::Vector3d>(tra).first(3), std::span<const Eigen::Vector3d>(hol).first(3));
    FAIL() << "3 points accepted";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("at least 4"), std::string::npos) << e.what();
  }
}

TEST(CubeCalibration, RefusesCoplanarAndCollinearPoints) {
  // One face of the cube: 4 coplanar vertices (x = -30 face: i even).
  const auto all = cubeVertices();
  std::vector<Eigen::Vector3d> face = {all[0], all[2], all[4], all[6]};
  const auto face_tra = mapPoints(someTransform(), face);
  try {
    calibrateCube(face_tra, face);
    FAIL() << "coplanar points accepted";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("coplanar"), std::string::npos) << e.what();
  }
  std::vector<Eigen::Vector3d> line;
  for (int i = 0; i < 5; ++i) line.push_back(Eigen::Vector3d(i * 10.0, 0.0, 0.0));
  try {
    calibrateCube(mapPoints(someTransform(), line), line);
    FAIL() << "collinear points accepted";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("collinear"), std::string::npos) << e.what();
  }
}

TEST(CubeCalibration, RefusesMismatchedAndNonFiniteInput) {
  const auto hol = cubeVertices();
  auto tra = mapPoints(someTransform(), hol);
  EXPECT_THROW(calibrateCube(std::span<const Eigen::Vector3d>(tra).first(7), hol), InvalidArgumentError);
  tra[2].x() = std::nan("");
  EXPECT_THROW(calibrateCube(tra, hol), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::hmd
