// The PlusServer emulation read back from the wire: header version per
// client, TRANSFORM with status metadata, invalid tools left out, TDATA on
// request, IMAGE geometry, a restart on the same port.
#include <gtest/gtest.h>

#include <chrono>
#include <mutex>
#include <thread>

#include "mrsns/core/error.h"
#include "mrsns/igtlink/client.h"
#include "mrsns/igtlink/server.h"
#include "mrsns/simulation/plus_server.h"

namespace mrsns::simulation {
namespace {

using namespace std::chrono_literals;

// Collects every message a client receives.
class Listener {
 public:
  explicit Listener(std::uint16_t port) {
    igtlink::ClientOptions o;
    o.port = port;
    o.backoff_initial_s = 0.05;
    client_ = std::make_unique<igtlink::Client>(o);
    client_->onMessage([this](const igtlink::Message& m) {
      std::lock_guard lock(mutex_);
      messages_.push_back(m);
    });
    client_->start();
  }
  bool waitConnected(PlusServerEmulator& server, std::size_t clients) {
    for (int i = 0; i < 200; ++i) {
      if (client_->connected() && server.stats().clients >= clients) return true;
      std::this_thread::sleep_for(10ms);
    }
    return false;
  }
  std::vector<igtlink::Message> take() {
    std::lock_guard lock(mutex_);
    return std::exchange(messages_, {});
  }
  std::vector<igtlink::Message> waitFor(std::size_t n) {
    for (int i = 0; i < 200; ++i) {
      {
        std::lock_guard lock(mutex_);
        if (messages_.size() >= n) break;
      }
      std::this_thread::sleep_for(10ms);
    }
    return take();
  }
  igtlink::Client& client() { return *client_; }

