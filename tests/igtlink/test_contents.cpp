// Content-level behaviour: image geometry helpers, POLYDATA <-> TriangleMesh,
// version-2 metadata.
#include <gtest/gtest.h>

#include "mrsns/core/error.h"
#include "mrsns/igtlink/codec.h"
#include "mrsns/igtlink/polydata_mesh.h"

namespace mrsns::igtlink {
namespace {

TEST(Image, GeometryHelpersSplitTheWireMatrix) {
  ImageContent im;
  const Eigen::Matrix3d dir = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  im.setGeometry({0.5, 0.25, 2.0}, dir, {10, 20, 30});
  EXPECT_TRUE(im.spacing().isApprox(Eigen::Vector3d(0.5, 0.25, 2.0), 1e-12));
  EXPECT_TRUE(im.direction().isApprox(dir, 1e-12));
  EXPECT_EQ(im.origin(), Eigen::Vector3d(10, 20, 30));
  im.scalar_type = ScalarType::kInt16;
  im.components = 3;
  im.resizeWhole({5, 4, 3});
  EXPECT_EQ(im.pixels.size(), 5u * 4 * 3 * 3 * 2);
  const auto back = decodeImage([&] {
    std::vector<std::uint8_t> b;
    encodeImage(im, b);
    return b;
  }());
  // Spacing survives float32 to within its relative precision.
  EXPECT_TRUE(back.spacing().isApprox(im.spacing(), 1e-7));
}

TEST(Image, SubVolumeUpdate) {
  ImageContent im;
  im.size = {100, 80, 10};
  im.subvolume_offset = {10, 20, 5};
  im.subvolume_size = {90, 60, 5};
  im.pixels.assign(90 * 60 * 5, 7);
  std::vector<std::uint8_t> b;
  encodeImage(im, b);
  EXPECT_EQ(b.size(), kImageHeaderSize + im.pixels.size());
  const auto back = decodeImage(b);
  EXPECT_EQ(back.subvolume_offset, im.subvolume_offset);
  EXPECT_EQ(back.pixels, im.pixels);
}

// Scalars wider than a byte come out little-endian whatever the sender
// used; 8-bit pixels and little-endian data are returned as they are.
TEST(Image, LittleEndianPixelsSwapsBigEndianScalars) {
  ImageContent im;
  im.scalar_type = ScalarType::kInt32;
  im.endian = PixelEndian::kBig;
  im.resizeWhole({2, 1, 1});
  im.pixels = {0x01, 0x02, 0x03, 0x04, 0xff, 0xff, 0xff, 0xfe};
  EXPECT_EQ(im.littleEndianPixels(), (std::vector<std::uint8_t>{0x04, 0x03, 0x02, 0x01, 0xfe, 0xff, 0xff, 0xff}));
  im.endian = PixelEndian::kLittle;
  EXPECT_EQ(im.littleEndianPixels(), im.pixels);
  im.scalar_type = ScalarType::kUint8;
  im.endian = PixelEndian::kBig;
  im.resizeWhole({8, 1, 1});
  im.pixels = {1, 2, 3, 4, 5, 6, 7, 8};
  EXPECT_EQ(im.littleEndianPixels(), im.pixels);
}

TEST(PolyDataMesh, MeshRoundTripKeepsTrianglesNormalsAndColours) {
  TriangleMesh mesh;
  mesh.vertices.resize(4, 3);
  mesh.vertices << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  mesh.faces.resize(4, 3);
  mesh.faces << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
  mesh.normals = mesh.vertices;
  mesh.normals.row(0) = Eigen::RowVector3d(-1, -1, -1).normalized();
  mesh.colors = Eigen::MatrixXd::Constant(4, 3, 0.5);
  const auto msg = decodeMessage(encodeMessage(makeMessage("Tetra", polyDataFromMesh(mesh))));
  const TriangleMesh back = meshFromPolyData(*msg.as<PolyDataContent>());
  EXPECT_EQ(back.faces, mesh.faces);
  EXPECT_TRUE(back.vertices.isApprox(mesh.vertices));
  EXPECT_TRUE(back.normals.isApprox(mesh.normals, 1e-7));
  EXPECT_TRUE(back.colors.isApprox(mesh.colors));
}

TEST(PolyDataMesh, PolygonsAreFannedAndStripsAlternateWinding) {
  PolyDataContent p;
  p.points.resize(5, 3);
  p.points << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 2, 0;
  p.polygons.add({0, 1, 2, 3});
  p.triangle_strips.add({0, 1, 3, 2, 4});
  const TriangleMesh m = meshFromPolyData(p);
  ASSERT_EQ(m.faces.rows(), 2 + 3);
  EXPECT_EQ(m.faces.row(0), Eigen::RowVector3i(0, 1, 2));
  EXPECT_EQ(m.faces.row(1), Eigen::RowVector3i(0, 2, 3));
  EXPECT_EQ(m.faces.row(2), Eigen::RowVector3i(0, 1, 3));
  EXPECT_EQ(m.faces.row(3), Eigen::RowVector3i(1, 2, 3));  // odd triangle flipped
  EXPECT_EQ(m.faces.row(4), Eigen::RowVector3i(3, 2, 4));
  // All strip triangles face the same way (+z) as the fan.
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f) {
    const Eigen::Vector3d a = m.vertices.row(m.faces(f, 0)), b = m.vertices.row(m.faces(f, 1)),
                          c = m.vertices.row(m.faces(f, 2));
    EXPECT_GT((b - a).cross(c - a).z(), 0.0) << f;
  }
  PolyDataContent bad = p;
  bad.polygons.indices[2] = 9;
  EXPECT_THROW(meshFromPolyData(bad), FormatError);
}

TEST(Metadata, Version2CarriesMessageIdAndUtf8Values) {
  Message m = makeMessage("ProbeToTracker", TransformContent{});
  m.extended.message_id = 4242;
  m.metadata = {{"Status", kEncodingUsAscii, "OK"}, {"Patient", kEncodingUtf8, "J\xC3\xBCrgen"}, {"", 3, ""}};
  const auto bytes = encodeMessage(m, HeaderVersion::kV2);
  EXPECT_EQ(bytes.size(), kHeaderSize + 12 + 48 + (2 + 3 * 8) + (6 + 2 + 7 + 7));
  const Message back = decodeMessage(bytes);
  EXPECT_EQ(back.extended.message_id, 4242u);
  EXPECT_EQ(back.extended.metadata_header_size, 2 + 3 * 8);
  EXPECT_EQ(back.metadata, m.metadata);
  EXPECT_EQ(back.metadataValue("Patient"), "J\xC3\xBCrgen");
}

TEST(Metadata, ExtraExtendedHeaderBytesArePreserved) {
  Message m = makeMessage("S", StringContent{kEncodingUsAscii, "abc"});
  m.extended.extra = {9, 8, 7, 6};
  const auto bytes = encodeMessage(m, HeaderVersion::kV2);
  const Message back = decodeMessage(bytes);
  EXPECT_EQ(back.extended.extended_header_size, 16);
  EXPECT_EQ(back.extended.extra, m.extended.extra);
  EXPECT_EQ(back.as<StringContent>()->text, "abc");
  EXPECT_TRUE(encodeMessage(back, HeaderVersion::kV2) == bytes);
}

TEST(Metadata, EmptyMetadataSectionFromOtherSendersIsAccepted) {
  // Some senders write metadata_header_size = 0 (no index_count) when they have no metadata.
  auto bytes = encodeMessage(makeMessage("S", StringContent{kEncodingUsAscii, "abc"}), HeaderVersion::kV2);
  bytes.resize(bytes.size() - 2);  // drop index_count
  bytes[kHeaderSize + 3] = 0;      // metadata_header_size = 0
  DecodeOptions options;
  options.verify_crc = false;
  bytes[42 + 7] = static_cast<std::uint8_t>(bytes.size() - kHeaderSize);
  const auto m = decodeMessage(bytes, options);
  EXPECT_TRUE(m.metadata.empty());
  EXPECT_EQ(m.as<StringContent>()->text, "abc");
}

}  // namespace
}  // namespace mrsns::igtlink
