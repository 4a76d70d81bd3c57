// Hand-tremor compensation (paper 001 Eq. 12-17).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/hmd/tremor_compensation.h"

namespace mrsns::hmd {
namespace {

// One fiducial held for 2 s at 60 Hz. Noise model: tremor 0.5 mm amplitude at 10 Hz on each
// axis (random phases), tracking noise 0.15 mm per axis, and `jerks` samples displaced by
// 3-5 mm in random directions (sudden hand movements).
std::vector<Eigen::Vector3d> heldSamples(const Eigen::Vector3d& centre, int jerks, std::mt19937& rng) {
  std::uniform_real_distribution<double> phase(0.0, 2.0 * std::numbers::pi);
  std::normal_distribution<double> n(0.0, 0.15);
  std::normal_distribution<double> dir(0.0, 1.0);
  std::uniform_real_distribution<double> jerk(3.0, 5.0);
  const Eigen::Vector3d ph(phase(rng), phase(rng), phase(rng));
  std::vector<Eigen::Vector3d> s;
  for (int k = 0; k < 120; ++k) {
    const double t = k / 60.0;
    Eigen::Vector3d p = centre;
    for (int a = 0; a < 3; ++a) p(a) += 0.5 * std::sin(2.0 * std::numbers::pi * 10.0 * t + ph(a)) + n(rng);
    s.push_back(p);
  }
  // Jerks go the same way (a hand slips in one direction), so they bias the plain mean.
  const Eigen::Vector3d d = Eigen::Vector3d(dir(rng), dir(rng), dir(rng)).normalized();
  for (int j = 0; j < jerks; ++j) s[static_cast<std::size_t>(7 * j + 3)] = centre + jerk(rng) * d;
  return s;
}

TEST(TremorCompensation, DropsJerksAndBeatsThePlainMean) {
  std::mt19937 rng(11);
  const int fiducials = 40;
  double err_comp = 0.0, err_raw = 0.0;
  int jerks_kept = 0;
  for (int f = 0; f < fiducials; ++f) {
    const Eigen::Vector3d c(f, 2.0 * f, 300.0);
    const auto s = heldSamples(c, 10, rng);
    const auto r = compensateTremor(s);
    err_comp += (r.centre - c).norm();
    err_raw += (r.raw_mean - c).norm();
    for (int j = 0; j < 10; ++j) jerks_kept += r.kept[static_cast<std::size_t>(7 * j + 3)] ? 1 : 0;
    EXPECT_GT(r.kept_count, 90);  // the filter keeps most of the hold
  }
  // 10 jerks of ~4 mm in 120 samples bias the mean by ~0.33 mm; dropping them leaves the
  // tremor/noise average, whose error is ~0.03 mm.
  EXPECT_LT(err_comp / fiducials, 0.5 * err_raw / fiducials);
  EXPECT_LT(err_comp / fiducials, 0.12);
  EXPECT_LT(jerks_kept, fiducials * 10 / 10);  // fewer than 10 % of jerks survive
}

TEST(TremorCompensation, CleanHoldGivesTheMean) {
  std::mt19937 rng(3);
  const Eigen::Vector3d c(1, 2, 3);
  const auto s = heldSamples(c, 0, rng);
  const auto r = compensateTremor(s);
  // Without outliers only a few edge samples may go; the centre stays within the mean's
  // standard error (~0.04 mm) of the raw mean.
  EXPECT_LT((r.centre - r.raw_mean).norm(), 0.1);
  EXPECT_EQ(r.curvature.size(), s.size());
  for (double k : r.curvature) EXPECT_LE(k, 0.0);  // Eq. 12 with beta in [0, pi/2]
}

TEST(TremorCompensation, RefusesTooFewSamplesAndBadOptions) {
  std::vector<Eigen::Vector3d> four(4, Eigen::Vector3d::Zero());
  EXPECT_THROW(compensateTremor(four), InvalidArgumentError);
  std::vector<Eigen::Vector3d> ten;
  for (int i = 0; i < 10; ++i) ten.emplace_back(i, i * i, 0.5 * i);
  TremorOptions bad;
  bad.omega = 0.0;
  EXPECT_THROW(compensateTremor(ten, bad), InvalidArgumentError);
  bad = {};
  bad.k_close = 1;
  EXPECT_THROW(compensateTremor(ten, bad), InvalidArgumentError);
  ten[4].y() = INFINITY;
  EXPECT_THROW(compensateTremor(ten), InvalidArgumentError);
}

TEST(TremorCompensation, DuplicateSamplesDoNotProduceNaN) {
  std::vector<Eigen::Vector3d> s(20, Eigen::Vector3d(5, 5, 5));
  s.push_back(Eigen::Vector3d(6, 5, 5));
  const auto r = compensateTremor(s);
  EXPECT_TRUE(r.centre.allFinite());
  EXPECT_LT((r.centre - Eigen::Vector3d(5, 5, 5)).norm(), 0.1);
}

TEST(TremorCompensation, ViewCalibrationWithEightFiducials) {
  std::mt19937 rng(5);
  std::vector<Eigen::Vector3d> hol;
  for (int i = 0; i < 8; ++i) hol.push_back(30.0 * Eigen::Vector3d(i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1));
  Vector6d xi;
  xi << 50, 60, 900, 0.3, 0.2, -0.4;
  const Eigen::Isometry3d tracker_T_hol = se3Exp(xi);
  std::vector<std::vector<Eigen::Vector3d>> samples;
  for (const auto& p : hol) samples.push_back(heldSamples(tracker_T_hol * p, 8, rng));
  const auto r = calibrateViewWithTremorCompensation(samples, hol);
  // Each centre is within ~0.1 mm: the calibration's error at the cube is of that order.
  for (const auto& p : hol) EXPECT_LT((r.calibration.tracker_T_hololens * p - tracker_T_hol * p).norm(), 0.15);
  ASSERT_EQ(r.dropped_samples.size(), 8u);
  EXPECT_THROW(
      calibrateViewWithTremorCompensation(std::span<const std::vector<Eigen::Vector3d>>(samples).first(7), hol),
      InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::hmd
