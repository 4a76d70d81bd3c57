#pragma once
// OpenIGTLink server on TCP (standalone Asio, one I/O thread).
//
// Many clients; one send queue per client. Messages go on one of two
// channels: Stream (tracking: when a client falls behind, the oldest queued
// stream message is dropped, so it always gets the newest pose) and Reliable
// (meshes, status: never dropped; a client whose reliable backlog exceeds a
// byte limit is disconnected instead). A slow client never slows the others
// or the producer: broadcast() only enqueues.
//
// Incoming messages are decoded with the size limits of DecodeOptions; a
// message with a bad body is counted and skipped, a stream that cannot be
// framed any more (bad header, oversized body) or that stalls mid-message is
// closed. A server that expects little from its clients (the hologram stream
// only sends) limits each message's size by its header and each client's
// message rate (limitInbound). Binds 127.0.0.1 unless told otherwise.
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "mrsns/igtlink/codec.h"
#include "mrsns/igtlink/framer.h"
#include "mrsns/igtlink/message.h"

namespace mrsns::igtlink {

enum class Channel { Stream, Reliable };

using ClientId = std::uint64_t;

struct ServerOptions {
  std::string bind_address = "127.0.0.1";
  /// 0 picks a free port (see Server::port()).
  std::uint16_t port = 18944;
  std::size_t max_clients = 64;
  /// Stream messages queued per client before the oldest is dropped.
  std::size_t stream_queue_limit = 16;
  /// Reliable bytes queued per client before it is disconnected as too slow.
  std::size_t reliable_queue_limit_bytes = 512ULL * 1024 * 1024;
  /// A client that leaves a message incomplete this long is disconnected.
  double incomplete_message_timeout_s = 10.0;
  DecodeOptions decode;
};

/// What a client may send (Server::limitInbound).
struct InboundLimits {
  /// The largest body of a message, decided from its header before any of the
  /// body is stored; a client whose header asks for more is disconnected.
  /// Empty: ServerOptions::decode.max_body_size for every message (always the
  /// ceiling).
  BodyLimit max_body_size;
  /// Messages a client may send per second on average, and at once. A client
  /// over it is not read until it is back under: TCP holds its data on its
  /// side, so a flood costs the server neither memory nor time. 0: unlimited.
  double max_messages_per_s = 0.0;
};

struct ServerStats {
  std::size_t clients = 0;
  std::uint64_t connections_accepted = 0;
  std::uint64_t connections_refused = 0;  ///< over max_clients
  std::uint64_t messages_sent = 0;
  std::uint64_t stream_messages_dropped = 0;
  std::uint64_t messages_received = 0;
  std::uint64_t malformed_messages = 0;
  std::uint64_t clients_closed_for_protocol_errors = 0;
  std::uint64_t clients_closed_as_too_slow = 0;
  /// Times a client's reading was paused for sending too many messages.
  std::uint64_t inbound_pauses = 0;
};

class Server {
 public:
  using ConnectHandler = std::function<void(ClientId)>;
  using MessageHandler = std::function<void(ClientId, const Message&)>;

  explicit Server(ServerOptions options = {});
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  /// Handlers run on the server's I/O thread; set them before start().
  void onConnect(ConnectHandler handler);
  void onDisconnect(ConnectHandler handler);
  void onMessage(MessageHandler handler);
  /// Limits what each client may send; set before start().
  void limitInbound(InboundLimits limits);

  /// Binds and starts accepting. Throws NetworkError (address in use,
  /// unknown address) with what to do.
  void start();
  /// Closes every connection and joins the I/O thread. Idempotent.
  void stop();
  [[nodiscard]] std::uint16_t port() const;
  [[nodiscard]] bool running() const;

  /// Encodes once and queues the bytes for every client.
  void broadcast(const Message& message, HeaderVersion version, Channel channel);
  /// Queues already-encoded bytes for every client.
  void broadcastEncoded(std::shared_ptr<const std::vector<std::uint8_t>> bytes, Channel channel);
  /// Queues for one client (e.g. the models sent on connect); false if gone.
  bool send(ClientId client, const Message& message, HeaderVersion version, Channel channel);
  /// Queues already-encoded bytes for one client (a sender that must order
  /// per-client messages, e.g. meshes before transforms); false if gone.
  bool sendEncoded(ClientId client, std::shared_ptr<const std::vector<std::uint8_t>> bytes, Channel channel);

  [[nodiscard]] ServerStats stats() const;
  /// Messages queued for the clients and not yet written to their sockets (the one being written included):
  /// 0 once everything sent so far is in the kernel's hands.
  [[nodiscard]] std::size_t queuedMessages() const;

 private:
  struct Impl;
  std::shared_ptr<Impl> impl_;
};

/// A TCP port free on `address` now, for a server a peer must be told about before it starts (a headset that
/// connects to the workstation): picked at random below the system's ephemeral range, so neither a server
/// bound to port 0 nor a client's own end is given it meanwhile (another program may still take it), and never
/// twice in one process (several rooms started at once would race for it). Throws
/// NetworkError when none of 200 tries can be bound.
std::uint16_t freeLocalPort(const std::string& address = "127.0.0.1");

}  // namespace mrsns::igtlink
