#include <gtest/gtest.h>

#include <atomic>
#include <mutex>

#include "mrsns/core/error.h"
#include "mrsns/igtlink/client.h"
#include "mrsns/igtlink/server.h"
#include "net_test_util.h"

namespace mrsns::igtlink {
namespace {

using test::waitFor;

ServerOptions loopbackOptions() {
  ServerOptions options;
  options.port = 0;  // a free port
  return options;
}

struct Received {
  std::mutex mutex;
  std::vector<Message> messages;
  void add(const Message& m) {
    std::lock_guard lock(mutex);
    messages.push_back(m);
  }
  std::size_t size() {
    std::lock_guard lock(mutex);
    return messages.size();
  }
};

TEST(IgtlServer, BindsLoopbackByDefault) {
  ServerOptions defaults;
  EXPECT_EQ(defaults.bind_address, "127.0.0.1");
}

TEST(IgtlServer, ClientReceivesModelsOnConnectThenStreamInOrder) {
  Server server(loopbackOptions());
  server.onConnect([&server](ClientId id) {
    server.send(id, test::stringMessage("Model", "vertebra C5"), HeaderVersion::kV2, Channel::Reliable);
  });
  server.start();
  ClientOptions client_options;
  client_options.port = server.port();
  Client client(client_options);
  Received received;
  client.onMessage([&](const Message& m) { received.add(m); });
  client.start();
  ASSERT_TRUE(waitFor([&] { return received.size() >= 1; }));
  for (int i = 0; i < 100; ++i) {
    server.broadcast(test::transformMessage("ProbeToTracker", i), HeaderVersion::kV1, Channel::Reliable);
  }
  ASSERT_TRUE(waitFor([&] { return received.size() >= 101; }));
  std::lock_guard lock(received.mutex);
  ASSERT_NE(received.messages[0].as<StringContent>(), nullptr);
  EXPECT_EQ(received.messages[0].as<StringContent>()->text, "vertebra C5");
  EXPECT_EQ(received.messages[0].header.version, 2);
  for (int i = 0; i < 100; ++i) {
    const auto* t = received.messages[static_cast<std::size_t>(i + 1)].as<TransformContent>();
    ASSERT_NE(t, nullptr);
    EXPECT_FLOAT_EQ(static_cast<float>(t->matrix(0, 3)), static_cast<float>(i));
  }
}

TEST(IgtlServer, ClientMessagesReachTheHandler) {
  Server server(loopbackOptions());
  std::atomic<int> got{0};
  server.onMessage([&](ClientId, const Message& m) {
    if (m.header.type == "STRING") got.fetch_add(1);
  });
  server.start();
  ClientOptions options;
  options.port = server.port();
  Client client(options);
  client.start();
  ASSERT_TRUE(waitFor([&] { return client.connected(); }));
  EXPECT_TRUE(client.send(test::stringMessage("Cmd", "hello")));
  EXPECT_TRUE(waitFor([&] { return got.load() == 1; }));
}

TEST(IgtlServer, SlowClientDoesNotSlowOthersAndLosesOnlyOldStreamMessages) {
  auto options = loopbackOptions();
  options.stream_queue_limit = 4;
  Server server(options);
  server.start();
  // A client that connects and never reads: its kernel buffers fill up.
  test::RawConnection stalled(server.port());
  asio::socket_base::receive_buffer_size small(4096);
  stalled.socket().set_option(small);
  ClientOptions client_options;
  client_options.port = server.port();
  Client good(client_options);
  Received received;
  good.onMessage([&](const Message& m) { received.add(m); });
  good.start();
  ASSERT_TRUE(waitFor([&] { return server.stats().clients == 2 && good.connected(); }));
  // 2000 stream messages of ~100 bytes: far more than the stalled client's buffers.
  const int count = 2000;
  for (int i = 0; i < count; ++i) {
    server.broadcast(test::transformMessage("ProbeToTracker", i), HeaderVersion::kV1, Channel::Stream);
    if (i % 50 == 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  // The good client gets the newest message; the stalled one made the server drop.
  ASSERT_TRUE(waitFor([&] {
    std::lock_guard lock(received.mutex);
    return !received.messages.empty() &&
           received.messages.back().as<TransformContent>()->matrix(0, 3) == static_cast<double>(count - 1);
  }));
  EXPECT_GT(server.stats().stream_messages_dropped, 0u);
  // Whatever the good client got is in increasing order (no reordering).
  std::lock_guard lock(received.mutex);
  for (std::size_t i = 1; i < received.messages.size(); ++i) {
    EXPECT_LT(received.messages[i - 1].as<TransformContent>()->matrix(0, 3),
              received.messages[i].as<TransformContent>()->matrix(0, 3));
  }
}

TEST(IgtlServer, GarbageHeaderClosesThatClientOnly) {
  Server server(loopbackOptions());
  server.start();
  ClientOptions client_options;
  client_options.port = server.port();
  Client good(client_options);
  Received received;
  good.onMessage([&](const Message& m) { received.add(m); });
  good.start();
  ASSERT_TRUE(waitFor([&] { return good.connected(); }));
  test::RawConnection bad(server.port());
  bad.send(std::vector<std::uint8_t>(58, 0xAB));  // version 0xABAB: not OpenIGTLink
  EXPECT_TRUE(bad.closedByPeer());
  server.broadcast(test::transformMessage("ProbeToTracker", 1), HeaderVersion::kV1, Channel::Reliable);
  EXPECT_TRUE(waitFor([&] { return received.size() == 1; }));
  EXPECT_GE(server.stats().clients_closed_for_protocol_errors, 1u);
}

TEST(IgtlServer, OversizedBodyIsRefusedBeforeAllocation) {
  auto options = loopbackOptions();
  options.decode.max_body_size = 1024 * 1024;
  Server server(options);
  server.start();
  test::RawConnection bad(server.port());
  auto bytes = encodeMessage(test::stringMessage("Big", "x"), HeaderVersion::kV1);
  // body_size field (offset 42, 8 bytes big endian) claims 1 TiB.
  const std::uint64_t huge = 1ULL << 40;
  for (int i = 0; i < 8; ++i) bytes[42 + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(huge >> (56 - 8 * i));
  bad.send(bytes);
  EXPECT_TRUE(bad.closedByPeer());
}

TEST(IgtlServer, BadCrcSkipsTheMessageButKeepsTheConnection) {
  Server server(loopbackOptions());
  std::atomic<int> good_messages{0};
  server.onMessage([&](ClientId, const Message&) { good_messages.fetch_add(1); });
  server.start();
  test::RawConnection client(server.port());
  auto corrupt = encodeMessage(test::stringMessage("A", "hello"), HeaderVersion::kV1);
  corrupt.back() ^= 0xFF;  // body changed, CRC no longer matches
  client.send(corrupt);
  client.send(encodeMessage(test::stringMessage("B", "world"), HeaderVersion::kV1));
  EXPECT_TRUE(waitFor([&] { return good_messages.load() == 1; }));
  EXPECT_EQ(server.stats().malformed_messages, 1u);
  EXPECT_FALSE(client.closedByPeer(0.2));
}

TEST(IgtlServer, StalledHalfMessageIsClosedAfterTimeout) {
  auto options = loopbackOptions();
  options.incomplete_message_timeout_s = 0.3;
  Server server(options);
  server.start();
  test::RawConnection slow(server.port());
  auto bytes = encodeMessage(test::stringMessage("A", "hello"), HeaderVersion::kV1);
  bytes.resize(30);  // half a header, then silence
  slow.send(bytes);
  EXPECT_TRUE(slow.closedByPeer(3.0));
}

TEST(IgtlServer, RefusesClientsBeyondTheLimit) {
  auto options = loopbackOptions();
  options.max_clients = 2;
  Server server(options);
  server.start();
  test::RawConnection a(server.port());
  test::RawConnection b(server.port());
  ASSERT_TRUE(waitFor([&] { return server.stats().clients == 2; }));
  test::RawConnection c(server.port());
  EXPECT_TRUE(c.closedByPeer());
  EXPECT_EQ(server.stats().connections_refused, 1u);
  EXPECT_FALSE(a.closedByPeer(0.1));
}

TEST(IgtlServer, PortInUseAndBadAddressGiveNetworkErrors) {
  Server first(loopbackOptions());
  first.start();
  ServerOptions same;
  same.port = first.port();
  Server second(same);
  try {
    second.start();
    FAIL() << "expected NetworkError";
  } catch (const NetworkError& e) {
    EXPECT_NE(std::string(e.what()).find("another server"), std::string::npos) << e.what();
  }
  ServerOptions bad;
  bad.bind_address = "localhost:80";
  EXPECT_THROW(Server(bad).start(), NetworkError);
}

TEST(IgtlClient, ReconnectsWhenTheServerComesBack) {
  Server probe(loopbackOptions());
  probe.start();
  const auto port = probe.port();
  probe.stop();
  ClientOptions options;
  options.port = port;
  options.backoff_initial_s = 0.02;
  options.backoff_max_s = 0.1;
  Client client(options);
  std::atomic<int> connects{0};
  client.onConnectionChange([&](bool up) {
    if (up) connects.fetch_add(1);
  });
  client.start();
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_FALSE(client.connected());
  ServerOptions again;
  again.port = port;
  {
    Server server(again);
    server.start();
    ASSERT_TRUE(waitFor([&] { return client.connected(); }));
    server.stop();
  }
  ASSERT_TRUE(waitFor([&] { return !client.connected(); }));
  Server third(again);
  third.start();
  EXPECT_TRUE(waitFor([&] { return client.connected() && connects.load() == 2; }));
}

TEST(IgtlClient, UnresolvableHostIsANetworkError) {
  ClientOptions options;
  options.host = "no-such-host.invalid";
  Client client(options);
  EXPECT_THROW(client.start(), NetworkError);
}

}  // namespace
}  // namespace mrsns::igtlink
