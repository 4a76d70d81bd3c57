// The hologram stream is send-only and reads little: a client message over a
// few KB is refused at its header (its body is never stored), a client
// flooding messages is read at a bounded rate, and neither disturbs a good
// headset's stream, its confirmations or the server's memory. Loopback only,
// bounded in time (2 s of attack) and size (one 100 MB message at a time).
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <fstream>
#include <thread>

#include "mrsns/core/log.h"
#include "mrsns/igtlink/codec.h"
#include "mrsns/igtlink/crc64.h"
#include "mrsns/tracking/hologram_streamer.h"
#include "mrsns/tracking/simulated_source.h"
#include "resident_memory.h"
#include "tracking_test_util.h"

namespace mrsns::tracking {
namespace {

using test::waitFor;

enum class SendResult { kSent, kClosedByPeer, kStopped };

// Sends `bytes` without blocking forever: a server that stops reading (a
// paused flooder) leaves the socket full until `stop`.
SendResult sendUntil(int fd, std::span<const std::uint8_t> bytes, const std::atomic<bool>& stop) {
  std::size_t offset = 0;
  while (offset < bytes.size()) {
    if (stop.load()) return SendResult::kStopped;
    const auto n = ::send(fd, bytes.data() + offset, bytes.size() - offset, MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n > 0) {
      offset += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
      pollfd p{fd, POLLOUT, 0};
      ::poll(&p, 1, 10);
      if ((p.revents & (POLLERR | POLLHUP)) != 0) return SendResult::kClosedByPeer;
      continue;
    }
    return SendResult::kClosedByPeer;
  }
  return SendResult::kSent;
}

// A header asking for a body of `body_size` bytes, then that many bytes in
// 1 MiB pieces until the server hangs up. Returns the bytes it got to send.
std::uint64_t sendHugeMessage(std::uint16_t port, const std::string& type, const std::string& device,
                              std::uint64_t body_size, const std::atomic<bool>& stop) {
  const int fd = test::connectRaw(port);
  if (fd < 0) return 0;
  igtlink::Header header;
  header.type = type;
  header.device_name = device;
  header.body_size = body_size;
  const auto header_bytes = igtlink::encodeHeader(header);
  std::uint64_t sent = 0;
  if (sendUntil(fd, header_bytes, stop) == SendResult::kSent) {
    sent += header_bytes.size();
    static const std::vector<std::uint8_t> piece(1 << 20, 0x5A);
    while (sent < body_size + header_bytes.size()) {
      const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(piece.size(), body_size + header_bytes.size() - sent));
      if (sendUntil(fd, std::span(piece.data(), n), stop) != SendResult::kSent) break;
      sent += n;
    }
  }
  ::close(fd);
  return sent;
}

std::vector<std::uint8_t> slicerStatus() {
  // What Slicer's OpenIGTLinkIF sends first when it connects as a client: a v2 STATUS.
  auto message = igtlink::makeMessage("Slicer", igtlink::StatusContent{1, 0, "", "OK"});
  message.header.version = 2;
  message.metadata.push_back({"Status", igtlink::kEncodingUsAscii, "Connected"});
  return igtlink::encodeMessage(message, igtlink::HeaderVersion::kV2);
}

struct OneModelStream {
  explicit OneModelStream(HologramStreamOptions options = {}) {
    igtlink::ServerOptions server_options = test::loopback();
    server_options.incomplete_message_timeout_s = 0.5;
    server = std::make_unique<igtlink::Server>(server_options);
    repository->setTransform("ReferenceToTracker", Eigen::Isometry3d::Identity(), TransformStatus::Ok, 1.0, true);
    options.hologram_frame = "Tracker";
    options.client_log_interval_s = 10.0;
    streamer = std::make_unique<HologramStreamer>(*server, repository,
                                                  std::vector<HologramModel>{{"Spine", test::tetrahedron(), "Reference"}},
                                                  options);
    server->start();
  }
  ~OneModelStream() { server->stop(); }
  std::shared_ptr<TransformRepository> repository = std::make_shared<TransformRepository>();
  std::unique_ptr<igtlink::Server> server;
  std::unique_ptr<HologramStreamer> streamer;
};

class QuietLog {
 public:
  QuietLog() { mrsns::setLogLevel("critical"); }
  ~QuietLog() { mrsns::setLogLevel("warn"); }
};

TEST(StreamInboundLimits, AMessageOverAFewKilobytesIsRefusedAtItsHeader) {
  QuietLog quiet;
  OneModelStream stream;
  const std::atomic<bool> never{false};
  const double idle_mb = mrsns::test::residentMegabytes();
  const std::uint64_t sent = sendHugeMessage(stream.server->port(), "POLYDATA", "Huge", 100'000'000, never);
  ASSERT_TRUE(waitFor([&] { return stream.server->stats().clients_closed_for_protocol_errors == 1; }));
  // Disconnected at the header: what got out before the reset sat in the socket buffers, never in the server.
  EXPECT_LT(sent, 100'000'000U);
  EXPECT_LT(mrsns::test::residentMegabytes() - idle_mb, 20.0);

  // Just over the limit is refused too; at the limit is read (and ignored: the stream is send-only).
  std::vector<std::uint8_t> at_limit_body(kMaxClientMessageBodyBytes, 0);
  igtlink::Header header;
  header.type = "FOO";
  header.device_name = "Big";
  header.body_size = kMaxClientMessageBodyBytes + 1;
  const auto over = igtlink::encodeHeader(header);
  const int over_fd = test::connectRaw(stream.server->port());
  ASSERT_GE(over_fd, 0);
  ASSERT_EQ(sendUntil(over_fd, over, never), SendResult::kSent);
  ASSERT_TRUE(waitFor([&] { return stream.server->stats().clients_closed_for_protocol_errors == 2; }));
  ::close(over_fd);

  test::Recorder slicer(stream.server->port());
  ASSERT_TRUE(waitFor([&] { return stream.streamer->readyClients() == 1; }));
  header.body_size = kMaxClientMessageBodyBytes;
  header.crc = igtlink::crc64(at_limit_body);
  const auto at_limit_header = igtlink::encodeHeader(header);
  std::vector<std::uint8_t> at_limit(at_limit_header.begin(), at_limit_header.end());
  at_limit.insert(at_limit.end(), at_limit_body.begin(), at_limit_body.end());
  const int ok_fd = test::connectRaw(stream.server->port());
  ASSERT_GE(ok_fd, 0);
  ASSERT_EQ(sendUntil(ok_fd, at_limit, never), SendResult::kSent);
  ASSERT_EQ(sendUntil(ok_fd, slicerStatus(), never), SendResult::kSent);
  EXPECT_TRUE(waitFor([&] { return stream.streamer->stats().client_messages_ignored >= 2; }));
  EXPECT_EQ(stream.server->stats().clients_closed_for_protocol_errors, 2U);
  ::close(ok_fd);
  EXPECT_EQ(slicer.client().stats().connects, 1U);
}

TEST(StreamInboundLimits, OnlyTheCameraPhotoMayBeLargeAndOnlyWhenPhotosAreAsked) {
  QuietLog quiet;
  const std::atomic<bool> never{false};
  {
    OneModelStream no_photos;  // a photo is like any other message: a few KB
    sendHugeMessage(no_photos.server->port(), "IMAGE", kCameraImageDevice, 1'000'000, never);
    EXPECT_TRUE(waitFor([&] { return no_photos.server->stats().clients_closed_for_protocol_errors == 1; }));
  }
  HologramStreamOptions options;
  options.on_camera_image = [](igtlink::ClientId, HeadsetCameraImage) {};
  OneModelStream photos(options);
  // A photo-sized IMAGE from the camera device is read: cut short, the stalled message is what closes it.
  const int fd = test::connectRaw(photos.server->port());
  ASSERT_GE(fd, 0);
  igtlink::Header header;
  header.type = "IMAGE";
  header.device_name = kCameraImageDevice;
  header.body_size = 1'000'000;
  const auto bytes = igtlink::encodeHeader(header);
  ASSERT_EQ(sendUntil(fd, bytes, never), SendResult::kSent);
  const std::vector<std::uint8_t> part(100'000, 0);
  ASSERT_EQ(sendUntil(fd, part, never), SendResult::kSent);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_EQ(photos.server->stats().clients_closed_for_protocol_errors, 0U);
  ::close(fd);
  // Larger than the largest photo, or the same size from another device or of another type: refused at the header.
  sendHugeMessage(photos.server->port(), "IMAGE", kCameraImageDevice, kMaxCameraImageBodyBytes + 1, never);
  sendHugeMessage(photos.server->port(), "IMAGE", "Other", 1'000'000, never);
  sendHugeMessage(photos.server->port(), "POLYDATA", kCameraImageDevice, 1'000'000, never);
  EXPECT_TRUE(waitFor([&] { return photos.server->stats().clients_closed_for_protocol_errors == 3; }));
}

TEST(StreamInboundLimits, FloodsAndHugeMessagesFromSeveralClientsLeaveTheGoodHeadsetAlone) {
  QuietLog quiet;
  auto repository = std::make_shared<TransformRepository>();
  SimulatorOptions sim;
  sim.rate_hz = 1000.0;
  ToolScript reference;
  reference.name = "ReferenceToTracker";
  sim.tools = {reference};
  SimulatedTrackingSource source(repository, sim);

  igtlink::ServerOptions server_options = test::loopback();
  server_options.decode.max_body_size = 256ULL * 1024 * 1024;  // the library's ceiling: the streamer's limits hold
  igtlink::Server server(server_options);
  std::atomic<int> confirmations{0};
  HologramStreamOptions stream_options;
  stream_options.hologram_frame = "Tracker";
  stream_options.client_log_interval_s = 10.0;
  stream_options.on_confirmation = [&](igtlink::ClientId, const std::string&) { ++confirmations; };
  HologramStreamer streamer(server, repository, {{"Spine", test::tetrahedron(), "Reference"}}, stream_options);
  source.setUpdateCallback([&](std::span<const ToolUpdate> updates) { streamer.update(updates.front().timestamp); });
  server.start();
  test::Recorder good(server.port());
  ASSERT_TRUE(waitFor([&] { return streamer.readyClients() == 1; }));
  source.start();
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  const double idle_mb = mrsns::test::residentMegabytes();

  std::atomic<bool> stop{false};
  std::atomic<double> peak_mb{idle_mb};
  std::thread sampler([&] {
    while (!stop.load()) {
      peak_mb = std::max(peak_mb.load(), mrsns::test::residentMegabytes());
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  });
  // Four clients each send Slicer's STATUS as fast as the socket takes it (a thousand per send).
  std::vector<std::uint8_t> batch;
  const auto status = slicerStatus();
  for (int i = 0; i < 1000; ++i) batch.insert(batch.end(), status.begin(), status.end());
  constexpr int kFlooders = 4;
  std::vector<std::thread> attackers;
  std::atomic<std::uint64_t> flood_sent{0};
  for (int t = 0; t < kFlooders; ++t) {
    attackers.emplace_back([&] {
      while (!stop.load()) {
        const int fd = test::connectRaw(server.port());
        if (fd < 0) continue;
        while (sendUntil(fd, batch, stop) == SendResult::kSent) flood_sent += 1000;
        ::close(fd);
      }
    });
  }
  // Two clients send 100 MB messages one after the other.
  std::atomic<int> huge_attempts{0};
  for (int t = 0; t < 2; ++t) {
    attackers.emplace_back([&] {
      while (!stop.load()) {
        sendHugeMessage(server.port(), "POLYDATA", "Huge", 100'000'000, stop);
        ++huge_attempts;
      }
    });
  }
  // The operator confirms every 100 ms from the good headset.
  int confirmations_sent = 0;
  const auto attack_end = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  const auto attack_start = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() < attack_end) {
    auto confirm = igtlink::makeMessage("Confirm", igtlink::StringContent{igtlink::kEncodingUsAscii, "ok"});
    if (good.client().send(confirm)) ++confirmations_sent;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  const double attack_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - attack_start).count();
  const auto stats_at_end = server.stats();
  stop = true;
  for (auto& thread : attackers) thread.join();
  sampler.join();
  source.stop();
  EXPECT_TRUE(waitFor([&] { return confirmations.load() == confirmations_sent; }, 5.0));
  const auto stats = server.stats();
  server.stop();

  const auto received = good.messages();
  std::vector<std::chrono::steady_clock::time_point> arrivals;
  std::vector<double> sent_times;
  for (const auto& r : received) {
    if (r.message.header.type == "TRANSFORM" && r.message.header.device_name == "Spine") {
      arrivals.push_back(r.at);
      sent_times.push_back(r.message.header.timestampSeconds());
    }
  }
  ASSERT_GT(arrivals.size(), 100U);
  const test::AddedGaps added = test::addedGaps(arrivals, sent_times);
  const double rate_hz = static_cast<double>(arrivals.size() - 1) /
                         std::chrono::duration<double>(arrivals.back() - arrivals.front()).count();
  const double flood_read = static_cast<double>(stats_at_end.messages_received) - confirmations_sent;
  std::printf(
      "inbound limits: %zu transforms at %.0f Hz, largest gap added by the stream %.2f ms (p99 %.2f ms); memory %.1f MB idle, "
      "peak +%.1f MB; %llu flood messages sent, %.0f read in %.2f s (%llu pauses); %d messages of 100 MB "
      "started, %llu clients closed; %d of %d confirmations\n",
      arrivals.size(), rate_hz, added.max_ms, added.p99_ms, idle_mb, peak_mb.load() - idle_mb,
      static_cast<unsigned long long>(flood_sent.load()), flood_read, attack_s,
      static_cast<unsigned long long>(stats.inbound_pauses), huge_attempts.load(),
      static_cast<unsigned long long>(stats.clients_closed_for_protocol_errors), confirmations.load(),
      confirmations_sent);
  RecordProperty("peak_memory_above_idle_mb", std::to_string(peak_mb.load() - idle_mb));
  RecordProperty("max_added_gap_ms", std::to_string(added.max_ms));
  RecordProperty("p99_added_gap_ms", std::to_string(added.p99_ms));
  // The attacks happened and were held back: the 100 MB messages refused at their headers, the flood read at
  // no more than kMaxClientMessagesPerSecond per connection (each new connection starts with a burst of that many).
  EXPECT_GE(huge_attempts.load(), 2);
  EXPECT_GE(stats.clients_closed_for_protocol_errors, static_cast<std::uint64_t>(huge_attempts.load()) - 2);
  EXPECT_GT(stats.inbound_pauses, 0U);
  EXPECT_GT(static_cast<double>(flood_sent.load()), 2.0 * flood_read);
  // The good headset: connected throughout, its stream within the bounds of the robustness test, every confirmation.
  EXPECT_EQ(good.client().stats().connects, 1U);
  EXPECT_LT(added.p99_ms, test::kAddedGapP99BoundMs);
  EXPECT_LT(added.max_ms, test::kAddedGapMaxBoundMs);
  EXPECT_GT(rate_hz, 300.0);
  EXPECT_GE(confirmations_sent, 15);
  EXPECT_EQ(confirmations.load(), confirmations_sent);
  // The bound on the server's memory.
  EXPECT_LT(peak_mb.load() - idle_mb, 100.0);
}

}  // namespace
}  // namespace mrsns::tracking