 private:
  std::unique_ptr<igtlink::Client> client_;
  std::mutex mutex_;
  std::vector<igtlink::Message> messages_;
};

std::vector<MeasuredTool> twoTools(bool stylus_valid) {
  Eigen::Matrix4d probe = Eigen::Matrix4d::Identity();
  probe(0, 3) = 12.5;
  return {{"ProbeToTracker", probe, true}, {"StylusToTracker", Eigen::Matrix4d::Identity(), stylus_valid}};
}

TEST(PlusServerEmulator, VersionOneClientsGetValidTransformsOnlyWithoutMetadata) {
  PlusServerOptions o;
  o.port = 0;
  PlusServerEmulator server(o);
  server.start();
  Listener listener(server.port());
  ASSERT_TRUE(listener.waitConnected(server, 1));
  server.publishTools(twoTools(false), 1000.25);
  const auto messages = listener.waitFor(1);
  ASSERT_EQ(messages.size(), 1u) << "the occluded stylus is not sent (PLUS's SendValidTransformsOnly)";
  EXPECT_EQ(messages[0].header.type, "TRANSFORM");
  EXPECT_EQ(messages[0].header.device_name, "ProbeToTracker");
  EXPECT_EQ(messages[0].header.version, 1);
  EXPECT_NEAR(messages[0].header.timestampSeconds(), 1000.25, 1e-6);
  ASSERT_NE(messages[0].as<igtlink::TransformContent>(), nullptr);
  EXPECT_DOUBLE_EQ(messages[0].as<igtlink::TransformContent>()->matrix(0, 3), 12.5);
}

TEST(PlusServerEmulator, AClientThatSpeaksVersionTwoGetsStatusMetadataAndInvalidTools) {
  PlusServerOptions o;
  o.port = 0;
  o.send_valid_transforms_only = false;
  PlusServerEmulator server(o);
  server.start();
  Listener listener(server.port());
  ASSERT_TRUE(listener.waitConnected(server, 1));
  ASSERT_TRUE(listener.client().send(igtlink::makeMessage("GET_STATUS", "", igtlink::GetRequest{}),
                                     igtlink::HeaderVersion::kV2));
  const auto replies = listener.waitFor(1);
  ASSERT_EQ(replies.size(), 1u);
  EXPECT_EQ(replies[0].header.type, "STATUS");
  EXPECT_EQ(replies[0].header.version, 2) << "answers in the client's version";
  server.publishTools(twoTools(false), 5.0);
  const auto messages = listener.waitFor(2);
  ASSERT_EQ(messages.size(), 2u);
  for (const auto& m : messages) {
    EXPECT_EQ(m.header.version, 2);
    const auto status = m.metadataValue("TransformStatus");
    ASSERT_TRUE(status.has_value());
    EXPECT_EQ(*status, m.header.device_name == "StylusToTracker" ? "INVALID" : "OK");
  }
}

TEST(PlusServerEmulator, TrackingDataOnlyAfterStartAndUntilStop) {
  PlusServerOptions o;
  o.port = 0;
  PlusServerEmulator server(o);
  server.start();
  Listener listener(server.port());
  ASSERT_TRUE(listener.waitConnected(server, 1));
  igtlink::StartTrackingDataContent start;
  start.resolution_ms = 50;
  ASSERT_TRUE(listener.client().send(igtlink::makeMessage("STT_TDATA", "Tracker", start)));
  auto replies = listener.waitFor(1);
  ASSERT_EQ(replies.size(), 1u);
  EXPECT_EQ(replies[0].header.type, "RTS_TDATA");
  // 60 Hz for 0.5 s with a 50 ms resolution: TDATA every third sample.
  for (int i = 0; i < 30; ++i) {
    // At the tracker's pace: a client that falls behind a burst loses the oldest samples (Stream channel).
    server.publishTools(twoTools(true), 100.0 + i / 60.0);
    std::this_thread::sleep_for(std::chrono::microseconds(16667));
  }
  std::this_thread::sleep_for(200ms);
  int tdata = 0, transforms = 0;
  for (const auto& m : listener.take()) {
    if (m.header.type == "TDATA") {
      ++tdata;
      ASSERT_NE(m.as<igtlink::TrackingDataContent>(), nullptr);
      EXPECT_EQ(m.as<igtlink::TrackingDataContent>()->elements.size(), 2u);
    }
    if (m.header.type == "TRANSFORM") ++transforms;
  }
  EXPECT_EQ(transforms, 60);
  EXPECT_EQ(tdata, 10);
  ASSERT_TRUE(listener.client().send(igtlink::makeMessage("STP_TDATA", "Tracker", igtlink::StopStream{})));
  std::this_thread::sleep_for(100ms);
  listener.take();
  server.publishTools(twoTools(true), 200.0);
  std::this_thread::sleep_for(100ms);
  for (const auto& m : listener.take()) EXPECT_NE(m.header.type, "TDATA");
}

TEST(PlusServerEmulator, ImagesCarryTheirSpacingAndPlacementAsOpenIgtLinkDefinesIt) {
  PlusServerOptions o;
  o.port = 0;
  PlusServerEmulator server(o);
  server.start();
  Listener listener(server.port());
  ASSERT_TRUE(listener.waitConnected(server, 1));
  BModeFrame frame;
  frame.width = 64;
  frame.height = 48;
  frame.spacing_x_mm = 0.2;
  frame.spacing_y_mm = 0.1;
  frame.pixels.assign(64 * 48, 7);
  frame.pixels[5] = 200;
  server.publishImage(frame, 3.0);
  const auto messages = listener.waitFor(1);
  ASSERT_EQ(messages.size(), 1u);
  const auto* image = messages[0].as<igtlink::ImageContent>();
  ASSERT_NE(image, nullptr);
  EXPECT_EQ(messages[0].header.device_name, "Image_Image");
  EXPECT_EQ(image->size[0], 64);
  EXPECT_EQ(image->size[1], 48);
  EXPECT_NEAR(image->spacing().x(), 0.2, 1e-6);
  EXPECT_NEAR(image->spacing().y(), 0.1, 1e-6);
  // The wire holds the centre: pixel (0,0) at the origin means the centre at ((w-1)/2 sx, (h-1)/2 sy).
  EXPECT_NEAR(image->origin().x(), 31.5 * 0.2, 1e-4);
  EXPECT_NEAR(image->origin().y(), 23.5 * 0.1, 1e-4);
  EXPECT_EQ(image->littleEndianPixels()[5], 200);
}

TEST(PlusServerEmulator, ADisconnectClosesClientsAndTheServerComesBackOnTheSamePort) {
  PlusServerOptions o;
  o.port = 0;
  PlusServerEmulator server(o);
  server.start();
  const auto port = server.port();
  Listener listener(port);
  ASSERT_TRUE(listener.waitConnected(server, 1));
  server.stop();
  for (int i = 0; i < 100 && listener.client().connected(); ++i) std::this_thread::sleep_for(10ms);
  EXPECT_FALSE(listener.client().connected());
  server.start();
  EXPECT_EQ(server.port(), port);
  ASSERT_TRUE(listener.waitConnected(server, 1)) << "the client reconnects to the restarted server";
  server.publishTools(twoTools(true), 9.0);
  EXPECT_EQ(listener.waitFor(2).size(), 2u);
}

TEST(PlusServerEmulator, APortInUseIsAClearError) {
  igtlink::ServerOptions taken;
  taken.port = 0;
  igtlink::Server other(taken);
  other.start();
  PlusServerOptions o;
  o.port = other.port();
  PlusServerEmulator server(o);
  try {
    server.start();
    FAIL() << "a port in use must be refused";
  } catch (const NetworkError& e) {
    EXPECT_NE(std::string(e.what()).find("tracker.port"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace mrsns::simulation
