// Broken and lying sequence files: each must fail with a FormatError (or
// FileError/UnsupportedError) whose message names the file and the problem,
// never crash or allocate what the header claims.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mrsns/core/error.h"
#include "mrsns/io/sequence_file.h"
#include "test_data.h"
#include "test_sequence_util.h"

namespace mrsns {
namespace {

using ::testing::HasSubstr;

// Runs `read` and returns the FormatError message (fails the test if none).
template <typename Read>
std::string formatErrorOf(Read&& read) {
  try {
    read();
  } catch (const FormatError& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected FormatError, got: " << e.what();
    return {};
  }
  ADD_FAILURE() << "expected FormatError, nothing thrown";
  return {};
}

std::string replaceOnce(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

TEST(SequenceCorrupt, TruncatedRealFileIsReportedAtOpen) {
  MRSNS_REQUIRE_DATA(path, "plus/fCal_Test_Calibration_3NWires.igs.mha");
  const auto dir = test::scratchDirectory("truncated");
  const std::string bytes = test::slurp(path);
  test::spit(dir / "half.igs.mha", bytes.substr(0, bytes.size() / 2));
  const std::string message = formatErrorOf([&] { (void)io::readSequenceHeader(dir / "half.igs.mha"); });
  EXPECT_THAT(message, HasSubstr("half.igs.mha"));
  EXPECT_THAT(message, HasSubstr("truncated"));
  // Cut inside the header: no ElementDataFile line.
  test::spit(dir / "head.igs.mha", bytes.substr(0, 5000));
  EXPECT_THAT(formatErrorOf([&] { (void)io::readSequence(dir / "head.igs.mha"); }), HasSubstr("head.igs.mha"));
}

TEST(SequenceCorrupt, TruncatedUncompressedAndGzipFiles) {
  const auto dir = test::scratchDirectory("cut");
  const TrackedSequence seq = test::makeSyntheticSequence(4);
  io::writeSequence(dir / "raw.mha", seq, test::writeOptions(false));
  std::string raw = test::slurp(dir / "raw.mha");
  test::spit(dir / "raw.mha", raw.substr(0, raw.size() - 10));
  EXPECT_THAT(formatErrorOf([&] { (void)io::SequenceReader(dir / "raw.mha"); }), HasSubstr("raw.mha"));

  io::writeSequence(dir / "gz.seq.nrrd", seq, test::writeOptions(true));
  std::string gz = test::slurp(dir / "gz.seq.nrrd");
  test::spit(dir / "gz.seq.nrrd", gz.substr(0, gz.size() - 40));
  EXPECT_THAT(formatErrorOf([&] { (void)io::readSequence(dir / "gz.seq.nrrd"); }), HasSubstr("gz.seq.nrrd"));

  io::writeSequence(dir / "d.mhd", seq, test::writeOptions(false));
  std::filesystem::resize_file(dir / "d.raw", seq.frameBytes());
  EXPECT_THAT(formatErrorOf([&] { (void)io::readSequence(dir / "d.mhd"); }), HasSubstr("d.mhd"));
  std::filesystem::remove(dir / "d.raw");
  EXPECT_THROW((void)io::readSequence(dir / "d.mhd"), FileError);
}

TEST(SequenceCorrupt, HeaderClaimingMoreFramesThanPresent) {
  const auto dir = test::scratchDirectory("lying");
  const TrackedSequence seq = test::makeSyntheticSequence(4);
  io::writeSequence(dir / "z.mha", seq, test::writeOptions(true));
  test::spit(dir / "z.mha", replaceOnce(test::slurp(dir / "z.mha"), "DimSize = 13 7 4", "DimSize = 13 7 5"));
  const std::string message = formatErrorOf([&] { (void)io::readSequence(dir / "z.mha"); });
  EXPECT_THAT(message, HasSubstr("z.mha"));
  EXPECT_THAT(message, HasSubstr("frame 4"));

  io::writeSequence(dir / "r.mha", seq, test::writeOptions(false));
  test::spit(dir / "r.mha", replaceOnce(test::slurp(dir / "r.mha"), "DimSize = 13 7 4", "DimSize = 13 7 9"));
  EXPECT_THAT(formatErrorOf([&] { (void)io::readSequenceHeader(dir / "r.mha"); }), HasSubstr("9 frames"));

  // Far more frames than the compressed bytes could ever inflate to.
  io::writeSequence(dir / "big.mha", seq, test::writeOptions(true));
  test::spit(dir / "big.mha", replaceOnce(test::slurp(dir / "big.mha"), "DimSize = 13 7 4", "DimSize = 13 7 400000"));
  EXPECT_THAT(formatErrorOf([&] { (void)io::readSequenceHeader(dir / "big.mha"); }), HasSubstr("big.mha"));
}

TEST(SequenceCorrupt, CorruptedZlibStream) {
  const auto dir = test::scratchDirectory("zlib");
  TrackedSequence seq = test::makeSyntheticSequence(4);
  io::writeSequence(dir / "z.mha", seq, test::writeOptions(true));
  std::string text = test::slurp(dir / "z.mha");
  const std::size_t data = text.find("ElementDataFile = LOCAL\n") + 24;
  std::string bad_header = text;
  bad_header[data] = '\x13';  // not a zlib/gzip header
  test::spit(dir / "h.mha", bad_header);
  EXPECT_THAT(formatErrorOf([&] { (void)io::readSequence(dir / "h.mha"); }), HasSubstr("h.mha"));
  // Garbage in the middle of the deflate data: caught by inflate or by the checksum.
  std::string bad_body = text;
  for (std::size_t i = data + 40; i < data + 80 && i < bad_body.size(); ++i)
    bad_body[i] = static_cast<char>(~bad_body[i]);
  test::spit(dir / "b.mha", bad_body);
  const std::string message = formatErrorOf([&] { (void)io::readSequence(dir / "b.mha"); });
  EXPECT_THAT(message, HasSubstr("b.mha"));
  EXPECT_THAT(message, HasSubstr("corrupt"));
}

TEST(SequenceCorrupt, BadMatrixNamesTheLine) {
  const auto dir = test::scratchDirectory("matrix");
  io::writeSequence(dir / "m.mha", test::makeSyntheticSequence(2), test::writeOptions(false));
  const std::string text = test::slurp(dir / "m.mha");
  const auto key = text.find("Seq_Frame0001_ReferenceToTrackerTransform = ");
  ASSERT_NE(key, std::string::npos);
  std::string bad = text;
  bad.replace(key + 44, 1, "x");
  test::spit(dir / "m.mha", bad);
  const std::string message = formatErrorOf([&] { (void)io::readSequenceHeader(dir / "m.mha"); });
  EXPECT_THAT(message, HasSubstr("m.mha"));
  EXPECT_THAT(message, HasSubstr("line "));
  EXPECT_THAT(message, HasSubstr("ReferenceToTrackerTransform"));
  EXPECT_THAT(message, HasSubstr("not a number"));
  test::spit(dir / "short.mha", replaceOnce(text, "Seq_Frame0000_ProbeToTrackerTransform = ",
                                            "Seq_Frame0000_ProbeToTrackerTransform = 1 2 3\nX_ = "));
  EXPECT_THAT(formatErrorOf([&] { (void)io::readSequenceHeader(dir / "short.mha"); }), HasSubstr("16 numbers"));
}

TEST(SequenceCorrupt, HugeDimSizeIsRefusedBeforeAllocation) {
  const auto dir = test::scratchDirectory("huge");
  test::spit(dir / "huge.mha",
             "ObjectType = Image\nNDims = 3\nDimSize = 100000 100000 100000\nElementType = MET_DOUBLE\n"
             "Seq_Frame0000_Timestamp = 1\nElementDataFile = LOCAL\n\x01\x02");
  const std::string message = formatErrorOf([&] { (void)io::readSequence(dir / "huge.mha"); });
  EXPECT_THAT(message, HasSubstr("huge.mha"));
  EXPECT_THAT(message, HasSubstr("more than"));
  // The limit is configurable.
  io::writeSequence(dir / "ok.mha", test::makeSyntheticSequence(3));
  io::SequenceReadOptions tight;
  tight.max_frames = 2;
  EXPECT_THAT(formatErrorOf([&] { (void)io::readSequence(dir / "ok.mha", tight); }), HasSubstr("max_frames"));
}

TEST(SequenceCorrupt, MissingOrMalformedHeaderFields) {
  const auto dir = test::scratchDirectory("fields");
  const std::string good =
      "ObjectType = Image\nNDims = 3\nDimSize = 2 2 1\nElementType = MET_UCHAR\n"
      "Seq_Frame0000_Timestamp = 1\nElementDataFile = LOCAL\n" +
      std::string(4, '\0');
  test::spit(dir / "good.mha", good);
  EXPECT_EQ(io::readSequence(dir / "good.mha").frames.size(), 1u);
  const std::pair<std::string, std::string> cases[] = {
      {"NDims = 3\n", ""},                                                                  // missing NDims
      {"DimSize = 2 2 1", "DimSize = 2 2"},                                                 // sizes vs NDims
      {"DimSize = 2 2 1", "DimSize = 2 -2 1"},                                              // negative size
      {"NDims = 3", "NDims = three"},                                                       // not a number
      {"Seq_Frame0000_Timestamp = 1", "Seq_Frame0000_Timestamp = soon"},                    // bad timestamp
      {"Seq_Frame0000_Timestamp = 1", "Seq_Frame0003_Timestamp = 1"},                       // frame beyond count
      {"Seq_Frame0000_Timestamp = 1", "Seq_FrameX_Timestamp = 1"},                          // malformed frame key
      {"Seq_Frame0000_Timestamp = 1", "Seq_Frame0000_Timestamp"},                           // no '='
      {"Seq_Frame0000_Timestamp = 1", "Seq_Frame0000_ProbeToTrackerTransformStatus = OK"},  // OK without matrix
  };
  for (const auto& [from, to] : cases) {
    SCOPED_TRACE(from + " -> " + to);
    test::spit(dir / "bad.mha", replaceOnce(good, from, to));
    EXPECT_THAT(formatErrorOf([&] { (void)io::readSequence(dir / "bad.mha"); }), HasSubstr("bad.mha"));
  }
  test::spit(dir / "type.mha", replaceOnce(good, "MET_UCHAR", "MET_LONG_LONG"));
  EXPECT_THROW((void)io::readSequence(dir / "type.mha"), UnsupportedError);
  EXPECT_THROW((void)io::readSequence(dir / "absent.mha"), FileError);
}

TEST(SequenceCorrupt, MalformedNrrdHeaders) {
  const auto dir = test::scratchDirectory("nrrd");
  const std::string good =
      "NRRD0004\ntype: uint8\ndimension: 4\nsizes: 2 2 1 1\nkinds: domain domain domain list\n"
      "encoding: raw\nSeq_Frame0000_Timestamp:=1\n\n" +
      std::string(4, '\0');
  test::spit(dir / "good.seq.nrrd", good);
  EXPECT_EQ(io::readSequence(dir / "good.seq.nrrd").frames.size(), 1u);
  const std::pair<std::string, std::string> cases[] = {
      {"sizes: 2 2 1 1", "sizes: 2 2 1"},
      {"dimension: 4", "dimension: 9"},
      {"type: uint8\n", ""},
      {"sizes: 2 2 1 1", "sizes: 2 2 1 7"},
      {"encoding: raw\n", "encoding: raw\nspace directions: (1,0,0) (0,x,0) (0,0,1) none\n"},
  };
  for (const auto& [from, to] : cases) {
    SCOPED_TRACE(from + " -> " + to);
    test::spit(dir / "bad.seq.nrrd", replaceOnce(good, from, to));
    EXPECT_THAT(formatErrorOf([&] { (void)io::readSequence(dir / "bad.seq.nrrd"); }), HasSubstr("bad.seq.nrrd"));
  }
  test::spit(dir / "bz.seq.nrrd", replaceOnce(good, "encoding: raw", "encoding: bzip2"));
  EXPECT_THROW((void)io::readSequence(dir / "bz.seq.nrrd"), UnsupportedError);
}

}  // namespace
}  // namespace mrsns
