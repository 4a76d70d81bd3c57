// The OpenIGTLink library's own test messages (shared data): each decodes,
// its fields are as the library's tests wrote them, and re-encoding gives the
// same bytes, CRC included.
#include <gtest/gtest.h>

#include "igtlink_test_util.h"
#include "mrsns/igtlink/codec.h"
#include "mrsns/igtlink/crc64.h"
#include "test_data.h"

namespace mrsns::igtlink {
namespace {

using test::readBytes;

std::vector<std::uint8_t> loadReference(const std::filesystem::path& path) {
  auto bytes = readBytes(path);
  const std::string name = path.filename().string();
  const auto at = name.find("_header.bin");
  if (at != std::string::npos) {
    const auto body = readBytes(path.parent_path() / (name.substr(0, at) + "_body.bin"));
    bytes.insert(bytes.end(), body.begin(), body.end());
  }
  return bytes;
}

#define LOAD_REFERENCE(var, file)                  \
  MRSNS_REQUIRE_DATA(var##_path, "igtlink/" file); \
  const std::vector<std::uint8_t> var = loadReference(var##_path)

void expectReencodesExactly(const std::vector<std::uint8_t>& bytes, const Message& m) {
  const auto again = encodeMessage(m, static_cast<HeaderVersion>(m.header.version));
  ASSERT_EQ(again.size(), bytes.size());
  EXPECT_TRUE(again == bytes) << "re-encoded bytes differ from the reference";
}

TEST(ReferenceMessages, EveryFileDecodesAndReencodesByteForByte) {
  MRSNS_REQUIRE_DATA(dir, "igtlink/README.md");
  int count = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir.parent_path())) {
    const std::string name = entry.path().filename().string();
    if (entry.path().extension() != ".bin" || name.find("_body.bin") != std::string::npos) continue;
    SCOPED_TRACE(name);
    const auto bytes = loadReference(entry.path());
    const Message m = decodeMessage(bytes);
    EXPECT_EQ(m.header.body_size + kHeaderSize, bytes.size());
    EXPECT_EQ(crc64(std::span<const std::uint8_t>(bytes).subspan(kHeaderSize)), m.header.crc);
    EXPECT_EQ(m.content.index(), contentIndexForType(m.header.type)) << m.header.type;
    expectReencodesExactly(bytes, m);
    ++count;
  }
  EXPECT_EQ(count, 23);  // 25 files, two of them bodies of a split message
}

TEST(ReferenceMessages, Transform) {
  LOAD_REFERENCE(bytes, "transform__test_transform_message.bin");
  const Message m = decodeMessage(bytes);
  EXPECT_EQ(m.header.version, 1);
  EXPECT_EQ(m.header.type, "TRANSFORM");
  EXPECT_EQ(m.header.device_name, "DeviceName");
  EXPECT_EQ(m.header.timestamp, 1234567892u);  // the library's test stamps 0 s + fraction 1234567892
  const auto* t = m.as<TransformContent>();
  ASSERT_NE(t, nullptr);
  // Column-major 3x4 on the wire: the first three floats are the first column.
  EXPECT_NEAR(t->matrix(0, 0), -0.954892, 1e-6);
  EXPECT_NEAR(t->matrix(1, 0), 0.196632, 1e-6);
  EXPECT_NEAR(t->matrix(2, 0), -0.222525, 1e-6);
  EXPECT_NEAR(t->matrix(0, 3), 46.0531, 1e-4);
  EXPECT_NEAR(t->matrix(1, 3), 19.4709, 1e-4);
  EXPECT_NEAR(t->matrix(2, 3), 46.0531, 1e-4);
  // A rotation within float32 rounding of the printed values (6 digits).
  const Eigen::Matrix3d r = t->matrix.topLeftCorner<3, 3>();
  EXPECT_LT((r.transpose() * r - Eigen::Matrix3d::Identity()).norm(), 1e-5);
  EXPECT_NEAR(std::abs(r.determinant()), 1.0, 1e-5);
}

TEST(ReferenceMessages, TransformVersion2WithMetadata) {
  LOAD_REFERENCE(bytes, "transformFormat2__test_transform_message_Format2.bin");
  LOAD_REFERENCE(v1, "transform__test_transform_message.bin");
  const Message m = decodeMessage(bytes);
  EXPECT_EQ(m.header.version, 2);
  EXPECT_EQ(m.extended.extended_header_size, 12);
  EXPECT_EQ(m.extended.metadata_header_size, 18);
  EXPECT_EQ(m.extended.metadata_size, 39u);
  EXPECT_EQ(m.extended.message_id, 1u);
  ASSERT_EQ(m.metadata.size(), 2u);
  EXPECT_EQ(m.metadata[0], (MetadataEntry{"First patient age", kEncodingUsAscii, "22"}));
  EXPECT_EQ(m.metadata[1], (MetadataEntry{"Second patient age", kEncodingUsAscii, "25"}));
  EXPECT_EQ(m.metadataValue("Second patient age"), "25");
  EXPECT_FALSE(m.metadataValue("missing"));
  // Same content as the version-1 message.
  EXPECT_EQ(m.as<TransformContent>()->matrix, decodeMessage(v1).as<TransformContent>()->matrix);
}

TEST(ReferenceMessages, PositionBothVersions) {
  LOAD_REFERENCE(bytes, "position__test_position_message.bin");
  LOAD_REFERENCE(bytes2, "positionFormat2__test_position_messageFormat2.bin");
  for (const auto* b : {&bytes, &bytes2}) {
    const auto m = decodeMessage(*b);
    const auto* p = m.as<PositionContent>();
    ASSERT_NE(p, nullptr);
    EXPECT_EQ(p->quaternion_components, 4);
    EXPECT_NEAR(p->position.x(), 46.0531, 1e-4);
    EXPECT_NEAR(p->position.y(), 19.4709, 1e-4);
    EXPECT_NEAR(p->position.z(), 46.0531, 1e-4);
    EXPECT_EQ(p->orientation.x(), 0.0);
    EXPECT_NEAR(p->orientation.y(), 0.5773503, 1e-6);
    EXPECT_NEAR(p->orientation.z(), 0.5773503, 1e-6);
    EXPECT_NEAR(p->orientation.w(), 0.3333333, 1e-6);
  }
}

TEST(ReferenceMessages, TrackingDataBothVersions) {
  LOAD_REFERENCE(bytes, "tdata__test_tdata_message.bin");
  LOAD_REFERENCE(bytes2, "tdataFormat2__test_tdata_messageFormat2.bin");
  for (const auto* b : {&bytes, &bytes2}) {
    const auto m = decodeMessage(*b);
    const auto* t = m.as<TrackingDataContent>();
    ASSERT_NE(t, nullptr);
    ASSERT_EQ(t->elements.size(), 3u);
    EXPECT_EQ(t->elements[0].name, "Tracker0");
    EXPECT_EQ(t->elements[2].name, "Tracker2");
    EXPECT_EQ(t->elements[0].type, static_cast<std::uint8_t>(TrackingInstrumentType::k6D));
    EXPECT_NEAR(t->elements[1].matrix(0, 0), -0.954892, 1e-6);
    EXPECT_NEAR(t->elements[1].matrix(2, 3), 46.0531, 1e-4);
  }
}

TEST(ReferenceMessages, Image) {
  LOAD_REFERENCE(bytes, "image__test_image_message.bin");
  const auto m = decodeMessage(bytes);
  const auto* im = m.as<ImageContent>();
  ASSERT_NE(im, nullptr);
  EXPECT_EQ(im->image_header_version, 1);
  EXPECT_EQ(im->components, 1);
  EXPECT_EQ(im->scalar_type, ScalarType::kUint8);
  EXPECT_EQ(im->endian, PixelEndian::kLittle);
  EXPECT_EQ(im->coordinate, ImageCoordinate::kRas);
  EXPECT_EQ(im->size, (std::array<std::uint16_t, 3>{50, 50, 1}));
  EXPECT_EQ(im->subvolume_size, im->size);
  EXPECT_EQ(im->subvolume_offset, (std::array<std::uint16_t, 3>{0, 0, 0}));
  EXPECT_EQ(im->pixels.size(), 2500u);
  EXPECT_NEAR(im->origin().y(), 19.4709, 1e-4);
  // The library's test image has unit spacing and a rotation as orientation.
  EXPECT_TRUE(im->spacing().isApprox(Eigen::Vector3d::Ones(), 1e-5)) << im->spacing().transpose();
}

TEST(ReferenceMessages, PolyData) {
  LOAD_REFERENCE(bytes, "polydata__test_polydata_message_header.bin");
  const auto m = decodeMessage(bytes);
  const auto* p = m.as<PolyDataContent>();
  ASSERT_NE(p, nullptr);
  // A unit cube: 8 points, 6 quadrilateral faces, one scalar attribute of 8 values.
  EXPECT_EQ(p->points.rows(), 8);
  EXPECT_EQ(p->points.row(6), Eigen::RowVector3d(1, 1, 1));
  EXPECT_EQ(p->polygons.size(), 6u);
  for (std::size_t c = 0; c < 6; ++c) EXPECT_EQ(p->polygons.cell(c).size(), 4u);
  EXPECT_EQ(std::vector<std::uint32_t>(p->polygons.cell(0).begin(), p->polygons.cell(0).end()),
            (std::vector<std::uint32_t>{0, 1, 2, 3}));
  EXPECT_TRUE(p->vertices.empty());
  EXPECT_TRUE(p->lines.empty());
  EXPECT_TRUE(p->triangle_strips.empty());
  ASSERT_EQ(p->attributes.size(), 1u);
  EXPECT_EQ(p->attributes[0].name, "attr");
  EXPECT_EQ(p->attributes[0].kind, AttributeKind::kScalar);
  EXPECT_FALSE(p->attributes[0].cell_data);
  ASSERT_EQ(p->attributes[0].data.rows(), 8);
  EXPECT_EQ(p->attributes[0].data(7, 0), 7.0);
}

TEST(ReferenceMessages, StringStatusPointCapability) {
  LOAD_REFERENCE(str, "string__test_string_message.bin");
  LOAD_REFERENCE(status, "status__test_status_message.bin");
  LOAD_REFERENCE(point, "point__test_point_message.bin");
  LOAD_REFERENCE(capability, "capability__test_capability_message.bin");
  const auto s = decodeMessage(str);
  EXPECT_EQ(s.as<StringContent>()->encoding, kEncodingUsAscii);
  EXPECT_EQ(s.as<StringContent>()->text, "Welcome to OpenIGTLink");

  const auto st = decodeMessage(status);
  const auto* sc = st.as<StatusContent>();
  ASSERT_NE(sc, nullptr);
  EXPECT_EQ(sc->code, static_cast<std::uint16_t>(StatusCode::kDisabled));
  EXPECT_EQ(sc->subcode, 10);
  EXPECT_EQ(sc->error_name, "ACTUATOR_DISABLED");
  EXPECT_EQ(sc->message, "Actuator A is disabled.");

  const auto pt = decodeMessage(point);
  const auto* pc = pt.as<PointContent>();
  ASSERT_NE(pc, nullptr);
  ASSERT_EQ(pc->points.size(), 3u);
  EXPECT_EQ(pc->points[0].name, "POINT_DESCRIPTION_0");
  EXPECT_EQ(pc->points[0].group, "Landmark");
  EXPECT_EQ(pc->points[0].rgba, (std::array<std::uint8_t, 4>{255, 0, 0, 255}));
  EXPECT_EQ(pc->points[0].position, Eigen::Vector3d(10, 15, 20));
  EXPECT_EQ(pc->points[0].radius, 5.0);
  EXPECT_EQ(pc->points[0].owner, "IMAGE_0");

  const auto cap = decodeMessage(capability);
  EXPECT_EQ(cap.as<CapabilityContent>()->types,
            (std::vector<std::string>{"IMAGE", "GET_IMAGE", "TRANSFORM", "GET_TRANS"}));
}

TEST(ReferenceMessages, UnknownTypesStayRawAndVersion2WithoutMetadata) {
  LOAD_REFERENCE(video, "videometa__test_videometa_message.bin");
  LOAD_REFERENCE(command, "command__test_command_message.bin");
  const auto v = decodeMessage(video);
  EXPECT_EQ(v.header.type, "VIDEOMETA");
  EXPECT_EQ(v.extended.metadata_header_size, 2);  // index_count only
  EXPECT_TRUE(v.metadata.empty());
  ASSERT_NE(v.as<RawContent>(), nullptr);
  EXPECT_EQ(v.as<RawContent>()->bytes.size(), 980u - 12 - 2);
  const auto c = decodeMessage(command);
  EXPECT_EQ(c.header.device_name, "");
  ASSERT_NE(c.as<RawContent>(), nullptr);
  EXPECT_EQ(c.as<RawContent>()->bytes.size(), 164u);
}

}  // namespace
}  // namespace mrsns::igtlink
