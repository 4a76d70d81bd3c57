#pragma once
// Helpers for the sequence-file tests: synthetic sequences with every
// feature, and field-by-field comparison with readable failures.
#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include "mrsns/core/tracked_frame.h"
#include "mrsns/io/sequence_file.h"

namespace mrsns::test {

/// A small sequence exercising every field: several transforms with all
/// statuses (and one missing in some frames), custom frame and global
/// fields, non-trivial geometry, pseudo-random pixels of `scalar` type.
inline TrackedSequence makeSyntheticSequence(int frames = 5, PixelType scalar = PixelType::UInt8, int components = 1,
                                             int dimensions = 2, unsigned seed = 7) {
  TrackedSequence seq;
  seq.geometry.dimensions = dimensions;
  seq.geometry.size = {13, 7, dimensions == 3 ? 3 : 1};
  seq.geometry.spacing = {0.25, 0.5, 2.0};
  seq.geometry.origin = {-10.5, 3.25, 7.0};
  seq.pixel_format = {scalar, components};
  seq.orientation = "MFA";
  seq.custom_header_fields = {{"AnatomicalOrientation", "RAI"}, {"CenterOfRotation", "0 0 0"}, {"DeviceName", "Sim"}};
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-300.0, 300.0);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int i = 0; i < frames; ++i) {
    TrackedFrame f;
    f.timestamp = 425.398686 + 0.0785 * i;
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) m(r, c) = u(rng) / (c < 3 ? 300.0 : 1.0);
    }
    f.transforms["ProbeToTracker"] = {m, i == 2 ? TransformStatus::Invalid : TransformStatus::Ok};
    f.transforms["ReferenceToTracker"] = {m.transpose(), TransformStatus::Ok};
    if (i % 2 == 0) f.transforms["StylusToTracker"] = {Eigen::Matrix4d::Identity(), TransformStatus::Invalid};
    f.image_status = i == 3 ? "INVALID" : "OK";
    f.custom_fields["UnfilteredTimestamp"] = std::to_string(1000 + i) + ".5";
    f.custom_fields["FrameNumber"] = std::to_string(i);
    f.pixels.resize(seq.frameBytes());
    for (auto& p : f.pixels) p = static_cast<std::uint8_t>(byte(rng));
    seq.frames.push_back(std::move(f));
  }
  return seq;
}

/// EXPECTs that two sequences are equal field by field (pixels bit-identical).
inline void expectSameSequence(const TrackedSequence& a, const TrackedSequence& b, bool compare_pixels = true) {
  EXPECT_EQ(a.geometry.dimensions, b.geometry.dimensions);
  EXPECT_EQ(a.geometry.size, b.geometry.size);
  EXPECT_EQ(a.geometry.spacing, b.geometry.spacing);
  EXPECT_EQ(a.geometry.origin, b.geometry.origin);
  EXPECT_TRUE(a.geometry.direction == b.geometry.direction) << a.geometry.direction << "\nvs\n" << b.geometry.direction;
  EXPECT_EQ(a.pixel_format, b.pixel_format);
  EXPECT_EQ(a.orientation, b.orientation);
  EXPECT_EQ(a.custom_header_fields, b.custom_header_fields);
  ASSERT_EQ(a.frames.size(), b.frames.size());
  for (std::size_t i = 0; i < a.frames.size(); ++i) {
    SCOPED_TRACE("frame " + std::to_string(i));
    const auto& fa = a.frames[i];
    const auto& fb = b.frames[i];
    EXPECT_EQ(fa.timestamp, fb.timestamp);
    EXPECT_EQ(fa.image_status, fb.image_status);
    EXPECT_EQ(fa.custom_fields, fb.custom_fields);
    ASSERT_EQ(fa.transforms.size(), fb.transforms.size());
    for (const auto& [name, t] : fa.transforms) {
      ASSERT_TRUE(fb.transforms.count(name)) << name;
      EXPECT_EQ(t.status, fb.transforms.at(name).status) << name;
      EXPECT_TRUE(t.matrix == fb.transforms.at(name).matrix) << name;
    }
    if (compare_pixels) {
      EXPECT_TRUE(fa.pixels == fb.pixels) << "pixels differ";
    }
  }
}

inline io::SequenceWriteOptions writeOptions(bool compress) {
  io::SequenceWriteOptions options;
  options.compress = compress;
  return options;
}

inline std::string slurp(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

inline void spit(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

}  // namespace mrsns::test
