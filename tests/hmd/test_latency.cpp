// Latency estimation (paper 000 §2.2) and latency compensation by prediction.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <vector>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/hmd/latency.h"
#include "mrsns/hmd/latency_predictor.h"

namespace mrsns::hmd {
namespace {

constexpr double kPi = std::numbers::pi;

// Head position while walking back and forth (tracker frame, mm): 3 m strides along x (PC1),
// lateral sway 30 mm at half the step rate (PC2), vertical bob 20 mm at the step rate
// 1.8 Hz (PC3), the paper's mid-stance pattern; a slow step-rate wobble keeps the events from
// being perfectly periodic.
Eigen::Vector3d headPosition(double t) {
  const double step_hz = 1.8 + 0.1 * std::sin(2.0 * kPi * 0.07 * t);
  return {1500.0 * std::sin(2.0 * kPi * 0.05 * t), 30.0 * std::sin(kPi * step_hz * t),
          1650.0 + 20.0 * std::sin(2.0 * kPi * step_hz * t + 0.3)};
}

struct Recording {
  std::vector<double> tt, th;
  std::vector<Eigen::Vector3d> pt, ph;
};

// Noise model: tracker 120 Hz, 0.2 mm per axis; HMD 60 Hz with 1 ms timestamp jitter,
// 0.5 mm per axis, in its own frame (rotated and shifted), and `latency` late: the HMD
// reports at t the pose the head had at t - latency.
Recording record(double latency, double duration, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  Recording r;
  for (double t = 0.0; t < duration; t += 1.0 / 120.0) {
    r.tt.push_back(t);
    r.pt.push_back(headPosition(t) + 0.2 * Eigen::Vector3d(n(rng), n(rng), n(rng)));
  }
  Eigen::Isometry3d slam_T_tracker = Eigen::Isometry3d::Identity();
  slam_T_tracker.linear() = so3Exp(Eigen::Vector3d(0.4, -1.9, 0.7));
  slam_T_tracker.translation() = Eigen::Vector3d(-300, 80, 1200);
  for (int k = 0; k * (1.0 / 60.0) < duration; ++k) {
    const double t = 0.37 + k / 60.0 + 0.001 * n(rng);  // different start, jittered clock
    r.th.push_back(t);
    r.ph.push_back(slam_T_tracker * headPosition(t - latency) + 0.5 * Eigen::Vector3d(n(rng), n(rng), n(rng)));
  }
  return r;
}

TEST(Latency, RecoversAnInjected40MsLatencyBothWays) {
  const auto rec = record(0.040, 40.0, 1);
  const auto r = estimateLatency(rec.tt, rec.pt, rec.th, rec.ph);
  // Within half the HMD's sample period (8.3 ms / 2); in practice far better.
  const double half_period = 0.5 / 60.0;
  EXPECT_NEAR(r.xcorr_latency_s, 0.040, half_period);
  EXPECT_NEAR(r.event_mean_s, 0.040, half_period);
  EXPECT_NEAR(r.event_median_s, 0.040, half_period);
  // ~2 events per step cycle (max and min) over 40 s at 1.8 Hz.
  EXPECT_GT(r.events.size(), 100u);
  EXPECT_LT(r.event_std_s, 0.010);
  EXPECT_GT(r.xcorr_peak, 0.9);
  // The bob is the smallest-variance axis (third component) in both frames.
  EXPECT_LT(r.tracker_explained_variance(2), 0.01);
}

TEST(Latency, NegativeAndZeroLatencyAndSignOfTheComponent) {
  for (double latency : {0.0, -0.025, 0.120}) {
    const auto rec = record(latency, 30.0, 7);
    const auto r = estimateLatency(rec.tt, rec.pt, rec.th, rec.ph);
    EXPECT_NEAR(r.xcorr_latency_s, latency, 0.5 / 60.0) << latency;
    EXPECT_NEAR(r.event_mean_s, latency, 0.5 / 60.0) << latency;
  }
  // Mirroring the HMD series flips its principal axes' sign: detected, same answer.
  auto rec = record(0.040, 30.0, 8);
  for (auto& p : rec.ph) p = -p;
  const auto r = estimateLatency(rec.tt, rec.pt, rec.th, rec.ph);
  EXPECT_NEAR(r.event_mean_s, 0.040, 0.5 / 60.0);
}

// A perfectly periodic bob correlates equally at the true lag and, sign-flipped, half a step
// period (278 ms) away: the short lag must win.
TEST(Latency, SteadyPeriodicMotionIsNotAmbiguous) {
  std::vector<double> tt, th;
  std::vector<Eigen::Vector3d> pt, ph;
  auto head = [](double t) {
    return Eigen::Vector3d(1500.0 * std::sin(2 * kPi * 0.05 * t), 30.0 * std::sin(kPi * 1.8 * t),
                           20.0 * std::sin(2 * kPi * 1.8 * t));
  };
  for (int k = 0; k < 120 * 20; ++k) {
    tt.push_back(k / 120.0);
    pt.push_back(head(tt.back()));
  }
  for (int k = 0; k < 60 * 20; ++k) {
    th.push_back(0.2 + k / 60.0);
    ph.push_back(-head(th.back() - 0.040));  // mirrored frame: the PCA sign flips
  }
  const auto r = estimateLatency(tt, pt, th, ph);
  EXPECT_NEAR(r.xcorr_latency_s, 0.040, 0.5 / 60.0);
  EXPECT_NEAR(r.event_mean_s, 0.040, 0.5 / 60.0);
}

TEST(Latency, RefusesBadSeries) {
  const auto rec = record(0.04, 10.0, 2);
  std::vector<double> few(rec.tt.begin(), rec.tt.begin() + 10);
  std::vector<Eigen::Vector3d> fewp(rec.pt.begin(), rec.pt.begin() + 10);
  EXPECT_THROW(estimateLatency(few, fewp, rec.th, rec.ph), InvalidArgumentError);
  auto t = rec.tt;
  t[50] = t[49];
  EXPECT_THROW(estimateLatency(t, rec.pt, rec.th, rec.ph), InvalidArgumentError);
  auto shifted = rec.th;
  for (double& x : shifted) x += 1000.0;  // clocks that never overlap
  EXPECT_THROW(estimateLatency(rec.tt, rec.pt, shifted, rec.ph), InvalidArgumentError);
  // A still head: no events.
  std::vector<Eigen::Vector3d> still(rec.pt.size(), Eigen::Vector3d(1, 2, 3));
  std::vector<Eigen::Vector3d> still_h(rec.ph.size(), Eigen::Vector3d(4, 5, 6));
  EXPECT_THROW(estimateLatency(rec.tt, still, rec.th, still_h), Error);
}

// Head pose at 60 Hz: 50 mm / 0.5 Hz and 30 mm / 0.8 Hz translation, 10 deg / 0.3 Hz rotation.
Eigen::Isometry3d headPose(double t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = so3Exp(Eigen::Vector3d(0.17 * std::sin(2 * kPi * 0.3 * t), 0.1 * std::sin(2 * kPi * 0.2 * t + 1), 0.05));
  T.translation() = Eigen::Vector3d(50 * std::sin(2 * kPi * 0.5 * t), 30 * std::cos(2 * kPi * 0.8 * t), 1600);
  return T;
}

// Noise model: 0.3 mm and 0.003 rad per axis on each measured pose; latency 40 ms.
TEST(LatencyPredictor, PredictionLowersTheErrorOfAKnownLatency) {
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<double> t;
  std::vector<Eigen::Isometry3d> truth, measured;
  for (int k = 0; k < 600; ++k) {
    t.push_back(k / 60.0);
    truth.push_back(headPose(t.back()));
    Vector6d xi;
    xi << 0.3 * n(rng), 0.3 * n(rng), 0.3 * n(rng), 0.003 * n(rng), 0.003 * n(rng), 0.003 * n(rng);
    measured.push_back(truth.back() * se3Exp(xi));
  }
  PredictorOptions cv;
  cv.model = PredictorModel::kConstantVelocity;
  const auto e_cv = evaluatePredictor(t, measured, truth, 0.040, cv);
  const auto e_kf = evaluatePredictor(t, measured, truth, 0.040, PredictorOptions{});
  // Without prediction the hologram trails by v * 40 ms: peak speed 2 pi (0.5 * 50) = 157 mm/s.
  EXPECT_GT(e_kf.rms_translation_none_mm, 3.0);
  EXPECT_LT(e_cv.rms_translation_predicted_mm, 0.6 * e_cv.rms_translation_none_mm);
  // The filter averages the velocity over several samples: better than two-sample differences.
  EXPECT_LT(e_kf.rms_translation_predicted_mm, e_cv.rms_translation_predicted_mm);
  EXPECT_LT(e_kf.rms_translation_predicted_mm, 0.3 * e_kf.rms_translation_none_mm);
  EXPECT_LT(e_kf.rms_rotation_predicted_rad, e_kf.rms_rotation_none_rad);
  EXPECT_GT(e_kf.count, 500);
  std::printf("none %.3f mm %.4f rad, cv %.3f mm %.4f rad, kalman %.3f mm %.4f rad\n", e_kf.rms_translation_none_mm,
              e_kf.rms_rotation_none_rad, e_cv.rms_translation_predicted_mm, e_cv.rms_rotation_predicted_rad,
              e_kf.rms_translation_predicted_mm, e_kf.rms_rotation_predicted_rad);
}

TEST(LatencyPredictor, ExactOnConstantTwistAndRobustToBadSamples) {
  Vector6d twist;
  twist << 100.0, -20.0, 5.0, 0.3, -0.1, 0.2;
  PosePredictor p(PredictorOptions{.model = PredictorModel::kConstantVelocity});
  EXPECT_TRUE(p.predict(1.0).isApprox(Eigen::Isometry3d::Identity()));
  for (int k = 0; k < 5; ++k) p.update(k * 0.02, se3Exp(twist * (k * 0.02)));
  EXPECT_LT((p.predict(0.08 + 0.05).matrix() - se3Exp(twist * 0.13).matrix()).cwiseAbs().maxCoeff(), 1e-9);
  p.update(0.05, Eigen::Isometry3d::Identity());  // time going backwards
  Eigen::Isometry3d nan_pose = Eigen::Isometry3d::Identity();
  nan_pose.translation().x() = std::nan("");
  p.update(0.2, nan_pose);
  EXPECT_EQ(p.rejected(), 2);
  EXPECT_EQ(p.samples(), 5);
  EXPECT_TRUE(p.predict(0.1).matrix().allFinite());
}

TEST(LatencyPredictor, EvaluationRefusesBadInput) {
  std::vector<double> t = {0, 1, 2};
  std::vector<Eigen::Isometry3d> poses(3, Eigen::Isometry3d::Identity());
  EXPECT_THROW(evaluatePredictor(t, poses, poses, 0.04), InvalidArgumentError);  // fewer than warm-up
  EXPECT_THROW(evaluatePredictor(t, poses, poses, -1.0, {}, 0), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::hmd
