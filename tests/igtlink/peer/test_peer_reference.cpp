// The reference messages decoded by our codec and by libopenigtlink 1.11 from
// the same bytes must agree field by field.
#include <gtest/gtest.h>
#include <igtlCapabilityMessage.h>
#include <igtlImageMessage.h>
#include <igtlPointMessage.h>
#include <igtlPolyDataMessage.h>
#include <igtlPositionMessage.h>
#include <igtlStatusMessage.h>
#include <igtlStringMessage.h>
#include <igtlTrackingDataMessage.h>
#include <igtlTransformMessage.h>

#include "../igtlink_test_util.h"
#include "mrsns/igtlink/codec.h"
#include "peer_util.h"
#include "test_data.h"

namespace mrsns::igtlink {
namespace {

using peer::peerDecode;

std::vector<std::uint8_t> load(const std::filesystem::path& path) {
  auto bytes = test::readBytes(path);
  const std::string name = path.filename().string();
  const auto at = name.find("_header.bin");
  if (at != std::string::npos) {
    const auto body = test::readBytes(path.parent_path() / (name.substr(0, at) + "_body.bin"));
    bytes.insert(bytes.end(), body.begin(), body.end());
  }
  return bytes;
}

#define LOAD(var, file)                            \
  MRSNS_REQUIRE_DATA(var##_path, "igtlink/" file); \
  const std::vector<std::uint8_t> var = load(var##_path)

void expectHeadersAgree(const Message& ours, igtl::MessageBase* theirs) {
  EXPECT_EQ(ours.header.device_name, theirs->GetDeviceName());
  EXPECT_EQ(ours.header.type, theirs->GetDeviceType());
  unsigned int sec = 0;
  unsigned int frac = 0;
  theirs->GetTimeStamp(&sec, &frac);
  EXPECT_EQ(ours.header.timestamp >> 32, sec);
  // The peer keeps nanoseconds and converts back, so the fraction agrees to ~1 ns (4.3 ticks of 2^-32 s).
  EXPECT_NEAR(static_cast<double>(ours.header.timestamp & 0xFFFFFFFFu), static_cast<double>(frac), 5.0);
}

void expectMatrixAgrees(const Eigen::Matrix4d& ours, igtl::Matrix4x4& theirs) {
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) EXPECT_EQ(ours(r, c), static_cast<double>(theirs[r][c])) << r << "," << c;
}

TEST(PeerReference, Transform) {
  LOAD(bytes, "transform__test_transform_message.bin");
  const Message ours = decodeMessage(bytes);
  int status = 0;
  auto theirs = peerDecode<igtl::TransformMessage>(bytes, status);
  ASSERT_TRUE(status & igtl::MessageHeader::UNPACK_BODY);
  expectHeadersAgree(ours, theirs);
  igtl::Matrix4x4 m;
  theirs->GetMatrix(m);
  expectMatrixAgrees(ours.as<TransformContent>()->matrix, m);
}

TEST(PeerReference, Position) {
  LOAD(bytes, "position__test_position_message.bin");
  const Message ours = decodeMessage(bytes);
  int status = 0;
  auto theirs = peerDecode<igtl::PositionMessage>(bytes, status);
  ASSERT_TRUE(status & igtl::MessageHeader::UNPACK_BODY);
  float pos[3];
  float quat[4];
  theirs->GetPosition(pos);
  theirs->GetQuaternion(quat);
  const auto* p = ours.as<PositionContent>();
  for (int i = 0; i < 3; ++i) EXPECT_EQ(p->position[i], pos[i]);
  EXPECT_EQ(p->orientation.x(), quat[0]);
  EXPECT_EQ(p->orientation.y(), quat[1]);
  EXPECT_EQ(p->orientation.z(), quat[2]);
  EXPECT_EQ(p->orientation.w(), quat[3]);
}

TEST(PeerReference, TrackingData) {
  LOAD(bytes, "tdata__test_tdata_message.bin");
  const Message ours = decodeMessage(bytes);
  int status = 0;
  auto theirs = peerDecode<igtl::TrackingDataMessage>(bytes, status);
  ASSERT_TRUE(status & igtl::MessageHeader::UNPACK_BODY);
  const auto* t = ours.as<TrackingDataContent>();
  ASSERT_EQ(static_cast<int>(t->elements.size()), theirs->GetNumberOfTrackingDataElements());
  for (int i = 0; i < theirs->GetNumberOfTrackingDataElements(); ++i) {
    igtl::TrackingDataElement::Pointer e;
    theirs->GetTrackingDataElement(i, e);
    const auto& mine = t->elements[static_cast<std::size_t>(i)];
    EXPECT_EQ(mine.name, e->GetName());
    EXPECT_EQ(mine.type, e->GetType());
    igtl::Matrix4x4 m;
    e->GetMatrix(m);
    expectMatrixAgrees(mine.matrix, m);
  }
}

TEST(PeerReference, Image) {
  LOAD(bytes, "image__test_image_message.bin");
  const Message ours = decodeMessage(bytes);
  int status = 0;
  auto theirs = peerDecode<igtl::ImageMessage>(bytes, status);
  ASSERT_TRUE(status & igtl::MessageHeader::UNPACK_BODY);
  expectHeadersAgree(ours, theirs);
  const auto* im = ours.as<ImageContent>();
  int dims[3];
  int sub[3];
  int off[3];
  theirs->GetDimensions(dims);
  theirs->GetSubVolume(sub, off);
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(im->size[static_cast<std::size_t>(a)], dims[a]);
    EXPECT_EQ(im->subvolume_size[static_cast<std::size_t>(a)], sub[a]);
    EXPECT_EQ(im->subvolume_offset[static_cast<std::size_t>(a)], off[a]);
  }
  EXPECT_EQ(static_cast<int>(im->scalar_type), theirs->GetScalarType());
  EXPECT_EQ(static_cast<int>(im->endian), theirs->GetEndian());
  EXPECT_EQ(static_cast<int>(im->coordinate), theirs->GetCoordinateSystem());
  EXPECT_EQ(im->components, theirs->GetNumComponents());
  float spacing[3];
  float origin[3];
  theirs->GetSpacing(spacing);
  theirs->GetOrigin(origin);
  // The peer derives spacing from the float matrix in float arithmetic.
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(im->spacing()[a], spacing[a], 1e-6);
    EXPECT_EQ(im->origin()[a], origin[a]);
  }
  ASSERT_EQ(static_cast<int>(im->pixels.size()), theirs->GetSubVolumeImageSize());
  EXPECT_EQ(0, std::memcmp(im->pixels.data(), theirs->GetScalarPointer(), im->pixels.size()));
}

TEST(PeerReference, PolyData) {
  LOAD(bytes, "polydata__test_polydata_message_header.bin");
  const Message ours = decodeMessage(bytes);
  int status = 0;
  auto theirs = peerDecode<igtl::PolyDataMessage>(bytes, status);
  ASSERT_TRUE(status & igtl::MessageHeader::UNPACK_BODY);
  const auto* p = ours.as<PolyDataContent>();
  auto points = theirs->GetPoints();
  ASSERT_EQ(p->points.rows(), points->GetNumberOfPoints());
  for (int i = 0; i < points->GetNumberOfPoints(); ++i) {
    float xyz[3];
    points->GetPoint(static_cast<unsigned>(i), xyz);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(p->points(i, k), xyz[k]);
  }
  auto polygons = theirs->GetPolygons();
  ASSERT_EQ(p->polygons.size(), polygons->GetNumberOfCells());
  for (unsigned c = 0; c < polygons->GetNumberOfCells(); ++c) {
    std::vector<igtlUint32> cell(polygons->GetCellSize(c));
    polygons->GetCell(c, cell.data());
    EXPECT_EQ(std::vector<std::uint32_t>(p->polygons.cell(c).begin(), p->polygons.cell(c).end()),
              std::vector<std::uint32_t>(cell.begin(), cell.end()));
  }
  ASSERT_EQ(static_cast<int>(p->attributes.size()), theirs->GetNumberOfAttributes());
  auto* att = theirs->GetAttribute(0);
  EXPECT_EQ(p->attributes[0].name, att->GetName());
  EXPECT_EQ(static_cast<std::uint32_t>(p->attributes[0].data.rows()), att->GetSize());
  std::vector<float> values(att->GetSize() * att->GetNumberOfComponents());
  att->GetData(values.data());
  for (std::size_t i = 0; i < values.size(); ++i) EXPECT_EQ(p->attributes[0].data.data()[i], values[i]);
}

TEST(PeerReference, StringStatusPointCapability) {
  LOAD(str, "string__test_string_message.bin");
  LOAD(status_bytes, "status__test_status_message.bin");
  LOAD(point, "point__test_point_message.bin");
  LOAD(capability, "capability__test_capability_message.bin");
  int status = 0;
  auto s = peerDecode<igtl::StringMessage>(str, status);
  ASSERT_TRUE(status & igtl::MessageHeader::UNPACK_BODY);
  const Message our_string = decodeMessage(str);
  EXPECT_EQ(our_string.as<StringContent>()->text, s->GetString());
  EXPECT_EQ(our_string.as<StringContent>()->encoding, s->GetEncoding());

  auto st = peerDecode<igtl::StatusMessage>(status_bytes, status);
  ASSERT_TRUE(status & igtl::MessageHeader::UNPACK_BODY);
  const auto ours = decodeMessage(status_bytes);
  EXPECT_EQ(ours.as<StatusContent>()->code, st->GetCode());
  EXPECT_EQ(ours.as<StatusContent>()->subcode, st->GetSubCode());
  EXPECT_EQ(ours.as<StatusContent>()->error_name, st->GetErrorName());
  EXPECT_EQ(ours.as<StatusContent>()->message, st->GetStatusString());

  auto pt = peerDecode<igtl::PointMessage>(point, status);
  ASSERT_TRUE(status & igtl::MessageHeader::UNPACK_BODY);
  const Message our_point = decodeMessage(point);
  const auto* pc = our_point.as<PointContent>();
  ASSERT_EQ(static_cast<int>(pc->points.size()), pt->GetNumberOfPointElement());
  for (int i = 0; i < pt->GetNumberOfPointElement(); ++i) {
    igtl::PointElement::Pointer e;
    pt->GetPointElement(i, e);
    const auto& mine = pc->points[static_cast<std::size_t>(i)];
    EXPECT_EQ(mine.name, e->GetName());
    EXPECT_EQ(mine.group, e->GetGroupName());
    EXPECT_EQ(mine.owner, e->GetOwner());
    igtlUint8 rgba[4];
    e->GetRGBA(rgba);
    for (int k = 0; k < 4; ++k) EXPECT_EQ(mine.rgba[static_cast<std::size_t>(k)], rgba[k]);
    float xyz[3];
    e->GetPosition(xyz);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(mine.position[k], xyz[k]);
    EXPECT_EQ(mine.radius, e->GetRadius());
  }

  auto cap = peerDecode<igtl::CapabilityMessage>(capability, status);
  ASSERT_TRUE(status & igtl::MessageHeader::UNPACK_BODY);
  const Message our_capability = decodeMessage(capability);
  EXPECT_EQ(our_capability.as<CapabilityContent>()->types, cap->GetTypes());
}

TEST(PeerReference, Version2MessagesAreMisreadByThePeer) {
  // libopenigtlink 1.11 knows header v1 only: given a v2 TRANSFORM it either
  // reads the extended header as the first matrix elements or refuses the
  // body; never the real content. Our codec reads the same bytes correctly
  // (checked against the v1 twin).
  LOAD(v2, "transformFormat2__test_transform_message_Format2.bin");
  LOAD(v1, "transform__test_transform_message.bin");
  const Message ours = decodeMessage(v2);
  const Message ours_v1 = decodeMessage(v1);
  EXPECT_EQ(ours.as<TransformContent>()->matrix, ours_v1.as<TransformContent>()->matrix);
  int status = 0;
  auto theirs = peerDecode<igtl::TransformMessage>(v2, status);
  igtl::Matrix4x4 m;
  theirs->GetMatrix(m);
  bool same = true;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) same = same && ours.as<TransformContent>()->matrix(r, c) == m[r][c];
  // Observed: run alone, Unpack reports UNPACK_BODY and m[0][0] holds the bytes 00 0C 00 12
  // (extended_header_size 12, metadata_header_size 18) read as a float; after other messages
  // were unpacked in the same process it returns 0 (refused) and leaves the identity matrix.
  EXPECT_FALSE(same && (status & igtl::MessageHeader::UNPACK_BODY))
      << "libopenigtlink 1.11 decoded a v2 message correctly; update the documentation";
  if (status & igtl::MessageHeader::UNPACK_BODY) {
    const std::uint32_t ext_bits = 0x000C0012u;
    float ext_as_float = 0.0f;
    std::memcpy(&ext_as_float, &ext_bits, 4);
    EXPECT_EQ(m[0][0], ext_as_float);
  }
}

}  // namespace
}  // namespace mrsns::igtlink
