// Property tests: random messages of every type survive encode -> decode
// unchanged (values are float32-representable, so equality is exact), in
// both header versions, and re-encode to the same bytes.
#include <gtest/gtest.h>

#include "igtlink_test_util.h"
#include "mrsns/igtlink/codec.h"

namespace mrsns::igtlink {
namespace {

void expectSame(const CellArray& a, const CellArray& b) {
  EXPECT_EQ(a.size(), b.size());
  EXPECT_EQ(a.indices, b.indices);
  if (!a.empty()) {
    EXPECT_EQ(a.offsets, b.offsets);
  }
}

void expectSame(const Content& a, const Content& b) {
  ASSERT_EQ(a.index(), b.index());
  std::visit(
      [&b](const auto& x) {
        using T = std::decay_t<decltype(x)>;
        const T& y = std::get<T>(b);
        if constexpr (std::is_same_v<T, TransformContent>) {
          EXPECT_EQ(x.matrix, y.matrix);
        }
        if constexpr (std::is_same_v<T, PositionContent>) {
          EXPECT_EQ(x.position, y.position);
          EXPECT_EQ(x.orientation.coeffs(), y.orientation.coeffs());
        }
        if constexpr (std::is_same_v<T, TrackingDataContent>) {
          ASSERT_EQ(x.elements.size(), y.elements.size());
          for (std::size_t i = 0; i < x.elements.size(); ++i) {
            EXPECT_EQ(x.elements[i].name, y.elements[i].name);
            EXPECT_EQ(x.elements[i].type, y.elements[i].type);
            EXPECT_EQ(x.elements[i].matrix, y.elements[i].matrix);
          }
        }
        if constexpr (std::is_same_v<T, ImageContent>) {
          EXPECT_EQ(x.components, y.components);
          EXPECT_EQ(x.scalar_type, y.scalar_type);
          EXPECT_EQ(x.endian, y.endian);
          EXPECT_EQ(x.coordinate, y.coordinate);
          EXPECT_EQ(x.size, y.size);
          EXPECT_EQ(x.subvolume_offset, y.subvolume_offset);
          EXPECT_EQ(x.subvolume_size, y.subvolume_size);
          EXPECT_EQ(x.ijk_to_xyz, y.ijk_to_xyz);
          EXPECT_EQ(x.pixels, y.pixels);
        }
        if constexpr (std::is_same_v<T, PolyDataContent>) {
          EXPECT_EQ(x.points, y.points);
          expectSame(x.vertices, y.vertices);
          expectSame(x.lines, y.lines);
          expectSame(x.polygons, y.polygons);
          expectSame(x.triangle_strips, y.triangle_strips);
          ASSERT_EQ(x.attributes.size(), y.attributes.size());
          for (std::size_t i = 0; i < x.attributes.size(); ++i) {
            EXPECT_EQ(x.attributes[i].kind, y.attributes[i].kind);
            EXPECT_EQ(x.attributes[i].cell_data, y.attributes[i].cell_data);
            EXPECT_EQ(x.attributes[i].name, y.attributes[i].name);
            EXPECT_EQ(x.attributes[i].data, y.attributes[i].data);
          }
        }
        if constexpr (std::is_same_v<T, StringContent>) {
          EXPECT_EQ(x.encoding, y.encoding);
          EXPECT_EQ(x.text, y.text);
        }
        if constexpr (std::is_same_v<T, StatusContent>) {
          EXPECT_EQ(x.code, y.code);
          EXPECT_EQ(x.subcode, y.subcode);
          EXPECT_EQ(x.error_name, y.error_name);
          EXPECT_EQ(x.message, y.message);
        }
        if constexpr (std::is_same_v<T, PointContent>) {
          ASSERT_EQ(x.points.size(), y.points.size());
          for (std::size_t i = 0; i < x.points.size(); ++i) {
            EXPECT_EQ(x.points[i].name, y.points[i].name);
            EXPECT_EQ(x.points[i].group, y.points[i].group);
            EXPECT_EQ(x.points[i].rgba, y.points[i].rgba);
            EXPECT_EQ(x.points[i].position, y.points[i].position);
            EXPECT_EQ(x.points[i].radius, y.points[i].radius);
            EXPECT_EQ(x.points[i].owner, y.points[i].owner);
          }
        }
        if constexpr (std::is_same_v<T, CapabilityContent>) {
          EXPECT_EQ(x.types, y.types);
        }
        if constexpr (std::is_same_v<T, RawContent>) {
          EXPECT_EQ(x.bytes, y.bytes);
        }
        if constexpr (std::is_same_v<T, StartStream>) {
          EXPECT_EQ(x.resolution, y.resolution);
        }
        if constexpr (std::is_same_v<T, RtsStatus>) {
          EXPECT_EQ(x.status, y.status);
        }
      },
      a);
}

void checkRoundTrip(const Message& m) {
  for (const auto version : {HeaderVersion::kV1, HeaderVersion::kV2}) {
    if (version == HeaderVersion::kV1 && !m.metadata.empty()) continue;
    const auto bytes = encodeMessage(m, version);
    const Message back = decodeMessage(bytes);
    EXPECT_EQ(back.header.version, static_cast<std::uint16_t>(version));
    EXPECT_EQ(back.header.type, m.header.type);
    EXPECT_EQ(back.header.device_name, m.header.device_name);
    EXPECT_EQ(back.header.timestamp, m.header.timestamp);
    if (version == HeaderVersion::kV2) {
      EXPECT_EQ(back.extended.message_id, m.extended.message_id);
      EXPECT_EQ(back.metadata, m.metadata);
    }
    expectSame(m.content, back.content);
    EXPECT_TRUE(encodeMessage(back, version) == bytes);
  }
}

class RandomRoundTrip : public ::testing::TestWithParam<int> {};

TEST_P(RandomRoundTrip, EveryTypeSurvivesEncodeDecode) {
  test::RandomContents rnd(static_cast<std::uint32_t>(1000 + GetParam()));
  for (int trial = 0; trial < 25; ++trial) {
    const std::vector<Content> contents = {rnd.transform(), rnd.position(), rnd.tdata(),
                                           rnd.image(),     rnd.polydata(), rnd.string(),
                                           rnd.status(),    rnd.point(),    rnd.capability()};
    for (const auto& c : contents) {
      Message m = makeMessage(rnd.text(20), c, rnd.uniform(0, 4e9));
      m.extended.message_id = static_cast<std::uint32_t>(rnd.integer(0, 1 << 30));
      const int nmeta = rnd.integer(0, 3);
      for (int k = 0; k < nmeta; ++k) {
        m.metadata.push_back({rnd.text(30), rnd.integer(0, 1) ? kEncodingUsAscii : kEncodingUtf8, rnd.text(60)});
      }
      SCOPED_TRACE(m.header.type);
      checkRoundTrip(m);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Seeds, RandomRoundTrip, ::testing::Range(0, 4));

TEST(RoundTrip, ControlMessagesAndRawContent) {
  checkRoundTrip(makeMessage("GET_IMAGE", "US", GetRequest{}));
  checkRoundTrip(makeMessage("STT_POLYDATA", "Model", StartStream{}));
  checkRoundTrip(makeMessage("STT_IMAGE", "US", StartStream{0x0000000080000000ULL}));
  checkRoundTrip(makeMessage("STP_TDATA", "Tracker", StopStream{}));
  checkRoundTrip(makeMessage("RTS_TDATA", "Tracker", RtsStatus{1}));
  checkRoundTrip(makeMessage("STT_TDATA", "Tracker", StartTrackingDataContent{50, "Reference"}));
  checkRoundTrip(makeMessage("SENSOR", "Force", RawContent{{1, 2, 3, 4, 5}}));
  // A prefixed message whose body has no generic shape is kept raw.
  const auto bytes = encodeMessage(makeMessage("RTS_POINT", "P", RawContent{{0, 1, 2}}));
  EXPECT_NE(decodeMessage(bytes).as<RawContent>(), nullptr);
}

TEST(RoundTrip, PositionShortFormsImplyW) {
  PositionContent p;
  p.position = {1, 2, 3};
  const Eigen::Quaterniond q = Eigen::Quaterniond(0.9, 0.1, -0.3, 0.2).normalized();
  p.orientation = q;
  for (const int n : {4, 3, 0}) {
    p.quaternion_components = n;
    std::vector<std::uint8_t> bytes;
    encodePosition(p, bytes);
    EXPECT_EQ(bytes.size(), 12u + 4u * static_cast<unsigned>(n));
    const auto back = decodePosition(bytes);
    EXPECT_EQ(back.quaternion_components, n);
    EXPECT_EQ(back.position, Eigen::Vector3d(1, 2, 3));
    // float32 components: rotation agrees to ~1e-7 (w recomputed from the other three for n = 3).
    if (n > 0) {
      EXPECT_LT(back.orientation.angularDistance(q), 1e-6) << n;
    }
    if (n == 0) {
      EXPECT_EQ(back.orientation.coeffs(), Eigen::Quaterniond::Identity().coeffs());
    }
  }
}

TEST(RoundTrip, TransformFromIsometry) {
  const Eigen::Isometry3d tracker_T_probe =
      Eigen::Translation3d(10, -20, 30) * Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized());
  const auto m = makeMessage("ProbeToTracker", TransformContent::fromIsometry(tracker_T_probe), 1763900000.25);
  const auto back = decodeMessage(encodeMessage(m));
  EXPECT_EQ(back.header.type, "TRANSFORM");
  EXPECT_DOUBLE_EQ(back.header.timestampSeconds(), 1763900000.25);
  // float32 on the wire: relative error <= 2^-24 per element.
  EXPECT_TRUE(back.as<TransformContent>()->isometry().matrix().isApprox(tracker_T_probe.matrix(), 1e-6));
}

}  // namespace
}  // namespace mrsns::igtlink
