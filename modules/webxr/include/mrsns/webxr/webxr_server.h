#pragma once
// The workstation's server for the WebXR hologram client (resources/webxr):
// HTTPS for the page and its scripts, a WebSocket (/ws) on the same port for
// the data. Standalone Asio with OpenSSL, one I/O thread.
//
// Admission: a page that opens the WebSocket must send the pairing code the
// workstation shows ({"type":"pair","code":"..."}) as its first message,
// within handshake_timeout_s of connecting; until then it gets nothing. A
// wrong code closes the connection; after max_failed_pairings wrong codes
// (from anyone) pairing is refused for pairing_lockout_s, so the code's
// million values cannot be tried in a lab's afternoon.
//
// What is served: a fixed list of files (the page's three from web_root and
// two of Debian's three.js, see doc/webxr_client.md); anything else is 404,
// anything but GET 405. One request per connection.
//
// What a client may send (send-only, bounded, like the OpenIGTLink stream):
// text messages of at most max_client_message_bytes; a larger frame, a
// binary or fragmented message or a protocol error closes the connection
// from the frame's header, before its payload is stored. A client sending
// more than max_client_messages_per_second is not read until it is back under
// (TCP holds the flood on its side). A client that does not read what it is
// sent is dropped when max_queued_bytes are waiting for it. Paired clients'
// text goes to the owner's handler and nowhere else.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "mrsns/webxr/tls_certificate.h"

namespace mrsns::webxr {

using WebXrClientId = std::uint64_t;
/// An encoded WebSocket frame, shared by every client it goes to.
using WsFrameBytes = std::shared_ptr<const std::vector<std::uint8_t>>;

WsFrameBytes textFrame(std::string_view text);
WsFrameBytes binaryFrame(std::span<const std::uint8_t> bytes);

struct WebXrServerOptions {
  /// 127.0.0.1 by default: a headset on the lab's network needs the
  /// workstation's address (or 0.0.0.0) given explicitly.
  std::string bind_address = "127.0.0.1";
  std::uint16_t port = 8443;         ///< 0: any free port (see port())
  std::filesystem::path web_root;    ///< index.html, client.js, style.css
  std::filesystem::path three_root;  ///< Debian's libjs-three (/usr/share/javascript/three)
  TlsCertificate certificate;        ///< ensureSelfSignedCertificate
  std::string pairing_code;          ///< isValidPairingCode
  std::size_t max_clients = 8;       ///< paired clients at once
  std::size_t max_client_message_bytes = 4096;
  double max_client_messages_per_second = 200.0;
  std::size_t max_queued_bytes = 64U << 20;
  double handshake_timeout_s = 10.0;  ///< TLS, the HTTP request and the pairing
  int max_failed_pairings = 10;
  double pairing_lockout_s = 60.0;
};

struct WebXrServerStats {
  std::uint64_t connections = 0;
  std::uint64_t files_served = 0;
  std::uint64_t not_found = 0;
  std::uint64_t paired = 0;
  std::uint64_t pairings_refused = 0;
  std::uint64_t clients_dropped = 0;  ///< over a limit or a protocol error
  std::uint64_t client_messages = 0;  ///< text messages from paired clients
  std::uint64_t frames_sent = 0;
  std::uint64_t bytes_sent = 0;
};

class WebXrServer {
 public:
  using PairedHandler = std::function<void(WebXrClientId)>;
  using MessageHandler = std::function<void(WebXrClientId, const std::string& text)>;
  using DisconnectHandler = std::function<void(WebXrClientId)>;

  /// Throws InvalidArgumentError for a pairing code that is not isValidPairingCode, a
  /// missing web_root/index.html or three.js, a certificate without files.
  explicit WebXrServer(WebXrServerOptions options);
  ~WebXrServer();
  WebXrServer(const WebXrServer&) = delete;
  WebXrServer& operator=(const WebXrServer&) = delete;

  /// Handlers run on the I/O thread; set them before start(). They may call send().
  void onPaired(PairedHandler handler);
  void onMessage(MessageHandler handler);
  void onDisconnect(DisconnectHandler handler);

  /// Listens (returns at once). Throws NetworkError when the address cannot
  /// be bound, FormatError when OpenSSL refuses the certificate or key.
  void start();
  void stop();

  [[nodiscard]] std::uint16_t port() const;
  /// https://<bind address or this host's name>:<port>/
  [[nodiscard]] std::string url() const;
  [[nodiscard]] std::size_t pairedClients() const;
  [[nodiscard]] WebXrServerStats stats() const;

  /// Queues a frame for one paired client / every paired client (any thread).
  void send(WebXrClientId client, WsFrameBytes frame);
  void broadcast(WsFrameBytes frame);

 private:
  struct Impl;
  std::shared_ptr<Impl> impl_;
};

/// A pairing code of `digits` decimal digits from OpenSSL's random generator.
std::string makePairingCode(int digits = 6);

/// What a pairing code must be (the page's field takes digits): at least 6 digits, at most 12.
bool isValidPairingCode(std::string_view code);

}  // namespace mrsns::webxr
