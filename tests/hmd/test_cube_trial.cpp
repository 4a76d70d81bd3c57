// The simulated Fig. 7 protocol of paper 001 (cube_trial.h).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "mrsns/core/error.h"
#include "mrsns/hmd/cube_trial.h"

namespace mrsns::hmd {
namespace {

// Paired t statistic of a[i] - b[i] (the methods share each trial's user bias and scene).
double pairedT(const std::vector<double>& a, const std::vector<double>& b) {
  const double n = static_cast<double>(a.size());
  double mean = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) mean += (a[i] - b[i]) / n;
  double var = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) var += (a[i] - b[i] - mean) * (a[i] - b[i] - mean) / (n - 1.0);
  return mean / std::sqrt(var / n);
}

TEST(CubeTrial, SmallRunIsCompleteAndReproducible) {
  CubeTrialOptions o;
  o.trials = 3;
  o.seed = 42;
  const auto a = runCubeTrial(o);
  const auto b = runCubeTrial(o);
  for (const auto* m : {&a.compensated, &a.uncompensated, &a.pointer, &a.front_only_compensated}) {
    ASSERT_EQ(m->rms_mm.size(), 3u) << m->name;
    for (double e : m->rms_mm) {
      EXPECT_TRUE(std::isfinite(e));
      EXPECT_GT(e, 0.0);
      EXPECT_LT(e, 10.0);  // millimetres, not metres or a blown-up fit
    }
  }
  EXPECT_EQ(a.compensated.rms_mm, b.compensated.rms_mm);
  EXPECT_EQ(a.pointer.rms_mm, b.pointer.rms_mm);
  o.seed = 43;
  EXPECT_NE(runCubeTrial(o).compensated.rms_mm, a.compensated.rms_mm);
  // Around 9 % of the samples are jerks (4 %) or tremor extremes the filter drops.
  EXPECT_GT(a.mean_dropped_fraction, 0.02);
  EXPECT_LT(a.mean_dropped_fraction, 0.3);
}

TEST(CubeTrial, WithoutNoiseEveryMethodIsExact) {
  CubeTrialOptions o;
  o.trials = 2;
  CubeNoiseModel zero;
  zero.tremor_amplitude_mm = zero.tremor_rotation_deg = zero.drift_mm_per_s = zero.jerk_probability = 0.0;
  zero.depth_bias_mm = zero.depth_error_mm = zero.lateral_error_mm = zero.alignment_rotation_deg = 0.0;
  zero.slam_jitter_mm = zero.slam_jitter_deg = zero.tracking_mm = 0.0;
  zero.pointer_depth_error_mm = zero.pointer_lateral_error_mm = zero.pointer_tip_error_mm = 0.0;
  o.noise = zero;
  const auto r = runCubeTrial(o);
  for (const auto* m : {&r.compensated, &r.uncompensated, &r.pointer, &r.front_only_compensated}) {
    EXPECT_LT(m->mean_rms_mm, 1e-8) << m->name;
  }
}

// Paired over 60 trials (about 0.5 s): the four-view compensated method beats both others.
// With the default noise the expected gains are ~0.45 mm (uncompensated) and ~1.2 mm (pointer)
// against per-trial differences of ~0.7 and ~1 mm standard deviation, so t ~ 5 and ~9; t > 3
// fails by chance with probability ~0.2 %.
TEST(CubeTrial, CompensatedBeatsUncompensatedAndPointer) {
  CubeTrialOptions o;
  o.trials = 60;
  o.seed = 2024;
  const auto r = runCubeTrial(o);
  EXPECT_GT(pairedT(r.uncompensated.rms_mm, r.compensated.rms_mm), 3.0);
  EXPECT_GT(pairedT(r.pointer.rms_mm, r.compensated.rms_mm), 3.0);
  EXPECT_GT(r.improvement_vs_uncompensated_percent, 0.0);
  // The depth error lies along the front view's axis (hologram z and y): four views cut the
  // z component; the uncompensated method keeps it.
  EXPECT_LT(r.compensated.mean_abs_axis_error_mm.z(), r.uncompensated.mean_abs_axis_error_mm.z());
}

// The run `mrsns-cli hmd-trial` prints by default (12 trials, seed 1) meets the goal:
// compensated <= 1.2 mm and >= 20 % better than uncompensated (paper: 1.64 mm, 12.3 %).
TEST(CubeTrial, DefaultRunMeetsTheGoal) {
  const auto r = runCubeTrial();
  EXPECT_EQ(r.compensated.rms_mm.size(), 12u);
  EXPECT_LE(r.compensated.mean_rms_mm, 1.2);
  EXPECT_GE(r.improvement_vs_uncompensated_percent, 20.0);
  EXPECT_GT(r.improvement_vs_pointer_percent, 20.0);
}

TEST(CubeTrial, RefusesBadOptions) {
  CubeTrialOptions o;
  o.trials = 1;
  EXPECT_THROW(runCubeTrial(o), InvalidArgumentError);
  o = {};
  o.noise.tracking_mm = -1.0;
  EXPECT_THROW(runCubeTrial(o), InvalidArgumentError);
  o = {};
  o.noise.tremor_min_hz = 20.0;
  EXPECT_THROW(runCubeTrial(o), InvalidArgumentError);
  o = {};
  o.noise.hold_s = 0.01;
  EXPECT_THROW(runCubeTrial(o), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::hmd
