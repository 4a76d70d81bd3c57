// Frames placed into a volume and a volume sampled on a frame: a round trip
// through a known smooth volume (synthetic ground truth), the fCal recording
// reconstructed with PLUS's calibration (the wires must show up where the
// phantom definition puts them), and the refusals.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mrsns/core/error.h"
#include "mrsns/core/frame_poses.h"
#include "mrsns/core/rigid.h"
#include "mrsns/io/device_set.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/ultrasound/probe_calibration.h"
#include "mrsns/ultrasound/volume_reconstruction.h"
#include "plus_reference.h"
#include "reference_reconstruction.h"
#include "test_data.h"

namespace mrsns::ultrasound {
namespace {

// A smooth volume (largest gradient ~ 80 / 6 = 13 grey levels per mm) on an
// oblique 1 mm grid.
ImageVolume smoothVolume() {
  ImageVolume v;
  v.size = {60, 50, 40};
  v.spacing = Eigen::Vector3d(1.0, 1.0, 1.0);
  v.origin = Eigen::Vector3d(-30, -20, 10);
  v.direction = so3Exp(Eigen::Vector3d(0.1, -0.2, 0.3));
  v.pixel_type = PixelType::UInt8;
  v.data.resize(v.byteCount());
  for (int k = 0; k < v.size[2]; ++k) {
    for (int j = 0; j < v.size[1]; ++j) {
      for (int i = 0; i < v.size[0]; ++i) {
        const double f = 120.0 + 80.0 * std::sin(i / 6.0) * std::cos(j / 8.0) + 1.0 * k;
        v.data[v.linearIndex(i, j, k)] = static_cast<std::byte>(static_cast<std::uint8_t>(std::lround(f)));
      }
    }
  }
  return v;
}

Eigen::Vector3d voxelCentre(const ImageVolume& v, int i, int j, int k) {
  return v.origin + v.direction * v.spacing.asDiagonal() * Eigen::Vector3d(i, j, k);
}

TEST(VolumeReconstruction, SweepThroughAKnownVolumeComesBack) {
  const ImageVolume truth = smoothVolume();
  // 0.25 mm pixels, planes 0.3 mm apart, tilted against the volume's axes.
  constexpr int kW = 120, kH = 100;
  std::vector<Eigen::Matrix4d> placements;
  std::vector<Eigen::Vector3d> corners;
  const Eigen::Vector3d centre = voxelCentre(truth, 30, 25, 20);
  const Eigen::Matrix3d R = truth.direction * so3Exp(Eigen::Vector3d(0.2, 0.1, 0.0));
  for (int s = 0; s < 40; ++s) {
    Eigen::Matrix4d lps_T_image = Eigen::Matrix4d::Identity();
    lps_T_image.block<3, 1>(0, 0) = R.col(0) * 0.25;
    lps_T_image.block<3, 1>(0, 1) = R.col(1) * 0.25;
    lps_T_image.block<3, 1>(0, 2) = R.col(2);
    lps_T_image.block<3, 1>(0, 3) = centre - R.col(0) * 15.0 - R.col(1) * 12.5 + R.col(2) * (-6.0 + 0.3 * s);
    placements.push_back(lps_T_image);
    for (const auto& [u, v] : {std::pair{0, 0}, {kW - 1, 0}, {0, kH - 1}, {kW - 1, kH - 1}}) {
      corners.push_back((lps_T_image * Eigen::Vector4d(u, v, 0, 1)).head<3>());
    }
  }
  const ImageVolume grid = gridAroundCorners(corners, 0.5, 1.0);
  VolumeReconstructor reconstructor(grid);
  for (const auto& p : placements) {
    const auto samples = sampleVolumeOnFrame(truth, p, kW, kH);
    std::vector<std::uint8_t> pixels(samples.size());
    for (std::size_t n = 0; n < samples.size(); ++n) pixels[n] = static_cast<std::uint8_t>(std::lround(samples[n]));
    reconstructor.addFrame({kW, kH, pixels}, p);
  }
  const ImageVolume out = reconstructor.result(1);
  EXPECT_EQ(reconstructor.figures().frames, 40u);
  EXPECT_EQ(reconstructor.figures().pixels_outside, 0u);
  // The sweep fills a slab; its voxels must hold the volume's values to
  // within the interpolation error: two trilinear steps over half-voxel
  // distances of a field changing ~13 grey levels/mm, plus rounding.
  double sum = 0.0, worst = 0.0;
  std::size_t count = 0;
  for (int k = 0; k < out.size[2]; ++k) {
    for (int j = 0; j < out.size[1]; ++j) {
      for (int i = 0; i < out.size[0]; ++i) {
        const double got = out.value(i, j, k);
        if (got == 0.0) continue;
        Eigen::Matrix4d at = Eigen::Matrix4d::Identity();
        at.block<3, 1>(0, 3) = voxelCentre(out, i, j, k);
        const double expected = sampleVolumeOnFrame(truth, at, 1, 1, -1.0f)[0];
        if (expected < 0.0) continue;
        const double e = std::abs(got - expected);
        sum += e;
        worst = std::max(worst, e);
        ++count;
      }
    }
  }
  ASSERT_GT(count, 10000u);
  EXPECT_LT(sum / static_cast<double>(count), 2.5);
  EXPECT_LT(worst, 20.0);
  EXPECT_GT(reconstructor.figures().filled_fraction, 0.3);
}

// The parallel splat against the one-pixel-at-a-time oracle, and against
// itself with other thread counts, on oblique frames of noise (every grey
// level, frames crossing each other and the grid's edge).
TEST(VolumeReconstruction, ParallelSplatMatchesTheStraightforwardOneAndIgnoresTheThreadCount) {
  ImageVolume grid;
  grid.size = {90, 80, 70};
  grid.spacing = Eigen::Vector3d::Constant(0.5);
  grid.origin = Eigen::Vector3d(-22, -20, -17);
  std::mt19937 rng(5);
  const int w = 300, h = 240;
  std::vector<std::uint8_t> pixels(static_cast<std::size_t>(w) * h);
  std::vector<std::vector<std::uint8_t>> frames;
  std::vector<Eigen::Matrix4d> poses;
  for (int f = 0; f < 12; ++f) {
    for (auto& p : pixels) p = static_cast<std::uint8_t>(rng() & 0xFF);
    frames.push_back(pixels);
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = so3Exp(Eigen::Vector3d(0.3 + 0.05 * f, -0.2, 0.1 * f)) * 0.15;  // 0.15 mm pixels
    m.topRightCorner<3, 1>() = Eigen::Vector3d(-20 + 0.7 * f, -18, -15 + 0.4 * f);
    poses.push_back(m);
  }
  test::ReferenceReconstructor oracle(grid);
  VolumeReconstructor one(grid, 1), two(grid, 2), three(grid, 3);
  for (std::size_t f = 0; f < frames.size(); ++f) {
    const GrayImageView view{w, h, frames[f]};
    const std::array<int, 4> clip = f % 3 == 0 ? std::array<int, 4>{10, 5, 250, 200} : std::array<int, 4>{};
    oracle.addFrame(view, poses[f], clip);
    for (auto* r : {&one, &two, &three}) r->addFrame(view, poses[f], clip);
  }
  const ImageVolume expected = oracle.result(1);
  const ImageVolume a = one.result(1), b = two.result(1), c = three.result(1);
  EXPECT_EQ(a.data, b.data);
  EXPECT_EQ(a.data, c.data);
  EXPECT_EQ(one.figures().pixels_inside, oracle.figures().pixels_inside);
  EXPECT_EQ(one.figures().pixels_outside, oracle.figures().pixels_outside);
  EXPECT_GT(one.figures().pixels_outside, 0u);
  // Same contributions, added in another order: float round-off (~1e-7 of a
  // sum) can move a voxel across a .5 boundary, nothing more.
  std::size_t differing = 0;
  int worst = 0;
  for (std::size_t n = 0; n < a.voxelCount(); ++n) {
    const int d = std::abs(static_cast<int>(a.data[n]) - static_cast<int>(expected.data[n]));
    worst = std::max(worst, d);
    differing += d != 0;
  }
  EXPECT_LE(worst, 1);
  EXPECT_LT(static_cast<double>(differing), 1e-4 * static_cast<double>(a.voxelCount()));
  EXPECT_NEAR(one.figures().filled_fraction, oracle.figures().filled_fraction, 1e-4);
}

TEST(VolumeReconstruction, SamplingAtVoxelCentresReturnsTheVoxels) {
  const ImageVolume v = smoothVolume();
  for (const auto& [i, j, k] : {std::array{0, 0, 0}, {59, 49, 39}, {17, 33, 5}}) {
    Eigen::Matrix4d at = Eigen::Matrix4d::Identity();
    at.block<3, 1>(0, 3) = voxelCentre(v, i, j, k);
    EXPECT_NEAR(sampleVolumeOnFrame(v, at, 1, 1)[0], v.value(i, j, k), 1e-9);
  }
  Eigen::Matrix4d far = Eigen::Matrix4d::Identity();
  far.block<3, 1>(0, 3) = Eigen::Vector3d(1000, 0, 0);
  EXPECT_EQ(sampleVolumeOnFrame(v, far, 1, 1, -7.0f)[0], -7.0f);
}

TEST(VolumeReconstruction, BadInputIsRefused) {
  EXPECT_THROW(gridAroundCorners({}, 0.5, 1.0), InvalidArgumentError);
  EXPECT_THROW(gridAroundCorners({Eigen::Vector3d::Zero()}, 0.0, 1.0), InvalidArgumentError);
  EXPECT_THROW(gridAroundCorners({Eigen::Vector3d::Zero(), Eigen::Vector3d(1000, 1000, 1000)}, 0.1, 0.0),
               InvalidArgumentError);
  const ImageVolume grid = gridAroundCorners({Eigen::Vector3d::Zero(), Eigen::Vector3d(10, 10, 10)}, 1.0, 0.0);
  VolumeReconstructor r(grid);
  const std::vector<std::uint8_t> few(10, 0);
  EXPECT_THROW(r.addFrame({20, 20, few}, Eigen::Matrix4d::Identity()), InvalidArgumentError);
  EXPECT_THROW(sampleVolumeOnFrame(ImageVolume{}, Eigen::Matrix4d::Identity(), 4, 4), InvalidArgumentError);
}

// The fCal calibration sweep reconstructed in the Reference frame with
// PLUS's ImageToProbe: the nine wires (phantom definition, PhantomToReference)
// run through the swept region and must be brighter than the water around.
TEST(VolumeReconstructionReal, FcalWiresAppearWhereThePhantomPutsThem) {
  MRSNS_REQUIRE_DATA(config_path, "plus/PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml");
  MRSNS_REQUIRE_DATA(sequence_path, "plus/fCal_Test_Calibration_3NWires.igs.mha");
  MRSNS_REQUIRE_DATA(results_path, "plus/FreehandCalibration3NWires.results.xml");
  const auto config = io::readDeviceSet(config_path);
  const auto sequence = io::readSequence(sequence_path);
  const Eigen::Matrix4d probe_T_image = test::readPlusReference(results_path).image_to_probe;
  const auto poses = extractFramePoses(sequence.frames, "ProbeToReference").poses;
  const int w = sequence.geometry.size[0], h = sequence.geometry.size[1];
  std::vector<Eigen::Vector3d> corners;
  for (const auto& p : poses) {
    for (const auto& [u, v] : {std::pair{0, 0}, {w - 1, 0}, {0, h - 1}, {w - 1, h - 1}}) {
      corners.push_back((p.to_T_from.matrix() * probe_T_image * Eigen::Vector4d(u, v, 0, 1)).head<3>());
    }
  }
  VolumeReconstructor reconstructor(gridAroundCorners(corners, 0.5, 0.0));
  // Every second frame keeps the test short; the sweep stays dense (0.16 mm
  // between frames on average at 12.5 frames/s).
  for (std::size_t n = 0; n < poses.size(); n += 2) {
    const auto& p = poses[n];
    const auto pixels = toMfPixels(sequence, sequence.frames[p.frame_index]);
    reconstructor.addFrame({w, h, pixels}, p.to_T_from.matrix() * probe_T_image);
  }
  const ImageVolume volume = reconstructor.result(1);
  const Eigen::Isometry3d reference_T_phantom = phantomToReference(config);
  double wire_sum = 0.0, all_sum = 0.0;
  std::size_t wire_n = 0, all_n = 0;
  for (std::size_t n = 0; n < volume.voxelCount(); n += 7) {
    const double v = volume.valueAtIndex(n);
    if (v > 0.0) {
      all_sum += v;
      ++all_n;
    }
  }
  for (const auto& pattern : config.requirePhantom().patterns) {
    for (const auto& wire : pattern.wires) {
      for (double t = 0.0; t <= 1.0; t += 0.01) {
        Eigen::Matrix4d at = Eigen::Matrix4d::Identity();
        at.block<3, 1>(0, 3) =
            reference_T_phantom * (wire.end_point_front + t * (wire.end_point_back - wire.end_point_front));
        const double v = sampleVolumeOnFrame(volume, at, 1, 1, 0.0f)[0];
        if (v <= 0.0) continue;
        wire_sum += v;
        ++wire_n;
      }
    }
  }
  std::printf("fCal volume %d x %d x %d, filled %.2f; mean along the wires %.1f over %zu samples, mean overall %.1f\n",
              volume.size[0], volume.size[1], volume.size[2], reconstructor.figures().filled_fraction,
              wire_sum / static_cast<double>(wire_n), wire_n, all_sum / static_cast<double>(all_n));
  ASSERT_GT(wire_n, 50u);
  EXPECT_GT(wire_sum / static_cast<double>(wire_n), 2.0 * all_sum / static_cast<double>(all_n));

  // The same sweep through the one-pixel-at-a-time oracle gives the same volume.
  test::ReferenceReconstructor oracle(gridAroundCorners(corners, 0.5, 0.0));
  for (std::size_t n = 0; n < poses.size(); n += 2) {
    const auto& p = poses[n];
    const auto pixels = toMfPixels(sequence, sequence.frames[p.frame_index]);
    oracle.addFrame({w, h, pixels}, p.to_T_from.matrix() * probe_T_image);
  }
  const ImageVolume expected = oracle.result(1);
  std::size_t differing = 0;
  int worst = 0;
  for (std::size_t n = 0; n < volume.voxelCount(); ++n) {
    worst = std::max(worst, std::abs(static_cast<int>(volume.data[n]) - static_cast<int>(expected.data[n])));
    differing += volume.data[n] != expected.data[n];
  }
  EXPECT_LE(worst, 1);
  EXPECT_LT(static_cast<double>(differing), 1e-4 * static_cast<double>(volume.voxelCount()));
  EXPECT_EQ(reconstructor.figures().pixels_inside, oracle.figures().pixels_inside);
}

}  // namespace
}  // namespace mrsns::ultrasound
