// Each headset client preset, checked by decoding the stream as that client's
// own code does (re-implemented from its source, cited per decoder; see
// modules/tracking/doc/hmd_clients.md) and comparing the pose the client
// would display with the intended one: the model origin to 1e-6 mm, the
// orientation to float32 precision (the wire's 2^-24 per matrix entry,
// through the client's quaternion and Euler angles).
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstring>
#include <thread>

#include "mrsns/core/error.h"
#include "mrsns/igtlink/codec.h"
#include "mrsns/igtlink/crc64.h"
#include "mrsns/tracking/hologram_client_preset.h"
#include "mrsns/tracking/unity_convention.h"
#include "tracking_test_util.h"

namespace mrsns::tracking {
namespace {

using test::waitFor;

// hologram_T_model of the test: a rotation whose quaternion has no small component (the Unity clients' copysign
// conversion loses precision near zero) and a translation exact in float32, so the wire rounds only the rotation.
Eigen::Isometry3d intendedPose() {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(0.9, Eigen::Vector3d(1.0, 2.0, 3.0).normalized()).toRotationMatrix();
  pose.translation() = Eigen::Vector3d(120.5, -42.25, 310.125);
  return pose;
}

std::uint64_t bigEndian(const std::uint8_t* p, int bytes) {
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v = (v << 8) | p[i];
  return v;
}

float bigEndianFloat(const std::uint8_t* p) {
  const auto bits = static_cast<std::uint32_t>(bigEndian(p, 4));
  float f = 0.0F;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

std::string fixedString(const std::uint8_t* p, std::size_t size) {
  std::string s(reinterpret_cast<const char*>(p), size);
  return s.substr(0, s.find('\0'));
}

// A raw TCP client: what the headset app's socket reads, chunk by chunk.
class RawClient {
 public:
  explicit RawClient(std::uint16_t port) : fd_(test::connectRaw(port)) {}
  ~RawClient() {
    if (fd_ >= 0) ::close(fd_);
  }
  RawClient(const RawClient&) = delete;
  RawClient& operator=(const RawClient&) = delete;
  [[nodiscard]] bool connected() const { return fd_ >= 0; }
  void send(const std::vector<std::uint8_t>& bytes) const {
    ASSERT_EQ(::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL), static_cast<ssize_t>(bytes.size()));
  }
  // Every chunk read() returns within `seconds`, as the client's socket gives them.
  [[nodiscard]] std::vector<std::vector<std::uint8_t>> readChunks(double seconds) const {
    std::vector<std::vector<std::uint8_t>> chunks;
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < end) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 10) <= 0) continue;
      std::vector<std::uint8_t> chunk(1 << 16);
      const auto n = ::recv(fd_, chunk.data(), chunk.size(), 0);
      if (n <= 0) break;
      chunk.resize(static_cast<std::size_t>(n));
      chunks.push_back(std::move(chunk));
    }
    return chunks;
  }

 private:
  int fd_ = -1;
};

std::vector<std::uint8_t> joined(const std::vector<std::vector<std::uint8_t>>& chunks) {
  std::vector<std::uint8_t> all;
  for (const auto& c : chunks) all.insert(all.end(), c.begin(), c.end());
  return all;
}

// The header fields every client reads at fixed offsets (OpenIGTLink v1/v2 header, 58 bytes).
struct RawHeader {
  int version = 0;
  std::string type, device;
  std::uint64_t body_size = 0, crc = 0;
};
RawHeader rawHeader(const std::uint8_t* p) {
  return {static_cast<int>(bigEndian(p, 2)), fixedString(p + 2, 12), fixedString(p + 14, 20), bigEndian(p + 42, 8),
          bigEndian(p + 50, 8)};
}

// The messages of a byte stream, split by their headers' body sizes.
std::vector<std::pair<RawHeader, std::vector<std::uint8_t>>> splitMessages(const std::vector<std::uint8_t>& bytes) {
  std::vector<std::pair<RawHeader, std::vector<std::uint8_t>>> out;
  std::size_t at = 0;
  while (at + igtlink::kHeaderSize <= bytes.size()) {
    const RawHeader h = rawHeader(bytes.data() + at);
    if (at + igtlink::kHeaderSize + h.body_size > bytes.size()) break;
    const auto body = bytes.begin() + static_cast<std::ptrdiff_t>(at + igtlink::kHeaderSize);
    out.emplace_back(h, std::vector<std::uint8_t>(body, body + static_cast<std::ptrdiff_t>(h.body_size)));
    at += igtlink::kHeaderSize + h.body_size;
  }
  return out;
}

// ---- Unity's math, as the Unity clients call it (UnityEngine.Matrix4x4 / Quaternion) ----

