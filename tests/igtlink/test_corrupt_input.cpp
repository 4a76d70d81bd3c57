// Malformed input: every case throws a FormatError naming the field, never
// crashes, never allocates what a size field claims before checking it.
#include <gtest/gtest.h>

#include "mrsns/core/error.h"
#include "mrsns/igtlink/byte_order.h"
#include "mrsns/igtlink/codec.h"
#include "mrsns/igtlink/crc64.h"

namespace mrsns::igtlink {
namespace {

/// Runs `f`, expects a FormatError whose message mentions `field`.
template <typename F>
void expectFormatError(F&& f, const std::string& field) {
  try {
    f();
    ADD_FAILURE() << "no FormatError (expected one about '" << field << "')";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
  }
}

void putU32(std::vector<std::uint8_t>& b, std::size_t at, std::uint32_t v) {
  ByteWriter::store32(b.data() + at, v);
}
void putU16(std::vector<std::uint8_t>& b, std::size_t at, std::uint16_t v) {
  b[at] = static_cast<std::uint8_t>(v >> 8);
  b[at + 1] = static_cast<std::uint8_t>(v);
}
void putU64(std::vector<std::uint8_t>& b, std::size_t at, std::uint64_t v) {
  putU32(b, at, static_cast<std::uint32_t>(v >> 32));
  putU32(b, at + 4, static_cast<std::uint32_t>(v));
}

/// Rewrites body size and CRC after the body was edited, so only the edit is wrong.
void refreshCrc(std::vector<std::uint8_t>& b) {
  putU64(b, 42, b.size() - kHeaderSize);
  putU64(b, 50, crc64(std::span<const std::uint8_t>(b).subspan(kHeaderSize)));
}

std::vector<std::uint8_t> sampleTransform() {
  return encodeMessage(makeMessage("T", TransformContent{}));
}

PolyDataContent triangle() {
  PolyDataContent p;
  p.points.resize(3, 3);
  p.points << 0, 0, 0, 1, 0, 0, 0, 1, 0;
  p.polygons.add({0, 1, 2});
  return p;
}

TEST(CorruptInput, TruncatedHeader) {
  const auto bytes = sampleTransform();
  for (std::size_t n : {0, 1, 20, 57}) {
    expectFormatError([&] { decodeMessage(std::span<const std::uint8_t>(bytes).first(n)); }, "header");
  }
}

TEST(CorruptInput, BodySizeLargerThanData) {
  auto bytes = sampleTransform();
  bytes.resize(bytes.size() - 1);
  expectFormatError([&] { decodeMessage(bytes); }, "body_size");
}

TEST(CorruptInput, BodySizeBeyondLimitIsRefusedBeforeReading) {
  auto bytes = sampleTransform();
  putU64(bytes, 42, 1ULL << 40);
  expectFormatError([&] { decodeMessage(bytes); }, "body_size");
  DecodeOptions small;
  small.max_body_size = 47;
  expectFormatError([&] { decodeMessage(sampleTransform(), small); }, "body_size");
}

TEST(CorruptInput, BadCrcIsRefusedUnlessDisabled) {
  auto bytes = sampleTransform();
  bytes[kHeaderSize + 5] ^= 0x40;
  expectFormatError([&] { decodeMessage(bytes); }, "crc");
  DecodeOptions lenient;
  lenient.verify_crc = false;
  EXPECT_NO_THROW(decodeMessage(bytes, lenient));
}

TEST(CorruptInput, WrongFixedContentSizes) {
  auto bytes = encodeMessage(makeMessage("T", TransformContent{}));
  bytes.push_back(0);
  refreshCrc(bytes);
  expectFormatError([&] { decodeMessage(bytes); }, "48 bytes");
  auto pos = encodeMessage(makeMessage("P", PositionContent{}));
  pos.resize(pos.size() - 2);
  refreshCrc(pos);
  expectFormatError([&] { decodeMessage(pos); }, "POSITION");
  TrackingDataContent t;
  t.elements.resize(2);
  auto td = encodeMessage(makeMessage("T", t));
  td.pop_back();
  refreshCrc(td);
  expectFormatError([&] { decodeMessage(td); }, "70-byte");
}

TEST(CorruptInput, ImageSizeFieldsDisagreeWithData) {
  ImageContent im;
  im.resizeWhole({4, 3, 2});
  const auto good = encodeMessage(makeMessage("US", im));
  {
    auto b = good;  // size of i axis doubled: sub-volume still inside, data too short
    putU16(b, kHeaderSize + 6, 8);
    putU16(b, kHeaderSize + 66, 8);
    refreshCrc(b);
    expectFormatError([&] { decodeMessage(b); }, "pixel bytes");
  }
  {
    auto b = good;  // sub-volume outside the volume
    putU16(b, kHeaderSize + 60, 3);
    refreshCrc(b);
    expectFormatError([&] { decodeMessage(b); }, "subvol");
  }
  {
    auto b = good;  // unknown scalar type
    b[kHeaderSize + 3] = 9;
    refreshCrc(b);
    expectFormatError([&] { decodeMessage(b); }, "scalar_type");
  }
  {
    auto b = good;  // truncated inside the image header
    b.resize(kHeaderSize + 40);
    refreshCrc(b);
    expectFormatError([&] { decodeMessage(b); }, "matrix");
  }
  {
    auto b = good;  // 65535^3 voxels claimed: refused without allocating
    for (int a = 0; a < 3; ++a) {
      putU16(b, kHeaderSize + 6 + 2 * static_cast<std::size_t>(a), 65535);
      putU16(b, kHeaderSize + 66 + 2 * static_cast<std::size_t>(a), 65535);
    }
    refreshCrc(b);
    expectFormatError([&] { decodeMessage(b); }, "pixel bytes");
  }
}

TEST(CorruptInput, PolyDataIndexOutOfRange) {
  auto b = encodeMessage(makeMessage("M", triangle()));
  // Header 40 + 3 points (36) + polygon count word (4): the first index.
  putU32(b, kHeaderSize + 40 + 36 + 4 + 8, 3);
  refreshCrc(b);
  expectFormatError([&] { decodeMessage(b); }, "beyond the 3 points");
}

TEST(CorruptInput, PolyDataCountsThatOverflowOrDisagree) {
  const auto good = encodeMessage(makeMessage("M", triangle()));
  {
    auto b = good;  // npoints so large that 12 * npoints overflows 32 bits
    putU32(b, kHeaderSize, 0x40000000);
    refreshCrc(b);
    expectFormatError([&] { decodeMessage(b); }, "points");
  }
  {
    auto b = good;  // npolygons far beyond what size_polygons can hold
    putU32(b, kHeaderSize + 20, 0xFFFFFFFF);
    refreshCrc(b);
    expectFormatError([&] { decodeMessage(b); }, "npolygons");
  }
  {
    auto b = good;  // size_polygons not a multiple of 4
    putU32(b, kHeaderSize + 24, 15);
    refreshCrc(b);
    expectFormatError([&] { decodeMessage(b); }, "size_polygons");
  }
  {
    auto b = good;  // a cell claiming 2^32-1 corners
    putU32(b, kHeaderSize + 40 + 36, 0xFFFFFFFF);
    refreshCrc(b);
    expectFormatError([&] { decodeMessage(b); }, "size_polygons");
  }
  {
    auto b = good;  // 2^32-1 attributes with no bytes for them
    putU32(b, kHeaderSize + 36, 0xFFFFFFFF);
    refreshCrc(b);
    expectFormatError([&] { decodeMessage(b); }, "nattributes");
  }
}

TEST(CorruptInput, PolyDataCellThatLeavesNoRoomForTheNextCount) {
  // Found by fuzz_igtlink_decoder: three triangles on four points take 12 words;
  // a first cell claiming 10 corners (all valid indices) used to be accepted and
  // written past the 9-index array (visible under AddressSanitizer).
  PolyDataContent p;
  p.points.resize(4, 3);
  p.points.setZero();
  p.polygons.add({0, 1, 2});
  p.polygons.add({1, 2, 3});
  p.polygons.add({2, 3, 0});
  auto b = encodeMessage(makeMessage("M", p));
  putU32(b, kHeaderSize + 40 + 48, 10);
  refreshCrc(b);
  expectFormatError([&] { decodeMessage(b); }, "cell 0 claims 10 points");
}

TEST(CorruptInput, PolyDataAttributeProblems) {
  PolyDataContent p = triangle();
  PolyDataAttribute a;
  a.kind = AttributeKind::kNormal;
  a.name = "N";
  a.data = Eigen::MatrixXd::Zero(3, 3);
  p.attributes.push_back(a);
  const auto good = encodeMessage(makeMessage("M", p));
  const std::size_t att = kHeaderSize + 40 + 36 + 16;
  {
    auto b = good;  // normals must have 3 components
    b[att + 1] = 4;
    refreshCrc(b);
    expectFormatError([&] { decodeMessage(b); }, "ncomponents");
  }
  {
    auto b = good;  // count of values beyond the data
    putU32(b, att + 2, 1000000);
    refreshCrc(b);
    expectFormatError([&] { decodeMessage(b); }, "attribute data");
  }
  {
    auto b = good;  // unknown attribute type
    b[att] = 0x25;
    refreshCrc(b);
    expectFormatError([&] { decodeMessage(b); }, "attribute type");
  }
  {
    auto b = good;  // name without NUL: overwrite NUL and the padding, data follows
    b.resize(att + 6 + 1);
    refreshCrc(b);
    expectFormatError([&] { decodeMessage(b); }, "attribute name");
  }
}

TEST(CorruptInput, StringLengthBeyondBody) {
  auto b = encodeMessage(makeMessage("S", StringContent{kEncodingUtf8, "hello"}));
  putU16(b, kHeaderSize + 2, 6);
  refreshCrc(b);
  expectFormatError([&] { decodeMessage(b); }, "length");
  auto extra = encodeMessage(makeMessage("S", StringContent{kEncodingUtf8, "hello"}));
  extra.push_back('!');
  refreshCrc(extra);
  expectFormatError([&] { decodeMessage(extra); }, "unexpected bytes");
}

TEST(CorruptInput, StatusWithoutTerminatorOrTrailingBytes) {
  auto b = encodeMessage(makeMessage("S", StatusContent{1, 0, "", "ok"}));
  b.back() = 'x';  // NUL replaced
  refreshCrc(b);
  expectFormatError([&] { decodeMessage(b); }, "status_message");
  auto t = encodeMessage(makeMessage("S", StatusContent{1, 0, "", "ok"}));
  t.push_back('x');
  refreshCrc(t);
  expectFormatError([&] { decodeMessage(t); }, "unexpected bytes");
}

TEST(CorruptInput, MetadataSizesInconsistent) {
  Message m = makeMessage("S", StringContent{kEncodingUsAscii, "x"});
  m.metadata = {{"key", kEncodingUsAscii, "value"}};
  const auto good = encodeMessage(m, HeaderVersion::kV2);
  const std::size_t metadata_header = kHeaderSize + 12 + 5;  // after the extended header and "x" (4 + 1 bytes)
  ASSERT_EQ(good.size(), metadata_header + 10 + 8);
  {
    auto b = good;  // metadata_size larger than the body
    putU32(b, kHeaderSize + 4, 1000);
    refreshCrc(b);
    expectFormatError([&] { decodeMessage(b); }, "metadata_header_size + metadata_size");
  }
  {
    auto b = good;  // an entry's value_size disagrees with metadata_size (8 bytes)
    putU32(b, metadata_header + 4, 4);
    refreshCrc(b);
    expectFormatError([&] { decodeMessage(b); }, "metadata_size");
  }
  {
    auto b = good;  // index_count disagrees with metadata_header_size
    putU16(b, metadata_header, 2);
    refreshCrc(b);
    expectFormatError([&] { decodeMessage(b); }, "index_count");
  }
  {
    auto b = good;  // extended header size below 12
    putU16(b, kHeaderSize, 8);
    refreshCrc(b);
    expectFormatError([&] { decodeMessage(b); }, "extended_header_size");
  }
  {
    auto b = good;  // extended header size beyond the body
    putU16(b, kHeaderSize, 60000);
    refreshCrc(b);
    expectFormatError([&] { decodeMessage(b); }, "extended_header_size");
  }
  {
    auto b = good;  // body shorter than the extended header
    b.resize(kHeaderSize + 5);
    refreshCrc(b);
    expectFormatError([&] { decodeMessage(b); }, "metadata_size");
  }
}

TEST(CorruptInput, EncoderRefusesContentThatDoesNotFit) {
  EXPECT_THROW(encodeMessage(makeMessage("STRING", "S", TransformContent{})), InvalidArgumentError);
  Message m = makeMessage("S", StringContent{});
  m.metadata = {{"k", 3, "v"}};
  EXPECT_THROW(encodeMessage(m, HeaderVersion::kV1), InvalidArgumentError);
  ImageContent im;
  im.resizeWhole({2, 2, 1});
  im.pixels.pop_back();
  EXPECT_THROW(encodeMessage(makeMessage("I", im)), InvalidArgumentError);
  PolyDataContent p = triangle();
  p.polygons.indices[1] = 7;
  EXPECT_THROW(encodeMessage(makeMessage("M", p)), InvalidArgumentError);
  EXPECT_THROW(encodeMessage(makeMessage("S", StringContent{3, std::string(70000, 'a')})), InvalidArgumentError);
  PointContent pc;
  pc.points.push_back({});
  pc.points[0].name = std::string(65, 'n');
  EXPECT_THROW(encodeMessage(makeMessage("P", pc)), InvalidArgumentError);
}

TEST(CorruptInput, EverySingleByteFlipEitherDecodesOrThrowsFormatError) {
  // Without the CRC the decoders see every corruption of every field.
  PolyDataContent p = triangle();
  p.lines.add({0, 1});
  p.attributes.push_back({AttributeKind::kScalar, true, "s", Eigen::MatrixXd::Ones(2, 1)});
  Message m = makeMessage("M", p);
  m.metadata = {{"k", 3, "v"}};
  const std::vector<std::vector<std::uint8_t>> samples = {
      encodeMessage(m, HeaderVersion::kV2), encodeMessage(makeMessage("S", StatusContent{2, 3, "E", "msg"})),
      encodeMessage(makeMessage("I", [] {
        ImageContent im;
        im.resizeWhole({3, 2, 1});
        return im;
      }()))};
  DecodeOptions options;
  options.verify_crc = false;
  for (const auto& good : samples) {
    for (std::size_t i = 0; i < good.size(); ++i) {
      for (const std::uint8_t v : {std::uint8_t{0x00}, std::uint8_t{0xFF}, std::uint8_t{0x7F}}) {
        auto b = good;
        b[i] = v;
        try {
          decodeMessage(b, options);
        } catch (const FormatError&) {
        }
      }
    }
  }
}

}  // namespace
}  // namespace mrsns::igtlink
