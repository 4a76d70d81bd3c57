#pragma once
// OpenIGTLink client on TCP (standalone Asio, one I/O thread) that keeps
// itself connected: after a refused or lost connection it retries with
// exponential back-off. Used to receive from PlusServer or 3D Slicer.
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "mrsns/igtlink/codec.h"
#include "mrsns/igtlink/message.h"

namespace mrsns::igtlink {

struct ClientOptions {
  std::string host = "127.0.0.1";
  std::uint16_t port = 18944;
  bool reconnect = true;
  double backoff_initial_s = 0.1;
  double backoff_max_s = 5.0;
  DecodeOptions decode;
};

struct ClientStats {
  bool connected = false;
  std::uint64_t connects = 0;
  std::uint64_t messages_received = 0;
  std::uint64_t malformed_messages = 0;
  std::uint64_t messages_sent = 0;
};

class Client {
 public:
  using MessageHandler = std::function<void(const Message&)>;
  using ConnectionHandler = std::function<void(bool connected)>;

  explicit Client(ClientOptions options = {});
  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  /// Handlers run on the client's I/O thread; set them before start().
  void onMessage(MessageHandler handler);
  void onConnectionChange(ConnectionHandler handler);

  /// Starts connecting (returns at once). Throws NetworkError when the host
  /// name cannot be resolved.
  void start();
  void stop();
  /// Queues a message; false when not connected (nothing is queued then).
  bool send(const Message& message, HeaderVersion version = HeaderVersion::kV1);
  [[nodiscard]] bool connected() const;
  [[nodiscard]] ClientStats stats() const;

 private:
  struct Impl;
  std::shared_ptr<Impl> impl_;
};

}  // namespace mrsns::igtlink
