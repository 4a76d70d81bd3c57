// The B-mode renderer judged by the algorithms that consume its frames: the
// N-wire segmentation and spatial calibration recover the known
// ImageToProbe, the lumen segmentation finds the vessel, the bone casts its
// shadow; and frames are reproducible.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <random>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/deformation/bmode.h"
#include "mrsns/io/device_set.h"
#include "mrsns/simulation/bmode_renderer.h"
#include "mrsns/ultrasound/probe_calibration.h"
#include "test_bmode_scenes.h"
#include "test_data.h"

namespace mrsns::simulation {
namespace {

// ---------------------------------------------------------------- N-wire

constexpr int kFcalWidth = 820, kFcalHeight = 616;
const Eigen::Vector2d kFcalSpacing(0.080, 0.074);

struct NWireSweep {
  TrackedSequence sequence;
  Eigen::Isometry3d probe_T_image = Eigen::Isometry3d::Identity();  ///< rigid part of the truth
  Eigen::Isometry3d reference_T_phantom = Eigen::Isometry3d::Identity();
};

// A hand sweep over the phantom (tilts about the plane's own axes, shifts),
// as tests/ultrasound/test_calibration_synthetic.cpp makeSequence, each
// frame rendered by renderBModeFrame and tracked with the true probe pose.
NWireSweep renderSweep(const io::PhantomDefinition& phantom, int frames, unsigned seed) {
  NWireSweep s;
  s.probe_T_image.linear() = so3Exp(Eigen::Vector3d(0.1, -1.5, 0.05));
  s.probe_T_image.translation() = Eigen::Vector3d(11.0, 46.0, -7.0);
  s.reference_T_phantom.linear() = so3Exp(Eigen::Vector3d(0.3, 2.0, -0.4));
  s.reference_T_phantom.translation() = Eigen::Vector3d(9.6, 36.0, 87.9);
  s.sequence.geometry.size = {kFcalWidth, kFcalHeight, 1};
  s.sequence.geometry.spacing = {kFcalSpacing.x(), kFcalSpacing.y(), 1.0};
  s.sequence.orientation = "MF";
  const EchoScene scene = test::nwireScene(phantom);
  const BModeGeometry geometry{kFcalWidth, kFcalHeight, kFcalSpacing.x(), kFcalSpacing.y()};
  const BModeNoiseModel noise;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  for (int i = 0; i < frames; ++i) {
    Eigen::Isometry3d phantom_T_image = test::nominalPlane(20.0 + 10.0 * uni(rng));
    const Eigen::Vector3d tilt(0.12 * uni(rng), 0.08 * uni(rng), 0.05 * uni(rng));
    phantom_T_image.linear() = phantom_T_image.linear() * so3Exp(tilt);
    phantom_T_image.translation() += Eigen::Vector3d(2.0 * uni(rng), 0.0, 1.5 * uni(rng));
    const Eigen::Isometry3d reference_T_probe = s.reference_T_phantom * phantom_T_image * s.probe_T_image.inverse();
    TrackedFrame frame;
    frame.timestamp = 0.1 * i;
    frame.pixels = renderBModeFrame(scene, phantom_T_image, geometry, noise, 1000u + static_cast<unsigned>(i));
    frame.transforms["ProbeToReference"] = FrameTransform{reference_T_probe.matrix(), TransformStatus::Ok};
    s.sequence.frames.push_back(std::move(frame));
  }
  return s;
}

TEST(BModeRenderer, NWireSweepCalibratesToTheKnownImageToProbe) {
  MRSNS_REQUIRE_DATA(config_path, "plus/PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml");
  const io::DeviceSetConfiguration config = io::readDeviceSet(config_path);
  const io::PhantomDefinition& phantom = config.requirePhantom();
  ASSERT_TRUE(config.segmentation.has_value());
  const auto options = ultrasound::segmentationOptionsFrom(*config.segmentation);
  const auto patterns = ultrasound::nwireGeometry(phantom);

  constexpr int kFrames = 40;
  const auto started = std::chrono::steady_clock::now();
  const NWireSweep sweep = renderSweep(phantom, kFrames, 11);
  const double render_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count() / kFrames;
  const auto segmented = ultrasound::segmentCalibrationSequence(sweep.sequence, phantom, options);
  const auto result = ultrasound::calibrateSpatial(segmented.frames, patterns, sweep.reference_T_phantom);

  const Eigen::Matrix4d truth =
      ultrasound::imageToProbeMatrix(sweep.probe_T_image.linear(), sweep.probe_T_image.translation(), kFcalSpacing);
  double worst_corner_mm = 0.0;
  for (const auto& [u, v] : {std::pair{0.0, 0.0},
                             {kFcalWidth - 1.0, 0.0},
                             {0.0, kFcalHeight - 1.0},
                             {kFcalWidth - 1.0, kFcalHeight - 1.0}}) {
    const Eigen::Vector4d p(u, v, 0.0, 1.0);
    worst_corner_mm = std::max(worst_corner_mm, (result.probe_T_image * p - truth * p).head<3>().norm());
  }
  std::printf(
      "bmode N-wire: %zu/%d frames segmented (%.1f ms/frame to render 820x616), corners within %.3f mm of the "
      "truth, spacing %.5f %.5f mm/px, 3D reprojection %.3f mm\n",
      segmented.frames.size(), kFrames, render_ms, worst_corner_mm, result.pixel_spacing_mm.x(),
      result.pixel_spacing_mm.y(), result.calibration.reprojection_3d_mean_mm);

  // (a) Every wire is a clean dot in water: nearly every frame must segment
  // (the sweep keeps all nine crossings inside the clip rectangle).
  EXPECT_GE(segmented.frames.size(), static_cast<std::size_t>(kFrames * 95 / 100));
  // (b) Tolerance. The dot is the PSF (sigma 0.35 x 0.2 mm widened by the
  // wire's section: ~4.6 x 3.2 px) of peak A = 220 grey levels over water
  // speckle and electronic noise of sigma_n ~ 2.6 levels. The Cramer-Rao
  // bound of a Gaussian spot's position, sigma_n / A * sqrt(2 sigma_x /
  // (pi sigma_y)) px ~ 0.013 px, is negligible: the dot error is set by
  // the segmentation (10 % threshold and morphological opening on 8-bit
  // pixels), ~0.1-0.2 px = 0.015 mm on the ultrasound tests' synthetic
  // frames. The N ratio turns it into ~40 mm * 0.015 / 25 = 0.024 mm along
  // the middle wire; with 40 frames x 9 dots the fitted plane's rotation is
  // good to ~1 mrad, i.e. ~0.05 mm at the corners ~45 mm from the wires.
  // Hence 0.25 mm (5x), sub-millimetre. A uniform shift of every dot is
  // indistinguishable from an ImageToProbe translation here:
  // WireDotIsCentredOnTheCrossing checks the dot's absolute position.
  EXPECT_LT(worst_corner_mm, 0.25);
  EXPECT_NEAR(result.pixel_spacing_mm.x(), kFcalSpacing.x(), 0.0008);
  EXPECT_NEAR(result.pixel_spacing_mm.y(), kFcalSpacing.y(), 0.0008);
  EXPECT_LT(result.calibration.reprojection_3d_mean_mm, 0.2);
}

TEST(BModeRenderer, WireDotIsCentredOnTheCrossing) {
  EchoScene scene;
  scene.water_bath = EchoBox{};
  const Eigen::Vector2d crossing_mm(12.34, 7.71);
  // Oblique wire (45 deg to the plane) through the crossing.
  scene.wires.push_back({Eigen::Vector3d(crossing_mm.x() - 5.0, crossing_mm.y(), -5.0),
                         Eigen::Vector3d(crossing_mm.x() + 5.0, crossing_mm.y(), 5.0), 0.25});
  const BModeGeometry geometry{256, 160, 0.1, 0.08};
  const auto pixels = renderBModeFrame(scene, Eigen::Isometry3d::Identity(), geometry, BModeNoiseModel{}, 3);
  Eigen::Vector2d weighted = Eigen::Vector2d::Zero();
  double total = 0.0;
  for (int r = 0; r < geometry.height; ++r) {
    for (int c = 0; c < geometry.width; ++c) {
      const double v = pixels[static_cast<std::size_t>(r * geometry.width + c)];
      if (v < 40.0) continue;  // the dot only, not the water's noise
      weighted += v * Eigen::Vector2d(c * geometry.spacing_x_mm, r * geometry.spacing_y_mm);
      total += v;
    }
  }
  ASSERT_GT(total, 0.0) << "no wire dot";
  const Eigen::Vector2d centroid_mm = weighted / total;
  std::printf("bmode wire dot: centroid %.3f mm from the crossing\n", (centroid_mm - crossing_mm).norm());
  // Clipping the symmetric dot at 40 levels keeps its centroid: within 0.02 mm.
  EXPECT_LT((centroid_mm - crossing_mm).norm(), 0.02);
}

// ---------------------------------------------------------------- vessel

// The frame as the lumen segmentation takes it, speckle-reduced by a box
// mean over (2 half + 1)^2 pixels as a B-mode pipeline does before edge
// finding: fully developed speckle (contrast 0.52) otherwise stops the
// segmentation's rays at dark grains in the tissue.
deformation::BModeImage toFloatImage(const std::vector<std::uint8_t>& pixels, const BModeGeometry& geometry, int half) {
  deformation::BModeImage image;
  image.width = geometry.width;
  image.height = geometry.height;
  image.spacing_mm = geometry.spacing_x_mm;
  image.pixels.assign(pixels.size(), 0.0f);
  const int w = geometry.width, h = geometry.height;
  for (int r = 0; r < h; ++r) {
    for (int c = 0; c < w; ++c) {
      float sum = 0.0f;
      int n = 0;
      for (int dr = std::max(0, r - half); dr <= std::min(h - 1, r + half); ++dr) {
        for (int dc = std::max(0, c - half); dc <= std::min(w - 1, c + half); ++dc, ++n)
          sum += pixels[static_cast<std::size_t>(dr * w + dc)];
      }
      image.pixels[static_cast<std::size_t>(r * w + c)] = sum / static_cast<float>(n);
    }
  }
  return image;
}

Polyline3d circle(const Eigen::Vector2d& centre, double radius, int points) {
  Polyline3d p;
  p.closed = true;
  for (int k = 0; k < points; ++k) {
    const double a = 2.0 * 3.14159265358979323846 * k / points;
    p.points.emplace_back(centre.x() + radius * std::cos(a), centre.y() + radius * std::sin(a), 0.0);
  }
  return p;
}

TEST(BModeRenderer, VesselLumenIsFoundWhereTheTubeCrossesThePlane) {
  const BModeGeometry geometry{400, 300, 0.1, 0.1};
  constexpr double kRadius = 3.0;
  double worst_centre = 0.0, worst_radius = 0.0, mean_radius_error = 0.0;
  constexpr int kFrames = 8;
  for (int k = 0; k < kFrames; ++k) {
    // The tube runs along the scene z axis, across the image plane z = 0,
    // at a different place in each frame.
    const Eigen::Vector2d centre(11.0 + 2.6 * k, 9.0 + 1.7 * k);
    EchoScene scene;
    scene.vessel_distance_mm =
        test::tubeDistance(Eigen::Vector3d(centre.x(), centre.y(), 0.0), Eigen::Vector3d::UnitZ(), kRadius);
    const auto pixels = renderBModeFrame(scene, Eigen::Isometry3d::Identity(), geometry, BModeNoiseModel{},
                                         50u + static_cast<unsigned>(k));
    const auto image = toFloatImage(pixels, geometry, 2);
    // The seed: the model's prediction, off by 0.7 mm and 20 % in size.
    const std::vector<Polyline3d> seeds{circle(centre + Eigen::Vector2d(0.5, -0.5), 1.2 * kRadius, 32)};
    const auto lumens = deformation::segmentLumens(image, seeds);
    ASSERT_EQ(lumens.size(), 1u);
    ASSERT_TRUE(lumens[0].ok) << "frame " << k << ": " << lumens[0].status;
    worst_centre = std::max(worst_centre, (lumens[0].center - centre).norm());
    const double radius = 0.5 * (lumens[0].semi_major_mm + lumens[0].semi_minor_mm);
    worst_radius = std::max(worst_radius, std::abs(radius - kRadius));
    mean_radius_error += (radius - kRadius) / kFrames;
    std::printf("  frame %d: centre off %.3f mm, radius %+.3f mm (semi-axes %.3f %.3f), fit rms %.3f\n", k,
                (lumens[0].center - centre).norm(), radius - kRadius, lumens[0].semi_major_mm, lumens[0].semi_minor_mm,
                lumens[0].fit_rms_mm);
  }
  std::printf("bmode vessel: lumen centre within %.3f mm, radius within %.3f mm of the tube's (mean %+.3f mm)\n",
              worst_centre, worst_radius, mean_radius_error);
  // The lumen edge is blurred over +-2 PSF sigmas (~0.5 mm) and the
  // segmentation walks rays in 0.1 mm steps through the remaining speckle,
  // 48 rays averaged by the ellipse fit: 2 px (0.2 mm) for the centre,
  // 0.3 mm for the radius of any frame. The renderer places the edge at the
  // true radius (the blur is symmetric about it), so over the frames the
  // radius is unbiased to the segmentation's half-step and rise rule: 0.15 mm.
  EXPECT_LT(worst_centre, 0.2);
  EXPECT_LT(worst_radius, 0.3);
  EXPECT_LT(std::abs(mean_radius_error), 0.15);
}

// ---------------------------------------------------------------- bone

double meanOf(const std::vector<std::uint8_t>& pixels, int width, int c0, int c1, int r0, int r1) {
  double sum = 0.0;
  for (int r = r0; r <= r1; ++r) {
    for (int c = c0; c <= c1; ++c) sum += pixels[static_cast<std::size_t>(r * width + c)];
  }
  return sum / ((c1 - c0 + 1.0) * (r1 - r0 + 1.0));
}

TEST(BModeRenderer, BoneSurfaceIsBrightAndShadowsTheBeamsBehindIt) {
  const BModeGeometry geometry{400, 400, 0.1, 0.1};
  constexpr double kDepth = 20.0, kEdge = 25.0;  // bone beyond 20 mm, for x < 25 mm
  EchoScene scene;
  scene.bone_distance_mm = test::plateDistance(kDepth, kEdge);
  const BModeNoiseModel noise;
  const auto pixels = renderBModeFrame(scene, Eigen::Isometry3d::Identity(), geometry, noise, 7);
  const int w = geometry.width;
  // Beams crossing the bone (x < 23 mm) and beams missing it (x > 27 mm).
  const double shadow = meanOf(pixels, w, 0, 230, 215, 399);
  const double beside = meanOf(pixels, w, 270, 399, 215, 399);
  const double above = meanOf(pixels, w, 0, 230, 100, 180);
  double surface = 0.0;
  for (int c = 0; c <= 230; c += 10) {
    int brightest = 0;
    for (int r = 190; r <= 212; ++r) brightest = std::max<int>(brightest, pixels[static_cast<std::size_t>(r * w + c)]);
    surface += brightest / 24.0;
  }
  std::printf("bmode bone: surface peak %.1f, shadow mean %.1f, beside it %.1f, above it %.1f grey levels\n", surface,
              shadow, beside, above);
  // Surface: 230 attenuated by 2 dB at 20 mm (x 0.79) = 182.
  EXPECT_GT(surface, 140.0);
  // Shadow: 2 % of the tissue echo plus clipped electronic noise (mean ~0.8).
  EXPECT_LT(shadow, 4.0);
  // Tissue at 21.5-40 mm: 70 x 0.6-0.8 (attenuation), no shadow.
  EXPECT_GT(beside, 30.0);
  EXPECT_GT(above, 40.0);
}

// ---------------------------------------------------------------- determinism, refusals

EchoScene mixedScene() {
  EchoScene scene;
  scene.vessel_distance_mm = test::tubeDistance(Eigen::Vector3d(10, 8, 0), Eigen::Vector3d::UnitZ(), 2.0);
  scene.bone_distance_mm = test::plateDistance(15.0, 12.0);
  scene.wires.push_back({Eigen::Vector3d(15, 5, -3), Eigen::Vector3d(15, 5, 3), 0.25});
  return scene;
}

TEST(BModeRenderer, FramesAreDeterministicPerSeed) {
  const BModeGeometry geometry{200, 240, 0.1, 0.1};
  const auto scene = mixedScene();
  const auto a = renderBModeFrame(scene, Eigen::Isometry3d::Identity(), geometry, BModeNoiseModel{}, 42);
  const auto b = renderBModeFrame(scene, Eigen::Isometry3d::Identity(), geometry, BModeNoiseModel{}, 42);
  const auto c = renderBModeFrame(scene, Eigen::Isometry3d::Identity(), geometry, BModeNoiseModel{}, 43);
  ASSERT_EQ(a.size(), static_cast<std::size_t>(geometry.width * geometry.height));
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  std::size_t differing = 0;
  for (std::size_t i = 0; i < a.size(); ++i) differing += a[i] != c[i];
  EXPECT_GT(differing, a.size() / 2) << "another seed should give other speckle";
}

TEST(BModeRenderer, BadGeometryIsRefused) {
  const EchoScene scene = mixedScene();
  const BModeNoiseModel noise;
  const Eigen::Isometry3d plane = Eigen::Isometry3d::Identity();
  EXPECT_THROW((void)renderBModeFrame(scene, plane, {0, 100, 0.1, 0.1}, noise, 1), InvalidArgumentError);
  EXPECT_THROW((void)renderBModeFrame(scene, plane, {100, -5, 0.1, 0.1}, noise, 1), InvalidArgumentError);
  EXPECT_THROW((void)renderBModeFrame(scene, plane, {100, 100, 0.0, 0.1}, noise, 1), InvalidArgumentError);
  EXPECT_THROW((void)renderBModeFrame(scene, plane, {100, 100, 0.1, -0.1}, noise, 1), InvalidArgumentError);
  EXPECT_THROW((void)renderBModeFrame(scene, plane, {100, 100, std::nan(""), 0.1}, noise, 1), InvalidArgumentError);
  BModeNoiseModel no_psf;
  no_psf.axial_psf_mm = 0.0;
  EXPECT_THROW((void)renderBModeFrame(scene, plane, {100, 100, 0.1, 0.1}, no_psf, 1), InvalidArgumentError);
  // A 1 x 1 frame is odd but valid.
  EXPECT_EQ(renderBModeFrame(scene, plane, {1, 1, 0.1, 0.1}, noise, 1).size(), 1u);
}

}  // namespace
}  // namespace mrsns::simulation