// SteamVR's Matrix4x4.GetRotation(), which OpenIGTLink-Unity calls: the copysign conversion.
Eigen::Quaterniond steamVrGetRotation(const Eigen::Matrix3d& m) {
  Eigen::Quaterniond q;
  q.w() = std::sqrt(std::max(0.0, 1 + m(0, 0) + m(1, 1) + m(2, 2))) / 2;
  q.x() = std::copysign(std::sqrt(std::max(0.0, 1 + m(0, 0) - m(1, 1) - m(2, 2))) / 2, m(2, 1) - m(1, 2));
  q.y() = std::copysign(std::sqrt(std::max(0.0, 1 - m(0, 0) + m(1, 1) - m(2, 2))) / 2, m(0, 2) - m(2, 0));
  q.z() = std::copysign(std::sqrt(std::max(0.0, 1 - m(0, 0) - m(1, 1) + m(2, 2))) / 2, m(1, 0) - m(0, 1));
  return q;
}

// Unity's Euler angles in degrees: Quaternion.Euler(x, y, z) rotates about z, then x, then y (R = Ry Rx Rz).
Eigen::Matrix3d unityEuler(const Eigen::Vector3d& degrees) {
  const Eigen::Vector3d r = degrees * M_PI / 180.0;
  return (Eigen::AngleAxisd(r.y(), Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(r.x(), Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(r.z(), Eigen::Vector3d::UnitZ()))
      .toRotationMatrix();
}
// Quaternion.eulerAngles: the inverse of unityEuler away from x = +-90 degrees.
Eigen::Vector3d unityEulerAngles(const Eigen::Matrix3d& r) {
  return Eigen::Vector3d(std::asin(-r(1, 2)), std::atan2(r(0, 2), r(2, 2)), std::atan2(r(1, 0), r(1, 1))) * 180.0 /
         M_PI;
}

// What both Unity clients display from the 12 floats of a TRANSFORM (OpenIGTLinkConnect.cs of
// franklinwk/OpenIGTLink-Unity, ReadMessageFromServer.cs of BSEL-UC3M's planner):
//   matrix.SetRow(0, new Vector4(m[0], m[3], m[6], m[9] / scaleMultiplier)) ...   (scaleMultiplier = 1000)
//   localPosition = new Vector3(-translation.x, translation.y, translation.z);
//   localRotation = Quaternion.Euler(euler.x, -euler.y, -euler.z);
struct UnityPose {
  Eigen::Vector3d position_m;
  Eigen::Matrix3d rotation;
};
UnityPose unityClientPose(const float* m, bool steamvr_rotation) {
  Eigen::Matrix3d r;
  r << m[0], m[3], m[6], m[1], m[4], m[7], m[2], m[5], m[8];
  const Eigen::Vector3d translation_m(m[9] / 1000.0, m[10] / 1000.0, m[11] / 1000.0);
  // OpenIGTLink-Unity takes the rotation through SteamVR's GetRotation, the planner through Unity's
  // Matrix4x4.rotation; both then through eulerAngles.
  const Eigen::Matrix3d rotation = steamvr_rotation ? steamVrGetRotation(r).toRotationMatrix() : r;
  const Eigen::Vector3d euler = unityEulerAngles(rotation);
  return {Eigen::Vector3d(-translation_m.x(), translation_m.y(), translation_m.z()),
          unityEuler(Eigen::Vector3d(euler.x(), -euler.y(), -euler.z()))};
}

// The pose a Unity client should display: the model's pose in Unity's convention (unity_convention.h).
void expectUnityPose(const UnityPose& shown, const Eigen::Isometry3d& hologram_T_model) {
  const Eigen::Matrix4d intended = transformToUnity(hologram_T_model.matrix());
  EXPECT_LT((shown.position_m - intended.block<3, 1>(0, 3)).norm() * 1000.0, 1e-6) << "position (m) "
                                                                                   << shown.position_m.transpose();
  const double angle = Eigen::AngleAxisd(shown.rotation.transpose() * intended.block<3, 3>(0, 0)).angle();
  EXPECT_LT(angle, 1e-6) << "orientation off by " << angle << " rad";
}

struct PresetStream {
  PresetStream(const std::string& preset, std::vector<HologramModel> models) {
    igtlink::ServerOptions options = test::loopback();
    server = std::make_unique<igtlink::Server>(options);
    repository->setTransform("ReferenceToTracker", intendedPose(), TransformStatus::Ok, 100.0);
    HologramStreamOptions stream_options;
    stream_options.hologram_frame = "Tracker";
    streamer = std::make_unique<HologramStreamer>(
        *server, repository, std::move(models), withClientPreset(stream_options, hologramClientPreset(preset)));
    streamer->setPrompt("Align the cube");
    server->start();
  }
  ~PresetStream() { server->stop(); }
  // A few tracking updates, a tracking loss and its recovery.
  void track() {
    for (int i = 0; i < 3; ++i) {
      repository->setTransform("ReferenceToTracker", intendedPose(), TransformStatus::Ok, 101.0 + i);
      streamer->update(0.0);
    }
    repository->setStatus("Reference", "Tracker", TransformStatus::Invalid, 104.0);
    streamer->update(0.0);
    repository->setTransform("ReferenceToTracker", intendedPose(), TransformStatus::Ok, 105.0);
    streamer->update(0.0);
  }
  std::shared_ptr<TransformRepository> repository = std::make_shared<TransformRepository>();
  std::unique_ptr<igtlink::Server> server;
  std::unique_ptr<HologramStreamer> streamer;
};

std::vector<HologramModel> spine() {
  return {{"Spine", test::tetrahedron(), "Reference"}};
}

TEST(HologramClientPresets, OpenIgtLinkUnityShowsTheIntendedPose) {
  PresetStream stream("openigtlink-unity", spine());
  RawClient unity(stream.server->port());
  ASSERT_TRUE(unity.connected());
  ASSERT_TRUE(waitFor([&] { return stream.streamer->readyClients() == 1; }));
  stream.track();
  const auto chunks = unity.readChunks(0.5);
  // Its reader: `if ((bytesRead > 0) & (bytesRead % 106 == 0))`, then the type at 2..14 must be TRANSFORM (any
  // other type ends the read) and the name at 14..34 picks the GameObjects. So every message must be a v1 TRANSFORM
  // of 58 + 48 bytes: one POLYDATA, STATUS or v2 header would make reads it drops.
  const auto messages = splitMessages(joined(chunks));
  ASSERT_EQ(messages.size(), 4U);  // three updates and the one after tracking came back
  for (const auto& [header, body] : messages) {
    EXPECT_EQ(header.version, 1);
    EXPECT_EQ(header.type, "TRANSFORM");
    EXPECT_EQ(header.device, "Spine");
    EXPECT_EQ(header.body_size, 48U);
  }
  int poses = 0;
  for (const auto& chunk : chunks) {
    if (chunk.empty() || chunk.size() % 106 != 0) continue;
    ASSERT_EQ(fixedString(chunk.data() + 2, 12), "TRANSFORM");
    float m[12];
    for (int i = 0; i < 12; ++i) m[i] = bigEndianFloat(chunk.data() + 58 + 4 * i);
    expectUnityPose(unityClientPose(m, true), intendedPose());
    ++poses;
  }
  EXPECT_GE(poses, 1);
}

TEST(HologramClientPresets, OurUnityMetresWouldBeMirroredAndScaledTwiceByOpenIgtLinkUnity) {
  // Why a preset names the client: the stream set up for a Unity app that applies poses as they come is
  // converted a second time by OpenIGTLink-Unity (and, in v2, never read by it at all).
  PresetStream stream("unity-metres", spine());
  RawClient unity(stream.server->port());
  ASSERT_TRUE(waitFor([&] { return stream.streamer->readyClients() == 1; }));
  stream.track();
  const auto messages = splitMessages(joined(unity.readChunks(0.5)));
  ASSERT_FALSE(messages.empty());
  EXPECT_EQ(messages.front().first.type, "POLYDATA");  // 58 + its size: not a multiple of 106 in general
  for (const auto& [header, body] : messages) {
    if (header.type != "TRANSFORM") continue;
    EXPECT_NE(header.body_size, 48U);  // v2: the extended header comes first, so its floats would be misread
    float m[12];
    for (int i = 0; i < 12; ++i) m[i] = bigEndianFloat(body.data() + 12 + 4 * i);  // even read at the right place
    const UnityPose shown = unityClientPose(m, true);
    const Eigen::Matrix4d intended = transformToUnity(intendedPose().matrix());
    EXPECT_GT((shown.position_m - intended.block<3, 1>(0, 3)).norm(), 0.1);  // 1/1000 of the distance, x mirrored
  }
}

TEST(HologramClientPresets, HoloLens2PedicleClientShowsTheIntendedPose) {
  PresetStream stream("hololens2-pedicle", spine());
  RawClient planner(stream.server->port());
  ASSERT_TRUE(waitFor([&] { return stream.streamer->readyClients() == 1; }));
  stream.track();
  // Its reader (ReadMessageFromServer.cs): the header's extHeaderSize at bytes 58-59, the matrix at
  // `headerSize + 12 + i * 4` ("We add +12 to skip the extended header"), every message whose type contains
  // TRANSFORM moves its MovingPlane, whatever the name.
  const auto messages = splitMessages(joined(planner.readChunks(0.5)));
  ASSERT_EQ(messages.size(), 4U);
  for (const auto& [header, body] : messages) {
    EXPECT_EQ(header.version, 2);
    ASSERT_NE(header.type.find("TRANSFORM"), std::string::npos);
    ASSERT_GE(body.size(), 12U + 48U);
    EXPECT_EQ(bigEndian(body.data(), 2), 12U);  // extHeaderSize: what its fixed +12 assumes
    float m[12];
    for (int i = 0; i < 12; ++i) m[i] = bigEndianFloat(body.data() + 12 + 4 * i);
    const UnityPose shown = unityClientPose(m, false);
    // Its guard: a translation over 10000 (m, after /1000) puts the plane at (0, 0, 0.5) instead.
    ASSERT_LT(shown.position_m.maxCoeff(), 10000.0);
    expectUnityPose(shown, intendedPose());
  }
}

TEST(HologramClientPresets, HoloLens2PedicleClientIsGivenOneModelOnly) {
  std::vector<HologramModel> two = spine();
  two.push_back({"Probe", test::tetrahedron(5.0), "Reference"});
  try {
    PresetStream stream("hololens2-pedicle", two);
    FAIL() << "two models were accepted for a client that moves one object with every TRANSFORM";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("stream only that many models"), std::string::npos) << e.what();
  }
}

TEST(HologramClientPresets, SlicerAsAViewerGetsModelsStatusPromptAndTheTransformAsItIs) {
  PresetStream stream("slicer", spine());
  RawClient slicer(stream.server->port());
  // vtkMRMLIGTLConnectorNode on ConnectedEvent: a v2 STATUS with an empty device name and metadata
  // "dummy" = "dummy" ("tell the server we can support v2 messages"). The stream must read it and keep the client.
  auto hello = igtlink::makeMessage("", igtlink::StatusContent{1, 0, "", ""});
  hello.header.version = 2;
  hello.metadata.push_back({"dummy", igtlink::kEncodingUsAscii, "dummy"});
  slicer.send(igtlink::encodeMessage(hello, igtlink::HeaderVersion::kV2));
  ASSERT_TRUE(waitFor([&] { return stream.streamer->readyClients() == 1; }));
  stream.track();
  const auto messages = splitMessages(joined(slicer.readChunks(0.5)));
  EXPECT_EQ(stream.server->stats().clients_closed_for_protocol_errors, 0U);
  EXPECT_EQ(stream.streamer->stats().client_messages_ignored, 1U);
  std::vector<std::string> sequence;
  int poses = 0;
  for (const auto& [header, body] : messages) {
    sequence.push_back(header.type);
    // igtl::MessageBase::Unpack(checkCRC = 1): the CRC covers the whole body (v2: extended header and metadata too).
    EXPECT_EQ(igtlink::crc64(body), header.crc) << header.type;
    if (header.type != "TRANSFORM") continue;
    // igtl::TransformMessage::UnpackContent after the extended header:
    //   matrix[i][0] = transform[i]; matrix[i][1] = transform[i+3]; matrix[i][2] = transform[i+6];
    //   matrix[i][3] = transform[i+9];
    // and igtlioTransformConverter copies it into the linear transform node named after the device, as it is.
    ASSERT_EQ(header.version, 2);
    const std::size_t content = bigEndian(body.data(), 2);
    float t[12];
    for (int i = 0; i < 12; ++i) t[i] = bigEndianFloat(body.data() + content + 4 * i);
    Eigen::Matrix4d shown = Eigen::Matrix4d::Identity();
    for (int i = 0; i < 3; ++i) {
      shown(i, 0) = t[i];
      shown(i, 1) = t[i + 3];
      shown(i, 2) = t[i + 6];
      shown(i, 3) = t[i + 9];
    }
    EXPECT_EQ(header.device, "Spine");
    EXPECT_LT((shown.block<3, 1>(0, 3) - intendedPose().translation()).norm(), 1e-6);  // mm
    EXPECT_LT(Eigen::AngleAxisd(shown.block<3, 3>(0, 0).transpose() * intendedPose().linear()).angle(), 1e-6);
    ++poses;
  }
  EXPECT_EQ(poses, 4);
  // The model, the operator's prompt, then the stream with the loss and recovery as STATUS nodes.
  ASSERT_GE(sequence.size(), 2U);
  EXPECT_EQ(sequence[0], "POLYDATA");
  EXPECT_EQ(sequence[1], "STRING");
  EXPECT_EQ(std::count(sequence.begin(), sequence.end(), "STATUS"), 2);
}

TEST(HologramClientPresets, UnknownClientNamesTheKnownOnes) {
  try {
    (void)hologramClientPreset("hololens");
    FAIL();
  } catch (const InvalidArgumentError& e) {
    const std::string what = e.what();
    for (const auto& preset : hologramClientPresets()) EXPECT_NE(what.find(preset.name), std::string::npos) << what;
  }
  EXPECT_EQ(hologramClientPresets().front().name, "slicer");
}

}  // namespace
}  // namespace mrsns::tracking
