// The trial's HTML page: per-sample series are summarised (their length and
// range) while report.json keeps them whole; short lists stay as they are.
#include <gtest/gtest.h>

#include "mrsns/workflow/trial.h"

namespace mrsns::workflow {
namespace {

TEST(TrialHtml, LongSeriesAreSummarisedShortListsKept) {
  nlohmann::json latency = nlohmann::json::array();
  for (int i = 0; i < 500; ++i) latency.push_back(0.5 + 0.001 * i);
  nlohmann::json report;
  report["paper"] = nlohmann::json::object();
  report["steps"]["navigation"]["figures"] = {
      {"loop_latency_ms", latency}, {"pixel_spacing_mm", {0.078, 0.074}}, {"nested", {{"series", latency}}}};
  const std::string html = renderTrialHtml(report);
  EXPECT_NE(html.find("500 values from 0.5 to 0.999"), std::string::npos);
  EXPECT_EQ(html.find("0.777"), std::string::npos) << "a value from the middle of the series is on the page";
  EXPECT_NE(html.find("0.078"), std::string::npos);
  std::size_t summaries = 0;
  for (auto at = html.find("values from"); at != std::string::npos; at = html.find("values from", at + 1)) ++summaries;
  EXPECT_EQ(summaries, 2u);
}

}  // namespace
}  // namespace mrsns::workflow
