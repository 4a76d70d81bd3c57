// N-wire segmentation on the real PLUS fCal recording, against the points
// PLUS segmented in the same validation frames.
#include <gtest/gtest.h>

#include "mrsns/core/log.h"
#include "mrsns/io/device_set.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/ultrasound/nwire_segmentation.h"
#include "plus_reference.h"
#include "test_data.h"

namespace mrsns::ultrasound {
namespace {

TEST(NWireSegmentationReal, ValidationFramesMatchPlusPoints) {
  MRSNS_REQUIRE_DATA(config_path, "plus/PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml");
  MRSNS_REQUIRE_DATA(sequence_path, "plus/fCal_Test_Validation_3NWires.igs.mha");
  MRSNS_REQUIRE_DATA(results_path, "plus/FreehandCalibration3NWires.results.xml");
  const auto config = io::readDeviceSet(config_path);
  const auto options = segmentationOptionsFrom(*config.segmentation);
  const auto reference = test::readPlusReference(results_path);
  auto sequence = io::readSequence(sequence_path);
  const int w = static_cast<int>(sequence.geometry.size[0]), h = static_cast<int>(sequence.geometry.size[1]);

  int ours = 0, both = 0, only_plus = 0, only_ours = 0, mislabelled = 0;
  double sum = 0.0, worst = 0.0;
  std::size_t points = 0;
  for (std::size_t f = 0; f < sequence.frames.size(); ++f) {
    const auto seg = segmentNWires({w, h, sequence.frames[f].pixels}, config.requirePhantom(), options);
    const auto it = reference.validation_points.find(static_cast<int>(f));
    if (seg.ok()) ++ours;
    if (seg.ok() && it != reference.validation_points.end()) {
      ++both;
      double frame_worst = 0.0;
      for (std::size_t i = 0; i < 9; ++i) {
        const double d = (seg.wire_points_px[i] - it->second[i]).norm();
        frame_worst = std::max(frame_worst, d);
        sum += d;
        ++points;
      }
      if (frame_worst > 10.0) ++mislabelled;
      worst = std::max(worst, frame_worst);
    } else if (it != reference.validation_points.end()) {
      ++only_plus;
      logger()->warn("frame {}: {}", f, seg.reason);
    } else if (seg.ok()) {
      ++only_ours;
    }
  }
  const double mean = points ? sum / static_cast<double>(points) : 0.0;
  std::printf(
      "validation frames %zu, PLUS segmented %zu, we segmented %d; both %d, only PLUS %d, only ours %d; "
      "mean point distance %.3f px, worst %.3f px, frames with a point > 10 px off %d\n",
      sequence.frames.size(), reference.validation_points.size(), ours, both, only_plus, only_ours, mean, worst,
      mislabelled);
  EXPECT_GE(both, static_cast<int>(reference.validation_points.size()) * 9 / 10);
  EXPECT_LT(mean, 1.0);
  EXPECT_EQ(mislabelled, 0);
}

}  // namespace
}  // namespace mrsns::ultrasound
