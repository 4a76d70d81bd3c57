// PLUS's own recordings (fCal N-wire calibration and validation sequences):
// full read, checks against the header text and an independent inflate,
// round trips through every format, streaming vs full read.
#include <gtest/gtest.h>
#include <zlib.h>

#include "mrsns/core/error.h"
#include "mrsns/io/sequence_file.h"
#include "test_data.h"
#include "test_sequence_util.h"

namespace mrsns {
namespace {

constexpr const char* kCalibration = "plus/fCal_Test_Calibration_3NWires.igs.mha";
constexpr const char* kValidation = "plus/fCal_Test_Validation_3NWires.igs.mha";

TEST(SequenceReal, CalibrationFileReadsFully) {
  MRSNS_REQUIRE_DATA(path, kCalibration);
  io::SequenceStorage storage;
  const TrackedSequence header = io::readSequenceHeader(path, {}, &storage);
  EXPECT_TRUE(storage.compressed);
  ASSERT_TRUE(storage.stored_bytes.has_value());
  EXPECT_EQ(*storage.stored_bytes, 1411285u);

  const TrackedSequence seq = io::readSequence(path);
  ASSERT_EQ(seq.frames.size(), 188u);
  EXPECT_EQ(seq.geometry.dimensions, 2);
  EXPECT_EQ(seq.geometry.size, (std::array<std::int64_t, 3>{820, 616, 1}));
  EXPECT_EQ(seq.pixel_format.scalar, PixelType::UInt8);
  EXPECT_EQ(seq.pixel_format.components, 1);
  EXPECT_EQ(seq.orientation, "MFA");
  EXPECT_EQ(seq.transformNames(),
            (std::vector<std::string>{"ProbeToTracker", "ReferenceToTracker", "StylusToTracker"}));
  // Global fields that are not layout are kept, in file order.
  ASSERT_EQ(seq.custom_header_fields.size(), 2u);
  EXPECT_EQ(seq.custom_header_fields[0], (std::pair<std::string, std::string>{"AnatomicalOrientation", "RAI"}));
  EXPECT_EQ(seq.custom_header_fields[1], (std::pair<std::string, std::string>{"CenterOfRotation", "0 0 0"}));

  // Frame 0 exactly as the header text has it.
  const TrackedFrame& f0 = seq.frames[0];
  EXPECT_EQ(f0.timestamp, 425.398686);
  EXPECT_EQ(f0.image_status, "OK");
  Eigen::Matrix4d probe;
  probe << -0.0215859, 0.20331, 0.978876, 264.765, -0.156876, 0.966287, -0.204155, 16.5199, -0.987382, -0.157969,
      0.0110363, -8.81807, 0, 0, 0, 1;
  EXPECT_TRUE(f0.transforms.at("ProbeToTracker").matrix == probe) << f0.transforms.at("ProbeToTracker").matrix;
  EXPECT_EQ(f0.transforms.at("StylusToTracker").matrix(0, 3), 79.1394);
  EXPECT_EQ(f0.transforms.at("ReferenceToTracker").matrix(2, 3), -42.0812);
  EXPECT_EQ(seq.frames.back().timestamp, 440.246214);
  for (const auto& frame : seq.frames) {
    for (const auto& name : seq.transformNames()) EXPECT_EQ(frame.transformStatus(name), TransformStatus::Ok);
    ASSERT_EQ(frame.pixels.size(), 820u * 616u);
  }

  // Pixels against an independent one-shot inflate of the data block.
  const std::string bytes = test::slurp(path);
  const std::string marker = "ElementDataFile = LOCAL";
  const auto start = bytes.find('\n', bytes.find(marker)) + 1;
  std::vector<std::uint8_t> expected(820u * 616u * 188u);
  uLongf expected_size = expected.size();
  ASSERT_EQ(uncompress(expected.data(), &expected_size, reinterpret_cast<const Bytef*>(bytes.data() + start),
                       static_cast<uLong>(bytes.size() - start)),
            Z_OK);
  ASSERT_EQ(expected_size, expected.size());
  for (std::size_t i = 0; i < seq.frames.size(); ++i) {
    ASSERT_TRUE(std::equal(seq.frames[i].pixels.begin(), seq.frames[i].pixels.end(),
                           expected.begin() + static_cast<std::ptrdiff_t>(i * 820u * 616u)))
        << "frame " << i;
  }
}

TEST(SequenceReal, HeaderOnlyReadHasMetadataButNoPixels) {
  MRSNS_REQUIRE_DATA(path, kCalibration);
  const TrackedSequence header = io::readSequenceHeader(path);
  ASSERT_EQ(header.frames.size(), 188u);
  EXPECT_FALSE(header.frames[0].hasPixels());
  EXPECT_EQ(header.frames[187].timestamp, 440.246214);
}

TEST(SequenceReal, StreamingReaderMatchesFullRead) {
  MRSNS_REQUIRE_DATA(path, kCalibration);
  const TrackedSequence full = io::readSequence(path);
  io::SequenceReader reader(path);
  ASSERT_EQ(reader.frameCount(), full.frames.size());
  for (std::size_t i = 0; i < reader.frameCount(); ++i) {
    const TrackedFrame frame = reader.readFrame(i);
    ASSERT_TRUE(frame == full.frames[i]) << "frame " << i;
  }
  // Iteration continues after the last frame read.
  EXPECT_FALSE(reader.readNextFrame().has_value());
  io::SequenceReader iterating(path);
  std::size_t count = 0;
  while (auto frame = iterating.readNextFrame()) {
    ASSERT_TRUE(*frame == full.frames[count]) << "frame " << count;
    ++count;
  }
  EXPECT_EQ(count, 188u);
  // Going back restarts the inflate; jumping ahead skips frames.
  EXPECT_TRUE(reader.readFrame(5) == full.frames[5]);
  EXPECT_TRUE(reader.readFrame(150) == full.frames[150]);
  EXPECT_TRUE(reader.readFrame(0) == full.frames[0]);
  EXPECT_THROW((void)reader.readFrame(188), InvalidArgumentError);
}

struct RoundTripCase {
  const char* file_name;
  bool compress;
  friend void PrintTo(const RoundTripCase& c, std::ostream* os) {
    *os << c.file_name << (c.compress ? " compressed" : " raw");
  }
};

class SequenceRealRoundTrip : public ::testing::TestWithParam<RoundTripCase> {};

TEST_P(SequenceRealRoundTrip, CalibrationFileSurvivesWriteRead) {
  MRSNS_REQUIRE_DATA(path, kCalibration);
  static const TrackedSequence original = io::readSequence(path);
  const auto dir = test::scratchDirectory("roundtrip");
  const auto out = dir / GetParam().file_name;
  io::SequenceWriteOptions options;
  options.compress = GetParam().compress;
  io::writeSequence(out, original, options);
  io::SequenceStorage storage;
  (void)io::readSequenceHeader(out, {}, &storage);
  EXPECT_EQ(storage.compressed, GetParam().compress);
  const TrackedSequence again = io::readSequence(out);
  test::expectSameSequence(original, again);
  // Written once more from the copy, the file is byte-identical: nothing drifts.
  std::filesystem::create_directories(dir / "again");
  const auto out2 = dir / "again" / GetParam().file_name;
  io::writeSequence(out2, again, options);
  EXPECT_TRUE(test::slurp(out) == test::slurp(out2));
  std::filesystem::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(Formats, SequenceRealRoundTrip,
                         ::testing::Values(RoundTripCase{"copy.igs.mha", true}, RoundTripCase{"copy.seq.mha", false},
                                           RoundTripCase{"copy.mhd", false}, RoundTripCase{"copy.mhd", true},
                                           RoundTripCase{"copy.seq.nrrd", true}, RoundTripCase{"copy.seq.nrrd", false}),
                         [](const auto& param_info) {
                           std::string name = param_info.param.file_name;
                           for (auto& c : name) {
                             if (c == '.') c = '_';
                           }
                           return name + (param_info.param.compress ? "_compressed" : "_raw");
                         });

TEST(SequenceReal, ValidationFileRoundTrips) {
  MRSNS_REQUIRE_DATA(path, kValidation);
  const TrackedSequence seq = io::readSequence(path);
  ASSERT_EQ(seq.frames.size(), 94u);
  EXPECT_EQ(seq.geometry.size, (std::array<std::int64_t, 3>{820, 616, 1}));
  EXPECT_EQ(seq.transformNames(),
            (std::vector<std::string>{"ProbeToTracker", "ReferenceToTracker", "StylusToTracker"}));
  const auto dir = test::scratchDirectory("validation");
  io::writeSequence(dir / "v.seq.nrrd", seq);
  test::expectSameSequence(seq, io::readSequence(dir / "v.seq.nrrd"));
  io::writeSequence(dir / "v.igs.mha", seq);
  test::expectSameSequence(seq, io::readSequence(dir / "v.igs.mha"));
  std::filesystem::remove_all(dir);
}

TEST(SequenceReal, RealFileIsRecognisedAsSequence) {
  MRSNS_REQUIRE_DATA(path, kCalibration);
  EXPECT_TRUE(io::looksLikeSequenceFile(path));
}

}  // namespace
}  // namespace mrsns
