// Debian's libopenigtlink 1.11 (header v1, written by the OpenIGTLink project,
// not here) as the client of the real `mrsns-sim run` process, as 3D Slicer's
// or a lab's C++ code would connect to a PlusServer: TRANSFORM of every tool
// of sim_tracker_scenario.json at its rate and where it put them, IMAGE
// (8-bit B-mode, its size and spacing), then STT_TDATA -> RTS_TDATA and TDATA
// with every valid tool at the requested resolution, and STP_TDATA ending
// them. Every message is decoded by libopenigtlink's own classes, which check
// the CRC.
#include <gtest/gtest.h>
#include <igtlClientSocket.h>
#include <igtlImageMessage.h>
#include <igtlMessageHeader.h>
#include <igtlTrackingDataMessage.h>
#include <igtlTransformMessage.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>

#include "../sim/sim_process.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

using Clock = std::chrono::steady_clock;

struct ExpectedScene {
  std::map<std::string, Eigen::Matrix4d> poses;  // tool name -> TrackerToTool as the scenario starts it
  double tracker_hz = 0;
  double image_hz = 0;
  int width = 0, height = 0;
  double spacing_x = 0, spacing_y = 0;
  std::string image_name;
};

std::filesystem::path scenarioPath() {
  return std::filesystem::path(MRSNS_INTEROP_DIR) / "sim_tracker_scenario.json";
}

ExpectedScene readScene() {
  std::ifstream in(scenarioPath());
  const auto j = nlohmann::json::parse(in);
  ExpectedScene s;
  for (const auto& tool : j.at("tools")) {
    const auto& start = tool.at("start");
    Eigen::Vector3d r = Eigen::Vector3d::Zero();
    if (start.contains("rotation_deg")) {
      for (int i = 0; i < 3; ++i) r[i] = start["rotation_deg"][static_cast<std::size_t>(i)].get<double>() * M_PI / 180;
    }
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    if (r.norm() > 0) m.block<3, 3>(0, 0) = Eigen::AngleAxisd(r.norm(), r.normalized()).toRotationMatrix();
    for (int i = 0; i < 3; ++i) m(i, 3) = start.at("translation_mm")[static_cast<std::size_t>(i)].get<double>();
    s.poses[tool.at("name").get<std::string>()] = m;
  }
  s.tracker_hz = j.at("tracker").at("rate_hz").get<double>();
  const auto& us = j.at("ultrasound");
  s.image_hz = us.at("rate_hz").get<double>();
  s.width = us.at("width").get<int>();
  s.height = us.at("height").get<int>();
  s.spacing_x = us.at("spacing_mm")[0].get<double>();
  s.spacing_y = us.at("spacing_mm")[1].get<double>();
  s.image_name = us.at("device_name").get<std::string>();
  return s;
}

Eigen::Matrix4d toEigen(igtl::Matrix4x4& m) {
  Eigen::Matrix4d e;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) e(r, c) = m[r][c];
  }
  return e;
}

