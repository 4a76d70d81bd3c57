// Server::sendEncoded: bytes encoded once, queued for one client only, in
// order with that client's other messages; false for a client that is gone.
#include <gtest/gtest.h>

#include <mutex>

#include "mrsns/igtlink/client.h"
#include "mrsns/igtlink/server.h"
#include "net_test_util.h"

namespace mrsns::igtlink {
namespace {

using test::waitFor;

TEST(IgtlServer, SendEncodedReachesOnlyThatClientInOrder) {
  ServerOptions options;
  options.port = 0;
  Server server(options);
  std::mutex mutex;
  std::vector<ClientId> ids;
  server.onConnect([&](ClientId id) {
    std::lock_guard lock(mutex);
    ids.push_back(id);
  });
  server.start();
  std::vector<std::unique_ptr<Client>> clients;
  std::vector<std::vector<std::string>> received(2);
  std::mutex received_mutex;
  for (int i = 0; i < 2; ++i) {
    ClientOptions client_options;
    client_options.port = server.port();
    clients.push_back(std::make_unique<Client>(client_options));
    clients.back()->onMessage([&, i](const Message& m) {
      std::lock_guard lock(received_mutex);
      received[i].push_back(m.header.device_name);
    });
    clients.back()->start();
    ASSERT_TRUE(waitFor([&] {
      std::lock_guard lock(mutex);
      return ids.size() == static_cast<std::size_t>(i + 1);
    }));
  }
  const auto model = std::make_shared<const std::vector<std::uint8_t>>(
      encodeMessage(test::stringMessage("Model", "mesh"), HeaderVersion::kV2));
  ASSERT_TRUE(server.sendEncoded(ids[1], model, Channel::Reliable));
  for (int k = 0; k < 5; ++k) {
    server.sendEncoded(ids[1],
                       std::make_shared<const std::vector<std::uint8_t>>(
                           encodeMessage(test::transformMessage("Pose" + std::to_string(k), k))),
                       Channel::Stream);
  }
  ASSERT_TRUE(waitFor([&] {
    std::lock_guard lock(received_mutex);
    return received[1].size() == 6;
  }));
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  {
    std::lock_guard lock(received_mutex);
    EXPECT_TRUE(received[0].empty());
    EXPECT_EQ(received[1], (std::vector<std::string>{"Model", "Pose0", "Pose1", "Pose2", "Pose3", "Pose4"}));
  }
  EXPECT_FALSE(server.sendEncoded(9999, model, Channel::Reliable));
  for (auto& c : clients) c->stop();
  server.stop();
}

}  // namespace
}  // namespace mrsns::igtlink
