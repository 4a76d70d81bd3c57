// Spatial calibration on frames rendered from a known ImageToProbe and
// phantom pose (wire dots blurred, speckle, a reverberation line), and the
// refusals on bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/io/device_set.h"
#include "mrsns/ultrasound/probe_calibration.h"
#include "synthetic_fcal.h"

namespace mrsns::ultrasound {
namespace {

using test::fcalPhantom;
using test::nominalPlane;
using test::Truth;

constexpr int kWidth = 820, kHeight = 616;

// Renders the frame whose image plane sits at phantom_T_image (rigid, mm);
// returns the pixels and the probe pose that goes with it.
std::pair<std::vector<std::uint8_t>, Eigen::Isometry3d> renderFrame(const Truth& truth,
                                                                    const std::vector<NWirePattern>& patterns,
                                                                    const Eigen::Isometry3d& phantom_T_image,
                                                                    std::mt19937& rng, bool with_wires = true) {
  std::normal_distribution<double> noise(0.0, 1.0);
  std::vector<double> image(static_cast<std::size_t>(kWidth * kHeight), 0.0);
  for (auto& v : image) v = 25.0 + 12.0 * std::abs(noise(rng));  // speckle
  // A reverberation: a long bright horizontal band, removed by the bar opening.
  for (int y = 540; y < 545; ++y) {
    for (int x = 60; x < 760; ++x) image[static_cast<std::size_t>(y * kWidth + x)] += 150.0;
  }
  const Eigen::Isometry3d image_T_phantom = phantom_T_image.inverse();
  for (const auto& p : patterns) {
    for (int w = 0; w < 3 && with_wires; ++w) {
      const Eigen::Vector3d a = image_T_phantom * p.front[w];
      const Eigen::Vector3d d = image_T_phantom.linear() * p.direction[w];
      const Eigen::Vector3d hit = a - d * (a.z() / d.z());
      const double u = hit.x() / truth.spacing.x(), v = hit.y() / truth.spacing.y();
      for (int y = static_cast<int>(v) - 12; y <= static_cast<int>(v) + 12; ++y) {
        for (int x = static_cast<int>(u) - 16; x <= static_cast<int>(u) + 16; ++x) {
          if (x < 0 || y < 0 || x >= kWidth || y >= kHeight) continue;
          // Wire blur: wider laterally than axially, as in B-mode.
          const double g = std::exp(-0.5 * (std::pow((x - u) / 4.0, 2) + std::pow((y - v) / 2.5, 2)));
          image[static_cast<std::size_t>(y * kWidth + x)] += 200.0 * g * (0.85 + 0.15 * noise(rng));
        }
      }
    }
  }
  std::vector<std::uint8_t> pixels(image.size());
  for (std::size_t i = 0; i < image.size(); ++i)
    pixels[i] = static_cast<std::uint8_t>(std::clamp(image[i], 0.0, 255.0));
  const Eigen::Isometry3d reference_T_probe =
      truth.reference_T_phantom * phantom_T_image * truth.probe_T_image_rigid.inverse();
  return {pixels, reference_T_probe};
}

struct Synthetic {
  Truth truth;
  io::PhantomDefinition phantom = fcalPhantom();
  std::vector<NWirePattern> patterns = nwireGeometry(phantom);
  TrackedSequence sequence;
};

Synthetic makeSequence(int frames, bool move, unsigned seed) {
  Synthetic s;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  s.truth.probe_T_image_rigid.linear() = so3Exp(Eigen::Vector3d(0.1, -1.5, 0.05));
  s.truth.probe_T_image_rigid.translation() = Eigen::Vector3d(11.0, 46.0, -7.0);
  s.truth.reference_T_phantom.linear() = so3Exp(Eigen::Vector3d(0.3, 2.0, -0.4));
  s.truth.reference_T_phantom.translation() = Eigen::Vector3d(9.6, 36.0, 87.9);
  s.sequence.geometry.size = {kWidth, kHeight, 1};
  s.sequence.orientation = "MF";
  for (int i = 0; i < frames; ++i) {
    Eigen::Isometry3d plane = nominalPlane(move ? 20.0 + 10.0 * uni(rng) : 20.0);
    if (move) {
      // Tilts about the plane's own axes and small shifts, as a hand sweep.
      const Eigen::Vector3d tilt(0.12 * uni(rng), 0.08 * uni(rng), 0.05 * uni(rng));
      plane.linear() = plane.linear() * so3Exp(tilt);
      plane.translation() += Eigen::Vector3d(2.0 * uni(rng), 0.0, 1.5 * uni(rng));
    }
    auto [pixels, pose] = renderFrame(s.truth, s.patterns, plane, rng);
    TrackedFrame f;
    f.timestamp = i * 0.1;
    f.pixels = std::move(pixels);
    f.transforms["ProbeToReference"] = FrameTransform{pose.matrix(), TransformStatus::Ok};
    s.sequence.frames.push_back(std::move(f));
  }
  return s;
}

TEST(SpatialCalibrationSynthetic, RecoversKnownImageToProbe) {
  const auto s = makeSequence(40, true, 11);
  NWireSegmentationOptions seg;
  seg.clip_x = 27;
  seg.clip_y = 27;
  seg.clip_width = 766;
  seg.clip_height = 562;
  const auto segmented = segmentCalibrationSequence(s.sequence, s.phantom, seg);
  EXPECT_GE(segmented.frames.size(), 36u);
  const auto r = calibrateSpatial(segmented.frames, s.patterns, s.truth.reference_T_phantom);
  const Eigen::Matrix4d truth = imageToProbeMatrix(s.truth.probe_T_image_rigid.linear(),
                                                   s.truth.probe_T_image_rigid.translation(), s.truth.spacing);
  double worst = 0.0;
  for (const auto& [u, v] : {std::pair{0.0, 0.0}, {819.0, 0.0}, {0.0, 615.0}, {819.0, 615.0}}) {
    const Eigen::Vector4d p(u, v, 0.0, 1.0);
    worst = std::max(worst, (r.probe_T_image * p - truth * p).head<3>().norm());
  }
  std::printf(
      "synthetic: %zu/%zu frames segmented, corners within %.3f mm of the truth, spacing %.5f %.5f, "
      "3D reprojection %.3f mm\n",
      segmented.frames.size(), s.sequence.frames.size(), worst, r.pixel_spacing_mm.x(), r.pixel_spacing_mm.y(),
      r.calibration.reprojection_3d_mean_mm);
  // Dot centroids are good to ~0.1-0.2 px (~0.015 mm) here; at the image
  // corners, 30 mm from the wires, a 0.5 mm bound leaves a wide margin for
  // the small tilt range of the sweep.
  EXPECT_LT(worst, 0.5);
  EXPECT_NEAR(r.pixel_spacing_mm.x(), 0.080, 0.0008);
  EXPECT_NEAR(r.pixel_spacing_mm.y(), 0.074, 0.0008);
  EXPECT_LT(r.calibration.reprojection_3d_mean_mm, 0.2);
}

TEST(SpatialCalibrationSynthetic, MiddleWirePointIsTheTrueCrossing) {
  const auto patterns = nwireGeometry(fcalPhantom());
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    Eigen::Isometry3d plane = nominalPlane(20.0 + 15.0 * uni(rng));
    plane.linear() = plane.linear() * so3Exp(Eigen::Vector3d(0.4 * uni(rng), 0.4 * uni(rng), 0.4 * uni(rng)));
    const Eigen::Isometry3d image_T_phantom = plane.inverse();
    for (const auto& p : patterns) {
      std::array<Eigen::Vector2d, 3> px;
      std::array<Eigen::Vector3d, 3> hits;
      for (int w = 0; w < 3; ++w) {
        const Eigen::Vector3d a = image_T_phantom * p.front[w];
        const Eigen::Vector3d d = image_T_phantom.linear() * p.direction[w];
        const Eigen::Vector3d hit = a - d * (a.z() / d.z());
        hits[w] = plane * hit;
        // Anisotropic pixels: the ratio along the line is preserved all the same.
        px[w] = Eigen::Vector2d(hit.x() / 0.08, hit.y() / 0.07);
      }
      EXPECT_LT((middleWirePoint(p, px[0], px[1], px[2]) - hits[1]).norm(), 1e-9);
    }
  }
}

TEST(SpatialCalibrationSynthetic, RefusesTooLittleMotion) {
  const auto s = makeSequence(12, false, 3);
  const auto segmented = segmentCalibrationSequence(s.sequence, s.phantom, {});
  ASSERT_GE(segmented.frames.size(), 10u);
  try {
    (void)calibrateSpatial(segmented.frames, s.patterns, s.truth.reference_T_phantom);
    FAIL() << "a static probe was accepted";
  } catch (const ComputationError& e) {
    EXPECT_NE(std::string(e.what()).find("too little probe motion"), std::string::npos) << e.what();
  }
}

TEST(SpatialCalibrationSynthetic, RefusesTooFewFrames) {
  const auto s = makeSequence(4, true, 4);
  const auto segmented = segmentCalibrationSequence(s.sequence, s.phantom, {});
  EXPECT_THROW((void)calibrateSpatial(segmented.frames, s.patterns, s.truth.reference_T_phantom), ComputationError);
}

TEST(SpatialCalibrationSynthetic, FramesWithoutWiresAreRejectedWithAReason) {
  Synthetic s;
  std::mt19937 rng(9);
  auto [pixels, pose] = renderFrame(s.truth, s.patterns, nominalPlane(20.0), rng, false);
  const auto seg = segmentNWires({kWidth, kHeight, pixels}, s.phantom, {});
  EXPECT_FALSE(seg.ok());
  EXPECT_FALSE(seg.reason.empty());
  std::printf("frame without wires: %s (%s)\n", segmentationStatusName(seg.status).c_str(), seg.reason.c_str());
  // A blank frame.
  std::vector<std::uint8_t> blank(static_cast<std::size_t>(kWidth * kHeight), 0);
  const auto empty = segmentNWires({kWidth, kHeight, blank}, s.phantom, {});
  EXPECT_EQ(empty.status, SegmentationStatus::NoCandidates);
  // A view whose size does not match its pixels.
  EXPECT_THROW((void)segmentNWires({kWidth, kHeight + 1, blank}, s.phantom, {}), InvalidArgumentError);
}

TEST(SpatialCalibrationSynthetic, SequenceWithoutProbeTransformIsRefused) {
  auto s = makeSequence(3, true, 5);
  for (auto& f : s.sequence.frames) {
    f.transforms.clear();
    f.transforms["StylusToTracker"] = FrameTransform{};
  }
  try {
    (void)segmentCalibrationSequence(s.sequence, s.phantom, {});
    FAIL() << "a sequence without ProbeToReference was accepted";
  } catch (const FrameError& e) {
    EXPECT_NE(std::string(e.what()).find("ProbeToReference"), std::string::npos) << e.what();
  }
}

TEST(SpatialCalibrationSynthetic, ConfigurationWithoutPhantomIsRefused) {
  io::DeviceSetConfiguration config;
  config.source = "no_phantom.xml";
  TrackedSequence empty;
  try {
    (void)calibrateProbe(config, empty, empty);
    FAIL() << "a configuration without phantom was accepted";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("no_phantom.xml"), std::string::npos) << e.what();
  }
  io::PhantomDefinition no_patterns;
  EXPECT_THROW((void)nwireGeometry(no_patterns), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::ultrasound
