// N-wire segmentation on the real PLUS fCal recordings, against the points
// PLUS segmented in the same frames (its results file keeps them for both
// sequences). The filtering is PLUS's, so the dots must agree to PLUS's
// printed precision (6 significant digits: 0.001-0.005 px here), every frame
// PLUS segmented must be segmented, with the same labels.
#include <gtest/gtest.h>

#include <map>

#include "mrsns/core/log.h"
#include "mrsns/io/device_set.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/ultrasound/nwire_segmentation.h"
#include "plus_reference.h"
#include "test_data.h"

namespace mrsns::ultrasound {
namespace {

struct Agreement {
  std::size_t frames = 0, plus_segmented = 0, ours = 0, both = 0, only_plus = 0, only_ours = 0;
  double mean_px = 0.0, worst_px = 0.0;
};

Agreement compare(const io::DeviceSetConfiguration& config, const TrackedSequence& sequence,
                  const std::map<int, std::vector<Eigen::Vector2d>>& plus_points) {
  const auto options = segmentationOptionsFrom(*config.segmentation);
  const int w = static_cast<int>(sequence.geometry.size[0]), h = static_cast<int>(sequence.geometry.size[1]);
  Agreement a;
  a.frames = sequence.frames.size();
  a.plus_segmented = plus_points.size();
  double sum = 0.0;
  std::size_t points = 0;
  for (std::size_t f = 0; f < sequence.frames.size(); ++f) {
    const auto seg = segmentNWires({w, h, sequence.frames[f].pixels}, config.requirePhantom(), options);
    const auto it = plus_points.find(static_cast<int>(f));
    if (seg.ok()) ++a.ours;
    if (seg.ok() && it != plus_points.end()) {
      ++a.both;
      for (std::size_t i = 0; i < seg.wire_points_px.size() && i < it->second.size(); ++i) {
        const double d = (seg.wire_points_px[i] - it->second[i]).norm();
        a.worst_px = std::max(a.worst_px, d);
        sum += d;
        ++points;
      }
    } else if (it != plus_points.end()) {
      ++a.only_plus;
      logger()->warn("frame {}: {}", f, seg.reason);
    } else if (seg.ok()) {
      ++a.only_ours;
    }
  }
  a.mean_px = points ? sum / static_cast<double>(points) : 0.0;
  std::printf(
      "%zu frames, PLUS segmented %zu, we segmented %zu; both %zu, only PLUS %zu, only ours %zu; "
      "dot distance to PLUS's mean %.4f px, worst %.4f px\n",
      a.frames, a.plus_segmented, a.ours, a.both, a.only_plus, a.only_ours, a.mean_px, a.worst_px);
  return a;
}

#define MRSNS_REQUIRE_PLUS_SEGMENTATION_DATA()                                               \
  MRSNS_REQUIRE_DATA(config_path, "plus/PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml"); \
  MRSNS_REQUIRE_DATA(results_path, "plus/FreehandCalibration3NWires.results.xml")

TEST(NWireSegmentationReal, ValidationFramesMatchPlusPoints) {
  MRSNS_REQUIRE_PLUS_SEGMENTATION_DATA();
  MRSNS_REQUIRE_DATA(sequence_path, "plus/fCal_Test_Validation_3NWires.igs.mha");
  const auto reference = test::readPlusReference(results_path);
  const auto a = compare(io::readDeviceSet(config_path), io::readSequence(sequence_path), reference.validation_points);
  EXPECT_EQ(a.both, a.plus_segmented);
  EXPECT_EQ(a.only_ours, 0u);
  EXPECT_LT(a.mean_px, 0.01);
  EXPECT_LT(a.worst_px, 0.05);
}

TEST(NWireSegmentationReal, CalibrationFramesMatchPlusPoints) {
  MRSNS_REQUIRE_PLUS_SEGMENTATION_DATA();
  MRSNS_REQUIRE_DATA(sequence_path, "plus/fCal_Test_Calibration_3NWires.igs.mha");
  const auto reference = test::readPlusReference(results_path);
  if (reference.calibration_points.empty()) GTEST_SKIP() << "the results file keeps no calibration points";
  const auto a = compare(io::readDeviceSet(config_path), io::readSequence(sequence_path), reference.calibration_points);
  EXPECT_EQ(a.both, a.plus_segmented);
  EXPECT_EQ(a.only_ours, 0u);
  EXPECT_LT(a.mean_px, 0.01);
  EXPECT_LT(a.worst_px, 0.05);
}

}  // namespace
}  // namespace mrsns::ultrasound
