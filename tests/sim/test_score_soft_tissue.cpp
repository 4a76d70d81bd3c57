// mrsns-sim score on the navigation's live soft tissue (synthetic ground truth): a session whose soft-tissue
// file holds the room's own coefficients scores E^SD = E^FP = 0; coefficients 0.2 SD off along a mode that
// translates the whole vessel by 5 mm per SD score E^FP = 1 mm exactly (every vertex 1 mm away) and E^SD at
// most that; the prior's error is the vessel's own swing. A step not from the room, or a scenario without
// deforming tissue, is listed as not scored.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "mrsns/io/statismo_io.h"
#include "mrsns/simulation/score.h"
#include "mrsns/simulation/soft_tissue.h"
#include "test_data.h"
#include "translating_vessel.h"

namespace mrsns::simulation {
namespace {

using Json = nlohmann::json;

using test::translatingVessel;  // 1 SD = 5 mm along x

struct Case {
  std::filesystem::path session, truth;
};

// A session whose navigation (from the room, or not) wrote posterior coefficients = truth + offset_sd at
// 50 frames over 10 s, and the room's truth file.
Case makeCase(const std::string& name, double offset_sd, bool from_room, bool room_has_tissue) {
  Case c;
  const auto dir = test::scratchDirectory(name);
  c.session = dir / "session";
  std::filesystem::create_directories(c.session / "shape_model");
  std::filesystem::create_directories(c.session / "navigation");
  io::writeStatismoModel(translatingVessel(), c.session / "shape_model" / "vessel.h5");
  io::writeStatismoModel(translatingVessel(), dir / "room_vessel.h5");

  SoftTissueSpec spec;
  spec.shape_model = dir / "room_vessel.h5";
  spec.ct_T_model.translation() = Eigen::Vector3d(-20.0, -25.0, -15.0);
  spec.modes = 1;
  spec.amplitude_sd = 1.0;
  spec.period_s = 8.0;
  const std::uint64_t seed = 7;
  const DeformingSoftTissue room(translatingVessel(), spec, seed);
  const double utc0 = 1.7e9;

  Json updates = Json::array();
  for (int k = 0; k < 50; ++k) {
    const double t = 0.2 * k;
    updates.push_back({{"timestamp", utc0 + t},
                       {"coefficients", {room.coefficients(t)[0] + offset_sd}},
                       {"observations", 100},
                       {"contours", 1}});
  }
  Json ct_T_model = Json::array();
  for (int r = 0; r < 4; ++r) {
    for (int col = 0; col < 4; ++col) ct_T_model.push_back(spec.ct_T_model.matrix()(r, col));
  }
  std::ofstream(c.session / "navigation" / "live_soft_tissue.json")
      << Json{{"format", "mrsns-soft-tissue/1"},
              {"shape_model", "shape_model/vessel.h5"},
              {"ct_T_model", ct_T_model},
              {"updates", updates}}
             .dump();
  std::ofstream(c.session / "session.json")
      << Json{{"steps",
               {{"navigation",
                 {{"status", "ok"},
                  {"figures",
                   {{"simulated", from_room},
                    {"device_identity", from_room ? "mrsns-sim" : ""},
                    {"soft_tissue", {{"file", "navigation/live_soft_tissue.json"}}}}}}}}}}
             .dump();
  Json truth_static = {{"seed", seed}, {"scenario", "synthetic"}};
  if (room_has_tissue) truth_static["soft_tissue"] = Json::parse(room.truthJson());
  c.truth = dir / "truth.json";
  std::ofstream(c.truth) << Json{{"format", "mrsns-truth/1"}, {"static", truth_static}, {"utc_start", utc0}}.dump();
  return c;
}

Json score(const Case& c) {
  return Json::parse(scoreSession(c.session, c.truth));
}

TEST(ScoreSoftTissue, ThePosteriorOnTheTruthScoresZero) {
  const Json s = score(makeCase("score-soft-tissue-exact", 0.0, true, true));
  ASSERT_TRUE(s["scored"].contains("navigation_soft_tissue")) << s.dump(2);
  const Json& t = s["scored"]["navigation_soft_tissue"];
  EXPECT_EQ(t["updates_scored"].get<int>(), 50);
  EXPECT_LT(t["posterior_sd_mean_mm"].get<double>(), 1e-6);
  EXPECT_LT(t["posterior_fp_mm"].get<double>(), 1e-6);
  // The prior (the mean shape) misses the swing: 5 mm x |sin| averages about 3 mm over whole swings.
  EXPECT_GT(t["prior_fp_mm"].get<double>(), 1.5);
  EXPECT_GT(t["prior_sd_mean_mm"].get<double>(), 0.5);
}

TEST(ScoreSoftTissue, APosteriorOffByATranslationScoresThatTranslation) {
  const Json s = score(makeCase("score-soft-tissue-offset", 0.2, true, true));
  const Json& t = s["scored"]["navigation_soft_tissue"];
  // 0.2 SD x 5 mm: every vertex 1 mm off along x.
  EXPECT_NEAR(t["posterior_fp_mm"].get<double>(), 1.0, 1e-9);
  // The surface distance of a 1 mm sideways shift of a tube: at most 1 mm, and well above 0.
  EXPECT_LE(t["posterior_sd_mean_mm"].get<double>(), 1.0 + 1e-9);
  EXPECT_GT(t["posterior_sd_mean_mm"].get<double>(), 0.3);
}

TEST(ScoreSoftTissue, AStepNotFromTheRoomOrARoomWithoutTissueIsNotScored) {
  for (const auto& [from_room, tissue] : {std::pair{false, true}, std::pair{true, false}}) {
    const Json s = score(makeCase("score-soft-tissue-none", 0.0, from_room, tissue));
    EXPECT_FALSE(s["scored"].contains("navigation_soft_tissue"));
    bool listed = false;
    for (const auto& n : s["not_scored"]) listed |= n.get<std::string>().find("navigation soft tissue") == 0;
    EXPECT_TRUE(listed) << s["not_scored"].dump();
  }
}

}  // namespace
}  // namespace mrsns::simulation
