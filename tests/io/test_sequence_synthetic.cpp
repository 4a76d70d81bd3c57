// Sequence files built here, one feature at a time: every format and
// compression, pixel types, components, 3D frames, statuses, custom fields,
// big-endian data, Slicer-style NRRD headers, atomic writes.
#include <gtest/gtest.h>

#include <algorithm>

#include "mrsns/core/error.h"
#include "mrsns/io/sequence_file.h"
#include "test_data.h"
#include "test_sequence_util.h"

namespace mrsns {
namespace {

struct FormatCase {
  const char* file_name;
  bool compress;
  friend void PrintTo(const FormatCase& c, std::ostream* os) {
    *os << c.file_name << (c.compress ? " compressed" : " raw");
  }
};

class SequenceFormats : public ::testing::TestWithParam<FormatCase> {};

TEST_P(SequenceFormats, EveryPixelTypeRoundTrips) {
  const auto dir = test::scratchDirectory("types");
  const PixelType types[] = {PixelType::UInt8,  PixelType::Int8,  PixelType::UInt16,  PixelType::Int16,
                             PixelType::UInt32, PixelType::Int32, PixelType::Float32, PixelType::Float64};
  for (const PixelType type : types) {
    SCOPED_TRACE(pixelTypeName(type));
    const TrackedSequence seq = test::makeSyntheticSequence(4, type);
    const auto path = dir / GetParam().file_name;
    io::SequenceWriteOptions options;
    options.compress = GetParam().compress;
    io::writeSequence(path, seq, options);
    test::expectSameSequence(seq, io::readSequence(path));
  }
}

TEST_P(SequenceFormats, RgbAndVolumeFramesRoundTrip) {
  const auto dir = test::scratchDirectory("rgb");
  io::SequenceWriteOptions options;
  options.compress = GetParam().compress;
  const TrackedSequence rgb = test::makeSyntheticSequence(3, PixelType::UInt8, 3);
  io::writeSequence(dir / GetParam().file_name, rgb, options);
  test::expectSameSequence(rgb, io::readSequence(dir / GetParam().file_name));
  const TrackedSequence volumes = test::makeSyntheticSequence(3, PixelType::Int16, 1, 3);
  io::writeSequence(dir / GetParam().file_name, volumes, options);
  const TrackedSequence back = io::readSequence(dir / GetParam().file_name);
  EXPECT_EQ(back.geometry.dimensions, 3);
  test::expectSameSequence(volumes, back);
}

TEST_P(SequenceFormats, EmptyAndSingleFrameSequences) {
  const auto dir = test::scratchDirectory("small");
  io::SequenceWriteOptions options;
  options.compress = GetParam().compress;
  for (const int n : {0, 1}) {
    const TrackedSequence seq = test::makeSyntheticSequence(n);
    io::writeSequence(dir / GetParam().file_name, seq, options);
    test::expectSameSequence(seq, io::readSequence(dir / GetParam().file_name));
  }
}

INSTANTIATE_TEST_SUITE_P(All, SequenceFormats,
                         ::testing::Values(FormatCase{"s.igs.mha", true}, FormatCase{"s.seq.mha", false},
                                           FormatCase{"s.mhd", true}, FormatCase{"s.mhd", false},
                                           FormatCase{"s.seq.nrrd", true}, FormatCase{"s.seq.nrrd", false}),
                         [](const auto& param_info) {
                           std::string name = param_info.param.file_name;
                           std::replace(name.begin(), name.end(), '.', '_');
                           return name + (param_info.param.compress ? "_z" : "_raw");
                         });

TEST(SequenceSynthetic, StatusesAndMissingTransformsSurvive) {
  const auto dir = test::scratchDirectory("status");
  const TrackedSequence seq = test::makeSyntheticSequence(5);
  io::writeSequence(dir / "s.igs.mha", seq);
  const TrackedSequence back = io::readSequence(dir / "s.igs.mha");
  EXPECT_EQ(back.frames[2].transformStatus("ProbeToTracker"), TransformStatus::Invalid);
  EXPECT_EQ(back.frames[1].transformStatus("ProbeToTracker"), TransformStatus::Ok);
  EXPECT_EQ(back.frames[0].transformStatus("StylusToTracker"), TransformStatus::Invalid);
  EXPECT_EQ(back.frames[1].transformStatus("StylusToTracker"), TransformStatus::Missing);
  EXPECT_EQ(back.frames[3].image_status, "INVALID");
  EXPECT_EQ(back.frames[4].custom_fields.at("UnfilteredTimestamp"), "1004.5");
  const auto text = test::slurp(dir / "s.igs.mha");
  EXPECT_NE(text.find("Seq_Frame0002_ProbeToTrackerTransformStatus = INVALID\n"), std::string::npos);
  EXPECT_EQ(text.find("Seq_Frame0001_StylusToTracker"), std::string::npos);
}

TEST(SequenceSynthetic, GlobalFieldsKeepTheirOrder) {
  const auto dir = test::scratchDirectory("order");
  TrackedSequence seq = test::makeSyntheticSequence(2);
  seq.custom_header_fields = {{"Zeta", "1"}, {"Alpha", "two words"}, {"Mid", "x"}};
  for (const char* name : {"s.mha", "s.seq.nrrd"}) {
    io::writeSequence(dir / name, seq);
    EXPECT_EQ(io::readSequence(dir / name).custom_header_fields, seq.custom_header_fields) << name;
  }
}

TEST(SequenceSynthetic, ManyFramesWidenTheFrameNumber) {
  const auto dir = test::scratchDirectory("wide");
  TrackedSequence seq = test::makeSyntheticSequence(1);
  seq.geometry.size = {2, 2, 1};
  seq.frames[0].pixels.assign(4, 9);
  seq.frames.resize(10001, seq.frames[0]);
  seq.frames.back().timestamp = 99.0;
  io::writeSequence(dir / "w.mha", seq);
  const TrackedSequence back = io::readSequence(dir / "w.mha");
  ASSERT_EQ(back.frames.size(), 10001u);
  EXPECT_EQ(back.frames.back().timestamp, 99.0);
  EXPECT_NE(test::slurp(dir / "w.mha").find("Seq_Frame10000_Timestamp = 99\n"), std::string::npos);
}

TEST(SequenceSynthetic, DetachedMetaImageNamesItsDataFile) {
  const auto dir = test::scratchDirectory("detached");
  const TrackedSequence seq = test::makeSyntheticSequence(3);
  io::writeSequence(dir / "rec.mhd", seq, test::writeOptions(true));
  EXPECT_TRUE(std::filesystem::exists(dir / "rec.zraw"));
  EXPECT_NE(test::slurp(dir / "rec.mhd").find("ElementDataFile = rec.zraw"), std::string::npos);
  io::writeSequence(dir / "rec2.mhd", seq, test::writeOptions(false));
  EXPECT_EQ(std::filesystem::file_size(dir / "rec2.raw"), 3 * seq.frameBytes());
  io::SequenceStorage storage;
  (void)io::readSequenceHeader(dir / "rec2.mhd", {}, &storage);
  EXPECT_EQ(storage.format, io::SequenceFormat::MetaImageDetached);
  EXPECT_EQ(storage.data_file, dir / "rec2.raw");
}

TEST(SequenceSynthetic, BigEndianDataIsSwapped) {
  const auto dir = test::scratchDirectory("endian");
  const TrackedSequence seq = test::makeSyntheticSequence(2, PixelType::UInt16);
  io::writeSequence(dir / "le.mha", seq, test::writeOptions(false));
  std::string text = test::slurp(dir / "le.mha");
  const auto at = text.find("BinaryDataByteOrderMSB = False");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 30, "BinaryDataByteOrderMSB = True");
  const std::size_t data = text.size() - 2 * seq.frameBytes();
  for (std::size_t i = data; i + 1 < text.size(); i += 2) std::swap(text[i], text[i + 1]);
  test::spit(dir / "be.mha", text);
  test::expectSameSequence(seq, io::readSequence(dir / "be.mha"));
}

TEST(SequenceSynthetic, SlicerStyleNrrdWithIndexValuesAndItemAttributes) {
  const auto dir = test::scratchDirectory("slicer");
  std::string header =
      "NRRD0005\n# written by hand\ntype: uint8\ndimension: 4\nspace: right-anterior-superior\nsizes: 2 3 1 3\n"
      "space directions: (0.5,0,0) (0,2,0) (0,0,1) none\nkinds: domain domain domain list\n"
      "labels: \"\" \"\" \"\" \"time\"\nendian: little\nencoding: raw\nspace origin: (10,20,30)\n"
      "DataNodeClassName:=vtkMRMLScalarVolumeNode\naxis 3 index type:=numeric\naxis 3 index values:=1.5 2.5 3.75\n"
      "axis 3 item 1 ProbeToTrackerTransform:=1 0 0 5 0 1 0 6 0 0 1 7 0 0 0 1\n"
      "axis 3 item 1 ProbeToTrackerTransformStatus:=OK\nCustomThing:=abc\n\n";
  std::string pixels(18, '\0');
  for (std::size_t i = 0; i < pixels.size(); ++i) pixels[i] = static_cast<char>(i * 7);
  test::spit(dir / "slicer.seq.nrrd", header + pixels);
  const TrackedSequence seq = io::readSequence(dir / "slicer.seq.nrrd");
  ASSERT_EQ(seq.frames.size(), 3u);
  EXPECT_EQ(seq.geometry.size, (std::array<std::int64_t, 3>{2, 3, 1}));
  EXPECT_EQ(seq.geometry.spacing, (std::array<double, 3>{0.5, 2.0, 1.0}));
  // RAS origin and axes come out in LPS.
  EXPECT_EQ(seq.geometry.origin, (std::array<double, 3>{-10.0, -20.0, 30.0}));
  EXPECT_EQ(seq.geometry.direction(0, 0), -1.0);
  EXPECT_EQ(seq.geometry.direction(1, 1), -1.0);
  EXPECT_EQ(seq.frames[2].timestamp, 3.75);
  EXPECT_EQ(seq.frames[1].transforms.at("ProbeToTracker").matrix(1, 3), 6.0);
  EXPECT_EQ(seq.frames[0].transformStatus("ProbeToTracker"), TransformStatus::Missing);
  EXPECT_EQ(seq.custom_header_fields, (std::vector<std::pair<std::string, std::string>>{{"CustomThing", "abc"}}));
  EXPECT_EQ(seq.frames[2].pixels[5], static_cast<std::uint8_t>(17 * 7));
}

TEST(SequenceSynthetic, DetachedNrrdHeaderReadsItsDataFile) {
  const auto dir = test::scratchDirectory("nhdr");
  const TrackedSequence seq = test::makeSyntheticSequence(3, PixelType::Int16);
  io::writeSequence(dir / "s.seq.nrrd", seq, test::writeOptions(true));
  const std::string text = test::slurp(dir / "s.seq.nrrd");
  const auto end = text.find("\n\n") + 2;
  test::spit(dir / "s.seq.nhdr", text.substr(0, end - 1) + "data file: s.gz\n");
  test::spit(dir / "s.gz", text.substr(end));
  test::expectSameSequence(seq, io::readSequence(dir / "s.seq.nhdr"));
}

TEST(SequenceSynthetic, InterleavedSlicerLayoutIsRefusedClearly) {
  const auto dir = test::scratchDirectory("interleaved");
  test::spit(dir / "old.seq.nrrd",
             "NRRD0004\ntype: uint8\ndimension: 4\nsizes: 3 2 2 1\nkinds: list domain domain domain\n"
             "encoding: raw\n\n" +
                 std::string(12, '\0'));
  EXPECT_THROW((void)io::readSequence(dir / "old.seq.nrrd"), UnsupportedError);
}

TEST(SequenceSynthetic, LooksLikeSequenceFileTellsSequencesFromImages) {
  const auto dir = test::scratchDirectory("sniff");
  io::writeSequence(dir / "s.mha", test::makeSyntheticSequence(2), test::writeOptions(false));
  io::writeSequence(dir / "s.mhd", test::makeSyntheticSequence(2));
  test::spit(dir / "image.mha",
             "ObjectType = Image\nNDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\nElementDataFile = LOCAL\n" +
                 std::string(8, '\1'));
  EXPECT_TRUE(io::looksLikeSequenceFile(dir / "s.mha"));
  EXPECT_TRUE(io::looksLikeSequenceFile(dir / "s.mhd"));
  EXPECT_FALSE(io::looksLikeSequenceFile(dir / "image.mha"));
  EXPECT_FALSE(io::looksLikeSequenceFile(dir / "absent.mha"));
  // A plain volume still reads, as frames along its last axis.
  EXPECT_EQ(io::readSequence(dir / "image.mha").frames.size(), 2u);
}

TEST(SequenceSynthetic, FailedWriteLeavesTheOriginalUntouched) {
  const auto dir = test::scratchDirectory("atomic");
  const TrackedSequence seq = test::makeSyntheticSequence(3);
  io::writeSequence(dir / "keep.igs.mha", seq);
  const std::string before = test::slurp(dir / "keep.igs.mha");
  TrackedSequence broken = seq;
  broken.frames[1].pixels.clear();  // metadata only: cannot be written
  EXPECT_THROW(io::writeSequence(dir / "keep.igs.mha", broken), InvalidArgumentError);
  broken = seq;
  broken.frames[0].custom_fields["Bad"] = "two\nlines";
  EXPECT_THROW(io::writeSequence(dir / "keep.igs.mha", broken), InvalidArgumentError);
  broken = seq;
  broken.custom_header_fields.emplace_back("DimSize", "1 1 1");
  EXPECT_THROW(io::writeSequence(dir / "keep.igs.mha", broken), InvalidArgumentError);
  EXPECT_TRUE(test::slurp(dir / "keep.igs.mha") == before);
  EXPECT_THROW(io::writeSequence(dir / "no_such_dir" / "x.mha", seq), FileError);
  EXPECT_THROW(io::writeSequence(dir / "x.png", seq), UnsupportedError);
  // No temporary files are left behind.
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(dir)) ++files;
  EXPECT_EQ(files, 1u);
}

