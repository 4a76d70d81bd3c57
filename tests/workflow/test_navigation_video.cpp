// The ultrasound video of a navigation run is recorded with the tracking:
// a PlusServer stand-in (in-process OpenIGTLink server) sends TRANSFORMs at
// 60 Hz and B-mode IMAGEs at 20 Hz; every image sent must be in the video
// recording, pixel for pixel, with its ImageToReference placement, and a
// frame of another size must be refused without stopping navigation.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "mrsns/igtlink/server.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/workflow/navigation.h"
#include "test_data.h"
#include "mrsns/core/wall_clock.h"

namespace mrsns::workflow {
namespace {

using namespace std::chrono_literals;

igtlink::Message bmode(int index, std::uint16_t width, std::uint16_t height, double t) {
  igtlink::ImageContent image;
  image.resizeWhole({width, height, 1});
  for (std::size_t i = 0; i < image.pixels.size(); ++i) {
    image.pixels[i] = static_cast<std::uint8_t>((i * 7 + static_cast<std::size_t>(index) * 13) % 251);
  }
  image.setGeometry(Eigen::Vector3d(0.2, 0.2, 1.0), Eigen::Matrix3d::Identity(),
                    Eigen::Vector3d(10.0 + index, 20.0, 30.0));
  return igtlink::makeMessage("Image_Reference", image, t);
}

TEST(NavigationVideo, EveryImageThePlusServerSendsIsRecordedBesideTheTracking) {
  igtlink::ServerOptions server_options;
  server_options.port = 0;
  igtlink::Server server(server_options);
  server.start();
  const auto dir = test::scratchDirectory("navigation-video");
  NavigationOptions o;
  o.devices.source = "plus";
  o.devices.port = server.port();
  o.recording = dir / "live_1.mhd";
  NavigationLoop loop(o);
  loop.start();
  const auto wait = [](const std::function<bool()>& done, std::chrono::milliseconds deadline) {
    const auto end = std::chrono::steady_clock::now() + deadline;
    while (!done() && std::chrono::steady_clock::now() < end) std::this_thread::sleep_for(5ms);
    return done();
  };
  ASSERT_TRUE(wait([&] { return server.stats().clients == 1; }, 5000ms));

  constexpr int kImages = 24;
  std::vector<double> sent_times;
  Eigen::Isometry3d probe = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 3 * kImages; ++i) {
    const double t = unixTimeSeconds();
    probe.translation() << 40.0 + 0.1 * i, 0, -990;
    server.broadcast(igtlink::makeMessage("ProbeToTracker", igtlink::TransformContent::fromIsometry(probe), t),
                     igtlink::HeaderVersion::kV1, igtlink::Channel::Reliable);
    if (i % 3 == 0) {
      server.broadcast(bmode(i / 3, 64, 48, t), igtlink::HeaderVersion::kV1, igtlink::Channel::Reliable);
      sent_times.push_back(t);
    }
    std::this_thread::sleep_for(16ms);
  }
  // A frame of another size (the user changed the depth): not recorded, navigation goes on.
  server.broadcast(bmode(99, 32, 48, unixTimeSeconds()), igtlink::HeaderVersion::kV1, igtlink::Channel::Reliable);
  ASSERT_TRUE(wait([&] { return loop.status().video_frames_dropped == 1; }, 5000ms)) << loop.status().video_error;
  EXPECT_TRUE(loop.status().running);
  loop.stop();
  server.stop();

  const auto s = loop.status();
  EXPECT_EQ(s.video_frames_recorded, static_cast<std::uint64_t>(kImages));
  EXPECT_EQ(s.video_frames_synced, static_cast<std::uint64_t>(kImages));
  EXPECT_NE(s.video_error.find("32x48x1"), std::string::npos) << s.video_error;
  ASSERT_EQ(s.video_recording, dir / "live_1_video.mhd");

  const auto video = io::readSequence(s.video_recording);
  ASSERT_EQ(video.frames.size(), static_cast<std::size_t>(kImages));
  EXPECT_EQ(video.geometry.size, (std::array<std::int64_t, 3>{64, 48, 1}));
  EXPECT_NEAR(video.geometry.spacing[0], 0.2, 1e-6);
  for (int k = 0; k < kImages; ++k) {
    const auto& f = video.frames[static_cast<std::size_t>(k)];
    EXPECT_NEAR(f.timestamp, sent_times[static_cast<std::size_t>(k)], 1e-3) << k;  // OpenIGTLink's 32-bit fraction
    ASSERT_EQ(f.pixels.size(), 64u * 48u);
    EXPECT_EQ(f.pixels[100], static_cast<std::uint8_t>((100 * 7 + static_cast<std::size_t>(k) * 13) % 251)) << k;
    ASSERT_TRUE(f.transforms.count("ImageToReference")) << k;
    // Voxel (0,0,0): the centre sent minus (size-1)/2 pixels.
    EXPECT_NEAR(f.transforms.at("ImageToReference").matrix(0, 3), 10.0 + k - 31.5 * 0.2, 1e-4) << k;
  }
  // The tracking stream is recorded too, as a tracker buffer.
  const auto tracking = io::readSequence(dir / "live_1.mhd");
  EXPECT_GE(tracking.frames.size(), static_cast<std::size_t>(3 * kImages) - 2);
}

// Without a recording there is no video file either; a simulated tracker
// (no images) never creates one.
TEST(NavigationVideo, NoImagesNoVideoFile) {
  const auto dir = test::scratchDirectory("navigation-no-video");
  NavigationOptions o;
  o.recording = dir / "live_1.mhd";
  NavigationLoop loop(o);
  loop.start();
  std::this_thread::sleep_for(300ms);
  loop.stop();
  EXPECT_EQ(loop.status().video_frames_recorded, 0u);
  EXPECT_TRUE(loop.status().video_recording.empty());
  EXPECT_FALSE(std::filesystem::exists(dir / "live_1_video.mhd"));
  EXPECT_GT(loop.status().frames_synced, 0u);
}

}  // namespace
}  // namespace mrsns::workflow
