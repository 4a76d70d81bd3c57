// Soft-tissue tracking replayed from the navigation loop's hook: the
// simulated carotid sweep frame by frame, the posterior's error against the
// held-out ground truth per frame.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "live_deformation.h"

namespace {

using mrsns::gui::DeformationSample;
using mrsns::gui::LiveDeformation;
using mrsns::gui::LiveDeformationOptions;

std::vector<DeformationSample> runBatches(LiveDeformation& live, int batches) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!live.ready() && live.failure().empty() && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  for (int b = 0; b < batches; ++b) live.onBatch(0.01 * b);
  return live.takeSamples();
}

TEST(LiveDeformation, OneSamplePerFrameFromThePriorAndTheSweepRepeats) {
  LiveDeformationOptions options;
  options.frames = 30;
  options.batches_per_frame = 2;
  LiveDeformation live(options);
  // Prior + 30 frames, then the prior of the next sweep.
  const auto samples = runBatches(live, 2 * 32);
  ASSERT_TRUE(live.failure().empty()) << live.failure();
  ASSERT_EQ(samples.size(), 32u);
  for (std::size_t i = 0; i < 31; ++i) EXPECT_EQ(samples[i].frame, static_cast<int>(i) - 1);
  EXPECT_EQ(samples[31].frame, -1);
  // A repeat starts from the model mean again: the same prior error exactly.
  EXPECT_EQ(samples[31].error_mm, samples[0].error_mm);
  EXPECT_DOUBLE_EQ(samples[1].time_s, 0.02);
}

TEST(LiveDeformation, AFullSweepEndsCloserToTheTruthThanThePrior) {
  // The simulated protocol of paper 001 III.A (stretch 2 mm RMS per axis,
  // calibration error 1.2 mm + 1 deg, tracking noise 0.35 mm) with the true
  // cut as contours: along the common carotid alone the posterior drifts
  // (the calibration error is fitted too), once both branches are seen it
  // must end below the prior's error (Table I: posterior about half the
  // prior; here 0.63, 0.83, 0.58 of it for seeds 1-3).
  double ratio_sum = 0.0;
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    LiveDeformationOptions options;
    options.seed = seed;
    options.frames = 60;
    options.batches_per_frame = 1;
    LiveDeformation live(options);
    const auto samples = runBatches(live, 61);
    ASSERT_TRUE(live.failure().empty()) << live.failure();
    ASSERT_EQ(samples.size(), 61u);
    const double prior = samples.front().error_mm;
    const double last = samples.back().error_mm;
    EXPECT_GT(prior, 0.5) << "seed " << seed << ": the truth is a stretched shape, not the mean";
    EXPECT_LT(last, prior) << "seed " << seed << ": prior " << prior << " mm, after the sweep " << last;
    ratio_sum += last / prior;
  }
  EXPECT_LT(ratio_sum / 3.0, 0.8);
}

}  // namespace
