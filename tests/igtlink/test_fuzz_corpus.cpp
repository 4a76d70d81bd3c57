// The seed corpus of tests/fuzz/fuzz_igtlink_decoder is written by our encoder:
// this test checks the checked-in files still equal what the encoder produces
// (MRSNS_WRITE_FUZZ_CORPUS=1 rewrites them).
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "igtlink_test_util.h"
#include "mrsns/igtlink/codec.h"

namespace mrsns::igtlink {
namespace {

std::vector<std::pair<std::string, std::vector<std::uint8_t>>> seeds() {
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> out;
  const auto add = [&out](std::string name, const Message& m, HeaderVersion v = HeaderVersion::kV1) {
    out.emplace_back(std::move(name), encodeMessage(m, v));
  };
  Message t = makeMessage("ProbeToTracker", TransformContent{}, 1763900000.5);
  add("transform_v1", t);
  t.extended.message_id = 7;
  t.metadata = {{"Status", kEncodingUsAscii, "OK"}, {"Patient", kEncodingUtf8, "J\xC3\xBCrgen"}};
  add("transform_v2_metadata", t, HeaderVersion::kV2);
  for (const int n : {4, 3, 0}) {
    PositionContent p;
    p.position = {1, 2, 3};
    p.quaternion_components = n;
    add("position_" + std::to_string(n), makeMessage("Stylus", p));
  }
  TrackingDataContent td;
  td.elements = {{"Probe", 2, Eigen::Matrix4d::Identity()}, {"Reference", 2, Eigen::Matrix4d::Identity()}};
  add("tdata", makeMessage("Tracker", td));
  add("stt_tdata", makeMessage("Tracker", StartTrackingDataContent{50, "Reference"}));
  ImageContent im;
  im.resizeWhole({4, 3, 1});
  add("image_uint8", makeMessage("US", im));
  ImageContent sub;
  sub.scalar_type = ScalarType::kInt16;
  sub.components = 2;
  sub.size = {4, 4, 2};
  sub.subvolume_offset = {1, 1, 1};
  sub.subvolume_size = {2, 3, 1};
  sub.pixels.assign(static_cast<std::size_t>(sub.expectedPixelBytes()), 3);
  add("image_subvolume_v2", makeMessage("CT", sub), HeaderVersion::kV2);
  PolyDataContent p;
  p.points.resize(4, 3);
  p.points << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  p.vertices.add({0});
  p.lines.add({0, 1, 2});
  p.polygons.add({0, 1, 2});
  p.polygons.add({0, 2, 3, 1});
  p.triangle_strips.add({0, 1, 2, 3});
  p.attributes.push_back({AttributeKind::kScalar, false, "s", Eigen::MatrixXd::Ones(4, 1)});
  p.attributes.push_back({AttributeKind::kRgba, true, "colour", Eigen::MatrixXd::Ones(5, 4)});
  add("polydata", makeMessage("Model", p));
  add("string", makeMessage("Console", StringContent{kEncodingUtf8, "hello"}));
  add("status", makeMessage("Robot", StatusContent{6, -1, "BUSY", "moving"}));
  PointContent pc;
  pc.points.push_back({"Nasion", "Fiducial", {255, 0, 0, 255}, {1, 2, 3}, 1.0, "CT"});
  add("point", makeMessage("Fiducials", pc));
  add("capability", makeMessage("Server", CapabilityContent{{"TRANSFORM", "IMAGE", "GET_IMAGE"}}));
  add("get_image", makeMessage("GET_IMAGE", "US", GetRequest{}));
  add("stt_polydata", makeMessage("STT_POLYDATA", "Model", StartStream{1ULL << 31}));
  add("stp_tdata", makeMessage("STP_TDATA", "Tracker", StopStream{}));
  add("rts_tdata", makeMessage("RTS_TDATA", "Tracker", RtsStatus{0}));
  add("raw_sensor", makeMessage("SENSOR", "Force", RawContent{{0, 3, 1, 2, 3, 4}}));
  std::vector<std::uint8_t> stream;
  for (std::size_t i = 0; i < 3; ++i) stream.insert(stream.end(), out[i].second.begin(), out[i].second.end());
  out.emplace_back("stream_of_three", stream);
  return out;
}

TEST(FuzzSeedCorpus, CheckedInSeedsEqualTheEncoderOutput) {
  // Not __FILE__: with ccache's base_dir it is relative to the build folder.
  const auto dir = std::filesystem::path(MRSNS_TEST_SOURCE_DIR) / "fuzz" / "corpus" / "igtlink";
  const char* write = std::getenv("MRSNS_WRITE_FUZZ_CORPUS");
  if (write != nullptr && std::string(write) == "1") {
    std::filesystem::create_directories(dir);
    for (const auto& [name, bytes] : seeds()) {
      std::ofstream(dir / (name + ".bin"), std::ios::binary)
          .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    }
  }
  ASSERT_TRUE(std::filesystem::exists(dir)) << "seed corpus missing at " << dir;
  for (const auto& [name, bytes] : seeds()) {
    EXPECT_TRUE(test::readBytes(dir / (name + ".bin")) == bytes)
        << name << " is stale: rerun with MRSNS_WRITE_FUZZ_CORPUS=1";
  }
}

}  // namespace
}  // namespace mrsns::igtlink
