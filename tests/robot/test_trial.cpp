// The simulated placement trial (paper 001 §III.C), small: 2 trials (4 screws) under the default noise
// model must complete every placement and meet the goal of <= 0.8 mm and <= 1.0 deg mean deviation.
#include <gtest/gtest.h>

#include "mrsns/core/error.h"
#include "mrsns/robot/placement_trial.h"

namespace mrsns::robot {
namespace {

TEST(PlacementTrial, TwoTrialsMeetTheGoalUnderTheNoiseModel) {
  PlacementTrialOptions o;
  o.trials = 2;
  o.seed = 3;
  o.advance_speed_mm_s = 10.0;  // half the simulated time of the default 5 mm/s; same noise model
  const auto r = runPlacementTrial(o);
  ASSERT_EQ(r.placements.size(), 4u);
  EXPECT_EQ(r.completed, 4);
  for (const auto& p : r.placements) {
    EXPECT_TRUE(p.completed) << p.path;
    // Tracking noise of 0.35 mm is averaged by the loop's filter; what remains is the registration (FLE
    // 0.35 mm over 8 fiducials: TRE ~0.2-0.3 mm) and the flange-marker calibration error at the drill's
    // lever arm, so no single screw should be near the paper's 1.04 mm.
    EXPECT_LT(p.distance_deviation_mm, 1.0) << p.path;
    EXPECT_LT(p.angle_deviation_deg, 1.2) << p.path;
    EXPECT_GT(p.min_soft_tissue_distance_mm, 2.0) << p.path;  // never inside the margin
  }
  EXPECT_LE(r.distance_deviation_mm.mean, 0.8);
  EXPECT_LE(r.angle_deviation_deg.mean, 1.0);
  // Nothing was noise-free: the chain really carried errors.
  EXPECT_GT(r.distance_deviation_mm.mean, 0.01);
  EXPECT_GT(r.calibration_residual_rms_mm, 0.0);
  EXPECT_GT(r.registration_fre_mm, 0.0);
}

TEST(PlacementTrial, NoiseFreeChainIsNearlyExact) {
  PlacementTrialOptions o;
  o.trials = 1;
  o.tracking_noise_mm = 0;
  o.tracking_rotation_deg = 0;
  o.registration_fle_mm = 0;
  const auto r = runPlacementTrial(o);
  EXPECT_EQ(r.completed, 2);
  // Without noise only the filter lag along the axis and the servo tracking remain.
  EXPECT_LT(r.distance_deviation_mm.max, 0.05);
  EXPECT_LT(r.angle_deviation_deg.max, 0.05);
}

TEST(PlacementTrial, RejectsBadOptions) {
  PlacementTrialOptions o;
  o.trials = 0;
  EXPECT_THROW(runPlacementTrial(o), InvalidArgumentError);
  o.trials = 1;
  o.tracking_noise_mm = -1;
  EXPECT_THROW(runPlacementTrial(o), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::robot
