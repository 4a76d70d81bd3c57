// The WebXR server's admission and limits, from a TLS client: only its own
// files, nothing before the pairing code, wrong codes refused and then locked
// out, oversized and binary messages dropped from the frame header, and a
// flood of messages and of 100 MB messages from several paired clients held
// to the limits while a good client keeps its stream and memory stays bounded.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "mrsns/core/log.h"
#include "mrsns/webxr/webxr_server.h"
#include "resident_memory.h"
#include "test_data.h"
#include "tls_test_client.h"
#include "wait_for.h"
#include "webxr_test_scene.h"

namespace mrsns::webxr {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

WebXrServerOptions serverOptions() {
  auto options = test::webXrServiceOptions(test::scratchDirectory("tls")).server;
  options.pairing_code = "246810";
  options.handshake_timeout_s = 1.0;
  options.max_failed_pairings = 3;
  options.pairing_lockout_s = 30.0;
  return options;
}

std::string pair(const std::string& code) {
  return R"({"type":"pair","code":")" + code + "\"}";
}

TEST(WebXrServerLimits, ServesItsOwnFilesAndNothingElse) {
  WebXrServer server(serverOptions());
  server.start();
  auto get = [&](const std::string& method, const std::string& path) {
    test::TlsTestClient client(server.port());
    return client.request(method + " " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n");
  };
  const auto page = get("GET", "/?code=1");
  EXPECT_TRUE(page.starts_with("HTTP/1.1 200")) << page.substr(0, 80);
  EXPECT_NE(page.find("Content-Security-Policy: default-src 'self'"), std::string::npos);
  EXPECT_NE(page.find("<canvas id=\"view\">"), std::string::npos);
  EXPECT_TRUE(get("GET", "/three/build/three.module.js").starts_with("HTTP/1.1 200"));
  EXPECT_TRUE(get("GET", "/three/examples/jsm/controls/OrbitControls.js").starts_with("HTTP/1.1 200"));
  EXPECT_TRUE(get("GET", "/etc/passwd").starts_with("HTTP/1.1 404"));
  EXPECT_TRUE(get("GET", "/three/../../../etc/passwd").starts_with("HTTP/1.1 400"));
  EXPECT_TRUE(get("POST", "/").starts_with("HTTP/1.1 405"));
  EXPECT_TRUE(get("GET", "no-slash").starts_with("HTTP/1.1 400"));
}

TEST(WebXrServerLimits, NothingReachesAPageBeforeItsCode) {
  WebXrServer server(serverOptions());
  server.start();
  test::TlsTestClient client(server.port());
  ASSERT_TRUE(client.upgrade());
  for (int i = 0; i < 20; ++i) server.broadcast(textFrame(R"({"type":"transform"})"));
  // Nothing but the close when the pairing time is up.
  const auto frame = client.readFrame();
  ASSERT_TRUE(!frame || frame->opcode == 0x8) << "an unpaired page received: " << frame->payload;
  EXPECT_EQ(server.stats().paired, 0U);
}

TEST(WebXrServerLimits, WrongCodesAreRefusedThenPairingLocksOut) {
  WebXrServer server(serverOptions());
  server.start();
  for (int i = 0; i < 3; ++i) {
    test::TlsTestClient client(server.port());
    ASSERT_TRUE(client.upgrade());
    client.sendText(pair("13579" + std::to_string(i)));
    const auto refused = client.readFrame();
    ASSERT_TRUE(refused);
    EXPECT_NE(refused->payload.find("wrong pairing code"), std::string::npos) << refused->payload;
    const auto close = client.readFrame();
    ASSERT_TRUE(close);
    EXPECT_EQ(close->opcode, 0x8);
    EXPECT_EQ((static_cast<std::uint8_t>(close->payload[0]) << 8) | static_cast<std::uint8_t>(close->payload[1]), 1008);
  }
  // Locked: even the right code is refused now.
  test::TlsTestClient late(server.port());
  ASSERT_TRUE(late.upgrade());
  late.sendText(pair("246810"));
  const auto answer = late.readFrame();
  ASSERT_TRUE(answer);
  EXPECT_NE(answer->payload.find("locked"), std::string::npos) << answer->payload;
  EXPECT_EQ(server.stats().paired, 0U);
  EXPECT_EQ(server.stats().pairings_refused, 4U);
}

TEST(WebXrServerLimits, OversizedAndBinaryMessagesDropTheClient) {
  WebXrServer server(serverOptions());
  std::atomic<int> messages{0};
  server.onMessage([&](WebXrClientId, const std::string&) { ++messages; });
  server.start();
  {
    test::TlsTestClient client(server.port());
    ASSERT_TRUE(client.upgrade());
    client.sendText(pair("246810"));
    ASSERT_EQ(client.readFrame()->payload, R"({"type":"paired"})");
    // A 100 MB message's header, then some of its body: dropped at the header.
    std::vector<std::uint8_t> header{0x81, 0xFF};
    for (int s = 56; s >= 0; s -= 8) header.push_back(static_cast<std::uint8_t>((100ULL << 20) >> s));
    header.insert(header.end(), {1, 2, 3, 4});
    client.sendRaw(header);
    client.sendRaw(std::vector<std::uint8_t>(1 << 16, 0x55));
    const auto close = client.readFrame();
    ASSERT_TRUE(close);
    EXPECT_EQ(close->opcode, 0x8);
    EXPECT_EQ((static_cast<std::uint8_t>(close->payload[0]) << 8) | static_cast<std::uint8_t>(close->payload[1]), 1009);
  }
  {
    test::TlsTestClient client(server.port());
    ASSERT_TRUE(client.upgrade());
    client.sendText(pair("246810"));
    ASSERT_TRUE(client.readFrame());
    client.sendRaw({0x82, 0x81, 1, 2, 3, 4, 5});  // a binary message
    const auto close = client.readFrame();
    ASSERT_TRUE(close);
    EXPECT_EQ((static_cast<std::uint8_t>(close->payload[0]) << 8) | static_cast<std::uint8_t>(close->payload[1]), 1003);
  }
  EXPECT_TRUE(test::waitFor([&] { return server.stats().clients_dropped == 2; }, 2s));
  EXPECT_EQ(messages.load(), 0);
}

/// A paired page sending 100 MB messages, one after another, until told to stop.
int hugeMessages(std::uint16_t port, const std::atomic<bool>& stop) {
  int refused = 0;
  std::vector<std::uint8_t> header{0x81, 0xFF};
  for (int s = 56; s >= 0; s -= 8) header.push_back(static_cast<std::uint8_t>((100ULL << 20) >> s));
  header.insert(header.end(), {9, 8, 7, 6});
  const std::vector<std::uint8_t> body(1 << 20, 0x41);
  while (!stop) {
    test::TlsTestClient client(port);
    if (!client.upgrade() || !client.sendText(pair("246810"))) return refused;
    client.sendRaw(header);
    for (int mb = 0; mb < 100 && !stop && client.sendRaw(body); ++mb) {
    }
    ++refused;
  }
  return refused;
}

TEST(WebXrServerLimits, AFloodIsHeldToTheRateAndTheGoodPageKeepsItsStream) {
  auto options = serverOptions();
  options.max_client_messages_per_second = 200.0;
  WebXrServer server(options);
  std::atomic<std::uint64_t> received{0};
  server.onMessage([&](WebXrClientId, const std::string&) { ++received; });
  server.start();

  test::TlsTestClient good(server.port());
  ASSERT_TRUE(good.upgrade());
  good.sendText(pair("246810"));
  ASSERT_TRUE(good.readFrame());

  constexpr int kFlooders = 3;
  constexpr double kFloodSeconds = 2.0;
  const double idle_mb = test::residentMegabytes();
  std::atomic<bool> stop{false};
  std::atomic<std::uint64_t> sent{0};
  std::atomic<int> huge_refused{0};
  std::vector<std::thread> flooders;
  for (int h = 0; h < 2; ++h) flooders.emplace_back([&] { huge_refused += hugeMessages(server.port(), stop); });
  for (int f = 0; f < kFlooders; ++f) {
    flooders.emplace_back([&] {
      test::TlsTestClient client(server.port());
      if (!client.upgrade() || !client.sendText(pair("246810"))) return;
      const std::string message = R"({"type":"confirm","text":")" + std::string(3000, 'x') + "\"}";
      while (!stop && client.sendText(message)) ++sent;
    });
  }
  // The workstation streams 100 poses a second to everyone meanwhile.
  std::vector<double> gaps_ms;
  auto last = Clock::now();
  std::thread streamer([&] {
    for (int i = 0; !stop; ++i) {
      server.broadcast(textFrame(R"({"type":"transform","seq":)" + std::to_string(i) + "}"));
      std::this_thread::sleep_for(10ms);
    }
  });
  const auto start = Clock::now();
  good.setTimeout(1.0);
  double peak_mb = idle_mb;
  while (Clock::now() - start < std::chrono::duration<double>(kFloodSeconds)) {
    peak_mb = std::max(peak_mb, test::residentMegabytes());
    const auto frame = good.readFrame();
    ASSERT_TRUE(frame) << "the good page lost its stream during the flood";
    const auto now = Clock::now();
    if (frame->payload.find("transform") != std::string::npos) {
      gaps_ms.push_back(std::chrono::duration<double, std::milli>(now - last).count());
      last = now;
    }
  }
  stop = true;
  streamer.join();
  for (auto& t : flooders) t.join();
  const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  std::sort(gaps_ms.begin(), gaps_ms.end());
  std::cout << "[ webxr ] flood: " << sent.load() << " messages written by " << kFlooders << " clients, "
            << received.load() << " read; " << huge_refused.load()
            << " messages of 100 MB refused; good page: " << gaps_ms.size() << " poses, largest gap " << gaps_ms.back()
            << " ms; memory " << peak_mb - idle_mb << " MB above idle at the peak" << std::endl;
  // The token bucket: at most a bucket (one second's worth) plus the rate per client over the run.
  EXPECT_LE(static_cast<double>(received.load()), kFlooders * options.max_client_messages_per_second * (elapsed + 1.5));
  EXPECT_GT(gaps_ms.size(), 0.7 * kFloodSeconds * 100);
  EXPECT_LT(gaps_ms.back(), 250.0);
  EXPECT_GE(huge_refused.load(), 2);
  EXPECT_LT(peak_mb - idle_mb, 100.0) << "the server stored what it should have refused";
}

}  // namespace
}  // namespace mrsns::webxr
