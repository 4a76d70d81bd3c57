// IgtlTrackingSource against an in-process mrsns Server playing PlusServer.
#include <gtest/gtest.h>

#include <cstring>
#include <mutex>

#include "mrsns/core/error.h"
#include "mrsns/igtlink/server.h"
#include "mrsns/tracking/igtl_source.h"
#include "tracking_test_util.h"

namespace mrsns::tracking {
namespace {

using test::loopback;
using test::waitFor;

Eigen::Isometry3d pose(double x, double angle = 0.3) {
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.linear() = Eigen::AngleAxisd(angle, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  p.translation() = Eigen::Vector3d(x, -20.0, -1000.0);
  return p;
}

igtlink::Message plusTransform(const std::string& name, const Eigen::Isometry3d& p, const std::string& status,
                               double t) {
  auto m = igtlink::makeMessage(name, igtlink::TransformContent::fromIsometry(p), t);
  m.metadata.push_back({"TransformStatus", igtlink::kEncodingUsAscii, status});
  return m;
}

struct PlusServerFixture : ::testing::Test {
  void SetUp() override {
    server = std::make_unique<igtlink::Server>(loopback());
    server->onMessage([this](igtlink::ClientId, const igtlink::Message& m) {
      std::lock_guard lock(mutex);
      requests.push_back(m.header.type);
    });
    server->start();
    options.client.port = server->port();
    options.client.backoff_initial_s = 0.02;
    options.stale_after_s = 0.1;
  }
  void TearDown() override { server->stop(); }
  std::unique_ptr<igtlink::Server> server;
  IgtlSourceOptions options;
  std::mutex mutex;
  std::vector<std::string> requests;
};

TEST_F(PlusServerFixture, TransformsWithStatusThenTdataThenSilenceGivesStale) {
  options.request_tdata = true;
  options.stale_after_s = 0.3;  // long enough not to fire between the steps on a loaded machine
  auto repository = std::make_shared<TransformRepository>();
  IgtlTrackingSource source(repository, options);
  std::atomic<int> batches{0};
  source.setUpdateCallback([&](std::span<const ToolUpdate>) { ++batches; });
  source.start();
  ASSERT_TRUE(waitFor([&] { return server->stats().clients == 1 && source.connected(); }));
  // PLUS asked for TDATA: STT_TDATA arrives on connection.
  ASSERT_TRUE(waitFor([&] {
    std::lock_guard lock(mutex);
    return std::find(requests.begin(), requests.end(), "STT_TDATA") != requests.end();
  }));

  const double t0 = 1.7e9;  // UTC seconds
  server->broadcast(plusTransform("ProbeToTracker", pose(10.0), "OK", t0), igtlink::HeaderVersion::kV2,
                    igtlink::Channel::Reliable);
  ASSERT_TRUE(waitFor([&] { return repository->hasFrame("Probe"); }));
  auto r = repository->getTransform("ProbeToTracker");
  EXPECT_EQ(r.status, TransformStatus::Ok);
  EXPECT_TRUE(test::equalAsFloat32(r.to_T_from.matrix(), pose(10.0).matrix()) ||
              r.to_T_from.matrix().isApprox(pose(10.0).matrix(), 1e-6));
  EXPECT_NEAR(r.timestamp, t0, 1e-9);

  // PLUS reports the tool out of view: Invalid, the last pose kept.
  server->broadcast(plusTransform("ProbeToTracker", Eigen::Isometry3d::Identity(), "INVALID", t0 + 0.01),
                    igtlink::HeaderVersion::kV2, igtlink::Channel::Reliable);
  ASSERT_TRUE(waitFor([&] { return repository->getTransform("ProbeToTracker").status == TransformStatus::Invalid; }));
  EXPECT_NEAR(repository->getTransform("ProbeToTracker").to_T_from.translation().x(), 10.0, 1e-4);

  // TDATA with two tools (one without "To": the reference is appended).
  igtlink::TrackingDataContent tdata;
  tdata.elements.push_back({"StylusToTracker", 2, pose(20.0).matrix()});
  tdata.elements.push_back({"Reference", 2, pose(30.0).matrix()});
  const int before = batches.load();
  server->broadcast(igtlink::makeMessage("Tools", tdata, t0 + 0.02), igtlink::HeaderVersion::kV1,
                    igtlink::Channel::Reliable);
  ASSERT_TRUE(waitFor([&] { return repository->hasFrame("Reference") && repository->hasFrame("Stylus"); }));
  EXPECT_EQ(batches.load(), before + 1);  // one batch per TDATA message
  EXPECT_EQ(repository->getTransform("StylusToTracker").status, TransformStatus::Ok);
  EXPECT_NEAR(repository->getTransform("ReferenceToTracker").to_T_from.translation().x(), 30.0, 1e-4);

  // Then silence: after stale_after_s every tool that was Ok is Invalid.
  ASSERT_TRUE(
      waitFor([&] { return repository->getTransform("StylusToTracker").status == TransformStatus::Invalid; }, 2.0));
  EXPECT_EQ(repository->getTransform("ReferenceToTracker").status, TransformStatus::Invalid);
  EXPECT_GE(source.stats().stale_events, 2U);
  EXPECT_EQ(source.stats().tdata_messages, 1U);
  EXPECT_EQ(source.stats().transforms, 2U);

  // Data again: Ok again.
  server->broadcast(plusTransform("StylusToTracker", pose(21.0), "OK", t0 + 1.0), igtlink::HeaderVersion::kV2,
                    igtlink::Channel::Reliable);
  ASSERT_TRUE(waitFor([&] { return repository->getTransform("StylusToTracker").status == TransformStatus::Ok; }));
  const auto names = source.toolNames();
  EXPECT_EQ(names, (std::vector<std::string>{"ProbeToTracker", "ReferenceToTracker", "StylusToTracker"}));
  source.stop();
}

TEST_F(PlusServerFixture, V1TransformWithBrokenMatrixIsInvalid) {
  auto repository = std::make_shared<TransformRepository>();
  IgtlTrackingSource source(repository, options);
  source.start();
  ASSERT_TRUE(waitFor([&] { return server->stats().clients == 1; }));
  server->broadcast(plusTransform("ProbeToTracker", pose(1.0), "OK", 10.0), igtlink::HeaderVersion::kV2,
                    igtlink::Channel::Reliable);
  ASSERT_TRUE(waitFor([&] { return repository->hasFrame("Probe"); }));
  Eigen::Matrix4d broken = pose(1.0).matrix();
  broken.block<3, 3>(0, 0) *= 2.0;  // a scaled "rotation": not a pose
  server->broadcast(igtlink::makeMessage("ProbeToTracker", igtlink::TransformContent{broken}, 11.0),
                    igtlink::HeaderVersion::kV1, igtlink::Channel::Reliable);
  ASSERT_TRUE(waitFor([&] { return repository->getTransform("ProbeToTracker").status == TransformStatus::Invalid; }));
  EXPECT_NEAR(repository->getTransform("ProbeToTracker").to_T_from.translation().x(), 1.0, 1e-4);
}

TEST_F(PlusServerFixture, ImageIsKeptWithVoxelZeroOrigin) {
  IgtlTrackingSource source(std::make_shared<TransformRepository>(), options);
  source.start();
  ASSERT_TRUE(waitFor([&] { return server->stats().clients == 1; }));
  igtlink::ImageContent image;
  image.resizeWhole({4, 3, 1});
  for (std::size_t i = 0; i < image.pixels.size(); ++i) image.pixels[i] = static_cast<std::uint8_t>(i);
  // Centre at (100, 50, 0) with 0.5 mm pixels along x and y.
  image.setGeometry(Eigen::Vector3d(0.5, 0.5, 1.0), Eigen::Matrix3d::Identity(), Eigen::Vector3d(100.0, 50.0, 0.0));
  server->broadcast(igtlink::makeMessage("Image_Reference", image, 20.0), igtlink::HeaderVersion::kV1,
                    igtlink::Channel::Reliable);
  ASSERT_TRUE(waitFor([&] { return source.latestImage().has_value(); }));
  const auto received = *source.latestImage();
  EXPECT_EQ(received.frame, "Reference");
  EXPECT_NEAR(received.timestamp, 20.0, 1e-9);
  EXPECT_EQ(received.pixels, image.pixels);
  // Voxel (0,0,0) sits (size-1)/2 voxels before the centre: x 100 - 1.5*0.5, y 50 - 1*0.5.
  const Eigen::Vector4d corner = received.ijk_to_frame * Eigen::Vector4d(0, 0, 0, 1);
  EXPECT_NEAR(corner.x(), 99.25, 1e-5);
  EXPECT_NEAR(corner.y(), 49.5, 1e-5);
  const Eigen::Vector4d last = received.ijk_to_frame * Eigen::Vector4d(3, 2, 0, 1);
  EXPECT_NEAR(last.x(), 100.75, 1e-5);
  EXPECT_NEAR(last.y(), 50.5, 1e-5);
}

// 16-bit pixels sent big-endian (the OpenIGTLink default) arrive in host
// order, and every image reaches the image callback, not just the latest.
TEST_F(PlusServerFixture, BigEndianPixelsAreSwappedAndEveryImageIsCalledBack) {
  IgtlTrackingSource source(std::make_shared<TransformRepository>(), options);
  std::mutex mutex;
  std::vector<double> seen;
  source.setImageCallback([&](const TrackedImage& image) {
    std::lock_guard lock(mutex);
    seen.push_back(image.timestamp);
  });
  source.start();
  ASSERT_TRUE(waitFor([&] { return server->stats().clients == 1; }));
  igtlink::ImageContent image;
  image.scalar_type = igtlink::ScalarType::kUint16;
  image.endian = igtlink::PixelEndian::kBig;
  image.resizeWhole({2, 2, 1});
  const std::uint16_t values[4] = {1, 258, 4096, 65535};
  for (int i = 0; i < 4; ++i) {
    image.pixels[2 * i] = static_cast<std::uint8_t>(values[i] >> 8);
    image.pixels[2 * i + 1] = static_cast<std::uint8_t>(values[i] & 0xff);
  }
  for (int k = 0; k < 5; ++k) {
    server->broadcast(igtlink::makeMessage("Image_Reference", image, 30.0 + k), igtlink::HeaderVersion::kV1,
                      igtlink::Channel::Reliable);
  }
  ASSERT_TRUE(waitFor([&] {
    std::lock_guard lock(mutex);
    return seen.size() == 5;
  }));
  const auto received = *source.latestImage();
  ASSERT_EQ(received.pixels.size(), 8u);
  for (int i = 0; i < 4; ++i) {
    std::uint16_t v = 0;
    std::memcpy(&v, received.pixels.data() + 2 * i, 2);
    EXPECT_EQ(v, values[i]) << i;
  }
  std::lock_guard lock(mutex);
  EXPECT_EQ(seen, (std::vector<double>{30.0, 31.0, 32.0, 33.0, 34.0}));
}

TEST_F(PlusServerFixture, ConnectionLossMarksToolsInvalidAndTheClientReconnects) {
  options.stale_after_s = 0.0;  // only the connection matters here
  auto repository = std::make_shared<TransformRepository>();
  IgtlTrackingSource source(repository, options);
  source.start();
  ASSERT_TRUE(waitFor([&] { return server->stats().clients == 1; }));
  server->broadcast(plusTransform("ProbeToTracker", pose(1.0), "OK", 10.0), igtlink::HeaderVersion::kV2,
                    igtlink::Channel::Reliable);
  ASSERT_TRUE(waitFor([&] { return repository->hasFrame("Probe"); }));
  const auto port = server->port();
  server->stop();
  ASSERT_TRUE(waitFor([&] { return repository->getTransform("ProbeToTracker").status == TransformStatus::Invalid; }));
  EXPECT_EQ(source.status().state, SourceState::Connecting);
  igtlink::ServerOptions again;
  again.port = port;
  server = std::make_unique<igtlink::Server>(again);
  server->start();
  ASSERT_TRUE(waitFor([&] { return server->stats().clients == 1; }, 10.0));
  server->broadcast(plusTransform("ProbeToTracker", pose(2.0), "OK", 11.0), igtlink::HeaderVersion::kV2,
                    igtlink::Channel::Reliable);
  ASSERT_TRUE(waitFor([&] { return repository->getTransform("ProbeToTracker").status == TransformStatus::Ok; }));
  EXPECT_EQ(source.status().state, SourceState::Running);
}

TEST(IgtlSource, RefusesNegativeStaleAge) {
  IgtlSourceOptions options;
  options.stale_after_s = -1.0;
  EXPECT_THROW(IgtlTrackingSource(std::make_shared<TransformRepository>(), options), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::tracking
