// The timed navigation step's real figures fill the output area's latency
// histogram and soft-tissue error plot (what a user sees after running the
// step from the function panel or the CLI and opening the session).
#include <gtest/gtest.h>

#include <numeric>

#include "gui_test_app.h"
#include "mrsns/workflow/session.h"
#include "mrsns/workflow/steps.h"
#include "output_panel.h"
#include "plot_widget.h"
#include "test_data.h"

TEST(NavigationStepPlots, TheStepsSeriesReachTheLatencyAndDeformationPlots) {
  mrsns::test::guiApp();
  auto session = mrsns::workflow::Session::create(mrsns::test::scratchDirectory("s") / "session");
  const auto result = mrsns::workflow::runStep(
      session, "navigation", {{"duration_s", 0.5}, {"deformation_cases", 1}, {"deformation_frames", 15}}, {});
  ASSERT_TRUE(result.ok) << result.summary;
  mrsns::gui::OutputPanel panel;
  EXPECT_TRUE(panel.latencyPlot()->histogramCounts().empty());
  EXPECT_EQ(panel.deformationPlot()->pointCount(), 0u);
  // As the main window does when a step finishes, with the figures the session recorded.
  const auto figures = session.step("navigation")["figures"];
  panel.showStepResult("navigation", "ok", figures);
  // Every batch's latency is counted in the histogram.
  const auto& counts = panel.latencyPlot()->histogramCounts();
  ASSERT_FALSE(counts.empty());
  EXPECT_EQ(std::accumulate(counts.begin(), counts.end(), 0), static_cast<int>(figures["loop_latency_ms"].size()));
  EXPECT_EQ(figures["loop_latency_ms"].size(), figures["batches"].get<std::size_t>());
  // The prior and one point per frame of the sweep.
  EXPECT_EQ(panel.deformationPlot()->pointCount(), 16u);
}
