// The patient's soft tissue deforming over time from a shape model: the echo
// scene's vessel follows the model's shape at each instant, and the truth file
// holds the trajectory.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "mrsns/core/error.h"
#include "mrsns/deformation/vessel_phantom.h"
#include "mrsns/io/statismo_io.h"
#include "mrsns/simulation/scenario.h"
#include "mrsns/simulation/soft_tissue.h"
#include "mrsns/simulation/world.h"
#include "test_data.h"
#include "translating_vessel.h"

namespace mrsns::simulation {
namespace {

using test::translatingVessel;

TEST(SoftTissue, TheVesselFollowsTheShapeModelOverTimeAndTheTruthHoldsItsTrajectory) {
  const auto dir = test::scratchDirectory("soft-tissue");
  const auto model = translatingVessel();
  io::writeStatismoModel(model, dir / "vessel.h5");
  const auto scenario = parseScenario(R"({"format": "mrsns-scenario/1",
      "tools": [{"name": "ReferenceToTracker", "start": {"translation_mm": [0, 0, -1400]}}],
      "patient": {"generated_phantom": {"spacing_mm": 2.0}, "reference_tool": "ReferenceToTracker",
                  "soft_tissue": {"shape_model": "vessel.h5", "model_to_ct": {"translation_mm": [-20, -25, -15]},
                                  "modes": 1, "amplitude_sd": 1.0, "period_s": 4.0}}})",
                                      dir);
  const World world(scenario);
  // The same trajectory, recomputed from the same seed: what the truth file describes.
  const DeformingSoftTissue tissue(io::readStatismoModel(dir / "vessel.h5"), *scenario.patient->soft_tissue,
                                   scenario.seed);
  // The centre of the vessel's first ring (the common carotid's end), model frame.
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  const int ring = deformation::VesselPhantomOptions{}.ring_vertices;
  for (int i = 0; i < ring; ++i) centre += model.reference.vertices.row(i).transpose();
  centre /= ring;
  centre.z() += 5.0;  // a little inside the tube, away from its open end
  int inside_moved = 0, outside_fixed = 0, samples = 0;
  for (double t = 0.0; t < 4.0; t += 0.25) {
    const double shift = 5.0 * tissue.coefficients(t)[0];
    const auto scene = world.echoScene(t);
    ASSERT_TRUE(scene.vessel_distance_mm);
    const Eigen::Isometry3d tracker_T_model = world.trackerTCt(t) * scenario.patient->soft_tissue->ct_T_model;
    // The surface is rebuilt every 0.1 s: query at the shape of the bucket's start.
    const double bucket_shift = 5.0 * tissue.coefficients(std::floor(t / 0.1) * 0.1)[0];
    const double moved = scene.vessel_distance_mm(tracker_T_model * (centre + Eigen::Vector3d(bucket_shift, 0, 0)));
    EXPECT_LT(moved, -3.0) << "t " << t << ": the moved centre is inside the lumen (radius 3.5 mm)";
    inside_moved += moved < 0.0;
    if (std::abs(shift) > 4.0) {
      // Displaced by more than the radius: the rest position is outside now.
      EXPECT_GT(scene.vessel_distance_mm(tracker_T_model * centre), 0.0) << "t " << t;
      ++outside_fixed;
    }
    ++samples;
  }
  EXPECT_EQ(inside_moved, samples);
  EXPECT_GT(outside_fixed, 2) << "the vessel swings 5 mm, more than its radius";
  const auto truth = nlohmann::json::parse(world.staticTruthJson());
  ASSERT_TRUE(truth.contains("soft_tissue"));
  EXPECT_EQ(truth["soft_tissue"]["phase"].size(), 1u);
  EXPECT_DOUBLE_EQ(truth["soft_tissue"]["period_s"].get<double>(), 4.0);
}

TEST(SoftTissue, MoreModesThanTheModelHasAreRefused) {
  const auto dir = test::scratchDirectory("soft-tissue-modes");
  io::writeStatismoModel(translatingVessel(), dir / "vessel.h5");
  const auto scenario = parseScenario(R"({"format": "mrsns-scenario/1",
      "tools": [{"name": "ReferenceToTracker"}],
      "patient": {"generated_phantom": {"spacing_mm": 2.0}, "soft_tissue": {"shape_model": "vessel.h5", "modes": 4}}})",
                                      dir);
  try {
    const World world(scenario);
    FAIL() << "4 modes of a 1-mode model must be refused";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("has 1 modes"), std::string::npos) << e.what();
  }
}

TEST(SoftTissue, TheStatismoModelOfTheSharedDataDeforms) {
  MRSNS_REQUIRE_DATA(path, "ssm/scalismo/model.h5");
  SoftTissueSpec spec;
  spec.shape_model = path;
  spec.modes = 5;
  spec.amplitude_sd = 2.0;
  spec.period_s = 10.0;
  const DeformingSoftTissue tissue(io::readStatismoModel(path), spec, 7);
  const Eigen::MatrixXd a = tissue.verticesAt(1.0), b = tissue.verticesAt(3.5);
  EXPECT_GT((a - b).rowwise().norm().maxCoeff(), 0.5) << "the shape changes over seconds";
  EXPECT_NE(tissue.surfaceAt(1.0), nullptr);
  EXPECT_EQ(tissue.surfaceAt(1.0), tissue.surfaceAt(1.05)) << "one surface per 0.1 s";
}

}  // namespace
}  // namespace mrsns::simulation