// Rigid, and within 3 mm / 1 deg of the scenario's pose (tracker noise: 0.12 mm, 0.05 deg RMS).
::testing::AssertionResult nearPose(const std::string& what, const Eigen::Matrix4d& m,
                                    const Eigen::Matrix4d& expected) {
  const Eigen::Matrix3d r = m.block<3, 3>(0, 0);
  const double orthogonality = (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (orthogonality > 1e-4 || std::abs(r.determinant() - 1.0) > 1e-4) {
    return ::testing::AssertionFailure() << what << ": not rigid (|R'R - I| = " << orthogonality << ")\n" << m;
  }
  const double distance = (m.block<3, 1>(0, 3) - expected.block<3, 1>(0, 3)).norm();
  const double cos_angle = std::clamp(((expected.block<3, 3>(0, 0).transpose() * r).trace() - 1.0) / 2.0, -1.0, 1.0);
  const double angle_deg = std::acos(cos_angle) * 180.0 / M_PI;
  if (distance > 3.0 || angle_deg > 1.0) {
    return ::testing::AssertionFailure() << what << ": " << distance << " mm and " << angle_deg
                                         << " deg from the scenario's pose\n"
                                         << m;
  }
  return ::testing::AssertionSuccess();
}

double rateHz(const std::vector<double>& stamps) {
  if (stamps.size() < 2 || stamps.back() <= stamps.front()) return 0.0;
  return static_cast<double>(stamps.size() - 1) / (stamps.back() - stamps.front());
}

class Receiver {
 public:
  explicit Receiver(igtl::ClientSocket::Pointer socket) : socket_(std::move(socket)) {}

  /// The next header (nullptr on timeout or close); its raw header version in `version`.
  igtl::MessageHeader::Pointer header(int& version) {
    igtl::MessageHeader::Pointer h = igtl::MessageHeader::New();
    h->InitPack();
    if (!receiveAll(h->GetPackPointer(), h->GetPackSize())) return nullptr;
    const auto* bytes = static_cast<const unsigned char*>(h->GetPackPointer());
    version = (bytes[0] << 8) | bytes[1];
    h->Unpack();
    return h;
  }
  /// Receives the body into `message` and unpacks it with the CRC check; false on a CRC or size failure.
  template <class M>
  bool body(const igtl::MessageHeader::Pointer& h, M& message) {
    message->SetMessageHeader(h);
    message->AllocatePack();
    if (!receiveAll(message->GetPackBodyPointer(), message->GetPackBodySize())) return false;
    return (message->Unpack(1) & igtl::MessageHeader::UNPACK_BODY) != 0;
  }
  void skip(const igtl::MessageHeader::Pointer& h) {
    std::vector<char> bytes(static_cast<std::size_t>(h->GetBodySizeToRead()));
    if (!bytes.empty()) (void)receiveAll(bytes.data(), static_cast<int>(bytes.size()));
  }

 private:
  // libopenigtlink's Receive may return part of a large body (an IMAGE) when a receive timeout is set.
  bool receiveAll(void* data, int length) {
    auto* bytes = static_cast<char*>(data);
    int got = 0;
    while (got < length) {
      const int n = socket_->Receive(bytes + got, length - got);
      if (n <= 0) return false;
      got += n;
    }
    return true;
  }

  igtl::ClientSocket::Pointer socket_;
};

double stampOf(const igtl::MessageHeader::Pointer& h) {
  igtl::TimeStamp::Pointer ts = igtl::TimeStamp::New();
  h->GetTimeStamp(ts);
  return ts->GetTimeStamp();
}

TEST(LibOpenIGTLinkSim, ReceivesTransformImageAndTrackingDataOfMrsnsSim) {
  ASSERT_TRUE(std::filesystem::exists(simBinary())) << "mrsns-sim not built at " << simBinary();
  const auto scene = readScene();
  ASSERT_EQ(scene.poses.size(), 4U);
  const auto dir = scratchDirectory("interop-libopenigtlink-sim");
  const auto ready_file = dir / "ready.json";
  std::filesystem::remove(ready_file);
  SimProcess sim({"run", "--scenario", scenarioPath().string(), "--truth", (dir / "truth.json").string(), "--any-ports",
                  "--ready-file", ready_file.string(), "--duration", "60", "--json"});
  ASSERT_TRUE(sim.started());
  const auto ready = sim.waitReady(ready_file, 60.0);
  ASSERT_FALSE(ready.is_null()) << "mrsns-sim not ready: " << sim.wait(1).err;
  const int port = ready.at("plus_port").get<int>();

  igtl::ClientSocket::Pointer socket = igtl::ClientSocket::New();
  ASSERT_EQ(socket->ConnectToServer(ready.at("host").get<std::string>().c_str(), port), 0)
      << "cannot connect to mrsns-sim's PlusServer on port " << port;
  socket->SetReceiveTimeout(5000);
  Receiver rx(socket);

  // 1. Three seconds of TRANSFORM and IMAGE (header v1: libopenigtlink 1.11 speaks nothing else).
  std::map<std::string, std::vector<double>> stamps;
  std::vector<double> image_stamps;
  int crc_failures = 0;
  int other = 0;
  int not_v1 = 0;
  auto end = Clock::now() + std::chrono::seconds(3);
  while (Clock::now() < end) {
    int version = 0;
    auto h = rx.header(version);
    ASSERT_TRUE(h) << "no message within 5 s";
    if (version != 1) ++not_v1;
    const std::string type = h->GetDeviceType();
    const std::string name = h->GetDeviceName();
    if (type == "TRANSFORM") {
      igtl::TransformMessage::Pointer t = igtl::TransformMessage::New();
      if (!rx.body(h, t)) {
        ++crc_failures;
        continue;
      }
      ASSERT_TRUE(scene.poses.count(name)) << "TRANSFORM of '" << name << "', not a scenario tool";
      igtl::Matrix4x4 m;
      t->GetMatrix(m);
      ASSERT_TRUE(nearPose("TRANSFORM '" + name + "'", toEigen(m), scene.poses.at(name)));
      stamps[name].push_back(stampOf(h));
    } else if (type == "IMAGE") {
      igtl::ImageMessage::Pointer image = igtl::ImageMessage::New();
      if (!rx.body(h, image)) {
        ++crc_failures;
        continue;
      }
      EXPECT_EQ(name, scene.image_name);
      int size[3];
      image->GetDimensions(size);
      EXPECT_EQ(size[0], scene.width);
      EXPECT_EQ(size[1], scene.height);
      EXPECT_EQ(size[2], 1);
      float spacing[3];
      image->GetSpacing(spacing);
      EXPECT_NEAR(spacing[0], scene.spacing_x, 1e-5);
      EXPECT_NEAR(spacing[1], scene.spacing_y, 1e-5);
      EXPECT_EQ(image->GetScalarType(), igtl::ImageMessage::TYPE_UINT8);
      EXPECT_EQ(image->GetNumComponents(), 1);
      EXPECT_EQ(image->GetImageSize(), scene.width * scene.height);
      const auto* pixels = static_cast<const unsigned char*>(image->GetScalarPointer());
      const auto [lo, hi] = std::minmax_element(pixels, pixels + image->GetImageSize());
      EXPECT_LT(*lo, *hi) << "a B-mode frame of one grey level";
      image_stamps.push_back(stampOf(h));
    } else {
      ++other;
      rx.skip(h);
    }
  }
  EXPECT_EQ(crc_failures, 0);
  EXPECT_EQ(not_v1, 0) << "header v2 sent to a client that never spoke v2";
  EXPECT_EQ(other, 0) << "messages other than TRANSFORM and IMAGE before STT_TDATA";
  for (const auto& [name, pose] : scene.poses) {
    ASSERT_GE(stamps[name].size(), 10U) << name;
    EXPECT_NEAR(rateHz(stamps[name]), scene.tracker_hz, 0.1 * scene.tracker_hz) << name;
    std::printf("TRANSFORM %-20s %zu messages at %.1f Hz\n", name.c_str(), stamps[name].size(), rateHz(stamps[name]));
  }
  ASSERT_GE(image_stamps.size(), 10U);
  EXPECT_NEAR(rateHz(image_stamps), scene.image_hz, 0.1 * scene.image_hz);
  std::printf("IMAGE %s: %zu frames at %.1f Hz\n", scene.image_name.c_str(), image_stamps.size(), rateHz(image_stamps));

  // 2. STT_TDATA at 50 ms resolution: RTS_TDATA, then TDATA of every valid tool at 20 Hz.
  igtl::StartTrackingDataMessage::Pointer start = igtl::StartTrackingDataMessage::New();
  start->SetDeviceName("Tracker");
  start->SetResolution(50);
  start->SetCoordinateName("Tracker");
  start->Pack();
  ASSERT_EQ(socket->Send(start->GetPackPointer(), start->GetPackSize()), 1);
  bool rts = false;
  int rts_status = -1;
  std::vector<double> tdata_stamps;
  std::map<std::string, Eigen::Matrix4d> last_transform;
  end = Clock::now() + std::chrono::seconds(3);
  while (Clock::now() < end) {
    int version = 0;
    auto h = rx.header(version);
    ASSERT_TRUE(h) << "no message within 5 s";
    EXPECT_EQ(version, 1);
    const std::string type = h->GetDeviceType();
    if (type == "RTS_TDATA") {
      igtl::RTSTrackingDataMessage::Pointer r = igtl::RTSTrackingDataMessage::New();
      if (!rx.body(h, r)) ++crc_failures;
      rts = true;
      rts_status = r->GetStatus();
    } else if (type == "TDATA") {
      igtl::TrackingDataMessage::Pointer t = igtl::TrackingDataMessage::New();
      if (!rx.body(h, t)) {
        ++crc_failures;
        continue;
      }
      std::set<std::string> names;
      for (int i = 0; i < t->GetNumberOfTrackingDataElements(); ++i) {
        igtl::TrackingDataElement::Pointer e;
        t->GetTrackingDataElement(i, e);
        names.insert(e->GetName());
        igtl::Matrix4x4 m;
        e->GetMatrix(m);
        ASSERT_TRUE(scene.poses.count(e->GetName())) << "TDATA element '" << e->GetName() << "'";
        ASSERT_TRUE(
            nearPose(std::string("TDATA element '") + e->GetName() + "'", toEigen(m), scene.poses.at(e->GetName())));
      }
      EXPECT_EQ(names.size(), scene.poses.size()) << "TDATA without every (valid) scenario tool";
      tdata_stamps.push_back(stampOf(h));
    } else {
      rx.skip(h);
    }
  }
  EXPECT_TRUE(rts) << "no RTS_TDATA answered STT_TDATA";
  EXPECT_EQ(rts_status, 0);
  ASSERT_GE(tdata_stamps.size(), 10U);
  // 50 ms resolution on 60 Hz samples: every third sample (20 Hz), a fourth now and then by timing jitter.
  const double tdata_hz = rateHz(tdata_stamps);
  EXPECT_GE(tdata_hz, 14.0);
  EXPECT_LE(tdata_hz, 21.0);
  std::printf("TDATA: RTS_TDATA status %d, %zu messages with all %zu tools at %.1f Hz (resolution 50 ms)\n", rts_status,
              tdata_stamps.size(), scene.poses.size(), tdata_hz);

  // 3. STP_TDATA: the TDATA stop (a few may have been in flight), the TRANSFORMs go on.
  igtl::StopTrackingDataMessage::Pointer stop = igtl::StopTrackingDataMessage::New();
  stop->SetDeviceName("Tracker");
  stop->Pack();
  ASSERT_EQ(socket->Send(stop->GetPackPointer(), stop->GetPackSize()), 1);
  int tdata_late = 0;
  int transforms_after = 0;
  const auto settle = Clock::now() + std::chrono::milliseconds(300);
  end = Clock::now() + std::chrono::milliseconds(1300);
  while (Clock::now() < end) {
    int version = 0;
    auto h = rx.header(version);
    ASSERT_TRUE(h);
    const std::string type = h->GetDeviceType();
    if (type == "TDATA" && Clock::now() > settle) ++tdata_late;
    if (type == "TRANSFORM") ++transforms_after;
    rx.skip(h);
  }
  EXPECT_EQ(tdata_late, 0) << "TDATA still sent 0.3 s after STP_TDATA";
  EXPECT_GT(transforms_after, 100);
  EXPECT_EQ(crc_failures, 0);
  socket->CloseSocket();

  sim.terminate();
  const auto result = sim.wait(30);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const auto summary = nlohmann::json::parse(result.out);
  EXPECT_EQ(summary.at("stopped_by"), "signal");
  EXPECT_GT(summary.at("messages").at("TDATA").get<int>(), 0);
  EXPECT_GT(summary.at("messages").at("IMAGE").get<int>(), 0);
}

}  // namespace
}  // namespace mrsns::test