TEST(SequenceSynthetic, StreamingReaderOnUncompressedFileSeeks) {
  const auto dir = test::scratchDirectory("seek");
  const TrackedSequence seq = test::makeSyntheticSequence(6, PixelType::Float32);
  io::writeSequence(dir / "s.seq.nrrd", seq, test::writeOptions(false));
  io::SequenceReader reader(dir / "s.seq.nrrd");
  EXPECT_EQ(reader.frameCount(), 6u);
  EXPECT_FALSE(reader.storage().compressed);
  for (const std::size_t i : {5u, 0u, 3u}) EXPECT_TRUE(reader.readFrame(i) == seq.frames[i]) << i;
  std::vector<std::uint8_t> wrong(3);
  EXPECT_THROW(reader.readFramePixels(0, wrong), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns

namespace mrsns {
namespace {

// A PLUS tracker buffer: frames with transforms and no image, written as
// DimSize = 0 0 N with no pixel data (PLUS's TrackerBuffer files).
TEST(SequenceSynthetic, PlusTrackerBufferWithoutImagesReadsAndRoundTrips) {
  const auto dir = test::scratchDirectory("tracker-buffer");
  std::string text =
      "ObjectType = Image\nNDims = 3\nAnatomicalOrientation = RAI\nBinaryData = True\nCompressedData = False\n"
      "DimSize = 0 0 3\nElementSpacing = 1 1 1\nOffset = 0 0 0\nTransformMatrix = 1 0 0 0 1 0 0 0 1\n"
      "ElementType = MET_UCHAR\nKinds = domain domain list\n";
  for (int i = 0; i < 3; ++i) {
    const std::string k = "Seq_Frame000" + std::to_string(i) + "_";
    text += k + "FrameNumber = " + std::to_string(i) + "\n";
    text += k + "ProbeToReferenceTransform = 1 0 0 0 0 1 0 0 0 0 1 " + std::to_string(2 * i) + " 0 0 0 1\n";
    text += k + "ProbeToReferenceTransformStatus = OK\n";
    text += k + "Timestamp = " + std::to_string(10 + i) + ".5\n";
    text += k + "ImageStatus = INVALID\n";
  }
  text += "ElementDataFile = LOCAL\n";
  test::spit(dir / "TrackerBuffer.mha", text);
  const TrackedSequence seq = io::readSequence(dir / "TrackerBuffer.mha");
  ASSERT_EQ(seq.frames.size(), 3u);
  EXPECT_TRUE(seq.trackingOnly());
  EXPECT_EQ(seq.frameBytes(), 0u);
  EXPECT_TRUE(seq.frames[1].pixels.empty());
  EXPECT_EQ(seq.frames[2].transforms.at("ProbeToReference").matrix(2, 3), 4.0);
  EXPECT_EQ(seq.frames[1].timestamp, 11.5);
  EXPECT_EQ(seq.frames[0].image_status, "INVALID");

  // Every MetaImage form writes and reads it back; NRRD cannot hold it and says so.
  for (const char* name : {"round.mha", "round.mhd"}) {
    for (const bool compress : {false, true}) {
      SCOPED_TRACE(std::string(name) + (compress ? " compressed" : " raw"));
      io::writeSequence(dir / name, seq, test::writeOptions(compress));
      test::expectSameSequence(seq, io::readSequence(dir / name));
      EXPECT_NE(test::slurp(dir / name).find("DimSize = 0 0 3"), std::string::npos);
    }
  }
  try {
    io::writeSequence(dir / "round.seq.nrrd", seq);
    ADD_FAILURE() << "NRRD accepted a sequence without images";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find(".mha"), std::string::npos) << e.what();
  }
  // Only an image with both in-plane sizes zero is a tracker buffer.
  test::spit(dir / "half.mha", [&] {
    std::string t = text;
    t.replace(t.find("DimSize = 0 0 3"), 15, "DimSize = 0 4 3");
    return t;
  }());
  EXPECT_THROW((void)io::readSequence(dir / "half.mha"), FormatError);
}

}  // namespace
}  // namespace mrsns
