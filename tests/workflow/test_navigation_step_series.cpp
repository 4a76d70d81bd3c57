// The navigation step's per-batch and per-frame series (what the GUI's latency histogram and
// soft-tissue error plot draw after the step): present, aligned with their *_time_s, thinned to at most
// 2000 points.
#include <gtest/gtest.h>

#include "mrsns/workflow/session.h"
#include "mrsns/workflow/steps.h"
#include "test_data.h"

namespace mrsns::workflow {
namespace {

StepContext quietContext() {
  return StepContext{};
}

TEST(NavigationStepSeries, LatencyPerBatchAndSoftTissueErrorPerFrame) {
  auto session = Session::create(test::scratchDirectory("s") / "session");
  const auto result =
      runStep(session, "navigation", {{"duration_s", 0.6}, {"deformation_cases", 1}, {"deformation_frames", 20}},
              quietContext());
  ASSERT_TRUE(result.ok) << result.summary;
  const auto& f = result.figures;
  const auto batches = f["batches"].get<std::size_t>();
  ASSERT_GT(batches, 5u);
  ASSERT_TRUE(f["loop_latency_ms"].is_array());
  // Below 2000 batches every batch is kept.
  EXPECT_EQ(f["loop_latency_decimation"], 1);
  EXPECT_EQ(f["loop_latency_ms"].size(), batches);
  ASSERT_EQ(f["loop_latency_ms_time_s"].size(), f["loop_latency_ms"].size());
  double sum = 0.0;
  for (std::size_t i = 0; i < batches; ++i) {
    EXPECT_GE(f["loop_latency_ms"][i].get<double>(), 0.0);
    if (i > 0) {
      EXPECT_GE(f["loop_latency_ms_time_s"][i].get<double>(), f["loop_latency_ms_time_s"][i - 1].get<double>());
    }
    sum += f["loop_latency_ms"][i].get<double>();
  }
  EXPECT_NEAR(sum / static_cast<double>(batches), f["mean_loop_latency_ms"].get<double>(), 1e-6 * (1.0 + sum));

  const auto& d = f["deformation"];
  ASSERT_TRUE(d["error_mm"].is_array()) << d.dump();
  // The prior, then one value per frame of the 20-frame sweep.
  ASSERT_EQ(d["error_mm"].size(), 21u);
  ASSERT_EQ(d["error_mm_time_s"].size(), 21u);
  EXPECT_EQ(d["error_mm_time_s"][0].get<double>(), 0.0);
  EXPECT_GT(d["error_mm_time_s"][20].get<double>(), 0.0);
  // Paper 001 Table I: the posterior (after the sweep) is closer to the truth than the prior (the mean shape).
  EXPECT_LT(d["error_mm"][20].get<double>(), d["error_mm"][0].get<double>()) << d["error_mm"].dump();
  // Kept in the session as recorded.
  EXPECT_EQ(session.step("navigation")["figures"]["loop_latency_ms"].size(), batches);
}

TEST(NavigationStepSeries, ALongRunIsThinnedToAtMost2000Points) {
  auto session = Session::create(test::scratchDirectory("s") / "session");
  // 4 kHz for 1.5 s: ~6000 batches, > 2000 even if a loaded machine drops most ticks (a 60 Hz tracker gets
  // past 2000 in 34 s).
  const auto result = runStep(session, "navigation",
                              {{"duration_s", 1.5}, {"rate_hz", 4000.0}, {"deformation_cases", 0}}, quietContext());
  ASSERT_TRUE(result.ok) << result.summary;
  const auto& f = result.figures;
  const auto batches = f["batches"].get<std::size_t>();
  ASSERT_GT(batches, 2000u) << "the simulated tracker delivered too few batches here";
  const auto stride = f["loop_latency_decimation"].get<std::size_t>();
  EXPECT_GE(stride, 2u);
  EXPECT_LE(f["loop_latency_ms"].size(), 2000u);
  EXPECT_EQ(f["loop_latency_ms"].size(), (batches + stride - 1) / stride);
  EXPECT_EQ(f["loop_latency_ms_time_s"].size(), f["loop_latency_ms"].size());
  EXPECT_FALSE(f["deformation"].contains("error_mm"));
}

}  // namespace
}  // namespace mrsns::workflow
