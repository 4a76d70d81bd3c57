#include "mrsns/webxr/webxr_server.h"

#include <fcntl.h>
#include <openssl/crypto.h>
#include <openssl/rand.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <asio.hpp>
#include <asio/ssl.hpp>
#include <atomic>
#include <cctype>
#include <chrono>
#include <deque>
#include <fstream>
#include <future>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <thread>

#include "http_request.h"
#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/webxr/websocket_protocol.h"

namespace mrsns::webxr {
namespace fs = std::filesystem;
namespace {

using Clock = std::chrono::steady_clock;
using SslStream = asio::ssl::stream<asio::ip::tcp::socket>;

constexpr std::size_t kMaxRequestHeadBytes = 16 * 1024;
constexpr std::uintmax_t kMaxServedFileBytes = 16U << 20;

struct ServedFile {
  fs::path path;
  const char* content_type;
};

std::string readWholeFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string httpResponse(int status, const char* reason, const char* content_type, const std::string& body) {
  std::ostringstream r;
  r << "HTTP/1.1 " << status << ' ' << reason << "\r\n"
    << "Content-Type: " << content_type << "\r\n"
    << "Content-Length: " << body.size() << "\r\n"
    << "Cache-Control: no-store\r\n"
    << "X-Content-Type-Options: nosniff\r\n"
    << "Referrer-Policy: no-referrer\r\n"
    // Everything from this server; nothing from the network (the page works offline in an OR).
    << "Content-Security-Policy: default-src 'self'; connect-src 'self'; img-src 'self' data: blob:; "
       "style-src 'self'; script-src 'self'\r\n"
    << "Connection: close\r\n\r\n"
    << body;
  return r.str();
}

bool constantTimeEquals(const std::string& a, const std::string& b) {
  return a.size() == b.size() && CRYPTO_memcmp(a.data(), b.data(), a.size()) == 0;
}

}  // namespace

WsFrameBytes textFrame(std::string_view text) {
  return std::make_shared<const std::vector<std::uint8_t>>(encodeWsFrame(WsOpcode::kText, text));
}

WsFrameBytes binaryFrame(std::span<const std::uint8_t> bytes) {
  return std::make_shared<const std::vector<std::uint8_t>>(encodeWsFrame(WsOpcode::kBinary, bytes));
}

std::string makePairingCode(int digits) {
  std::string code;
  while (static_cast<int>(code.size()) < digits) {
    unsigned char byte = 0;
    if (RAND_bytes(&byte, 1) != 1) throw ComputationError("OpenSSL's random generator failed");
    if (byte < 250) code += static_cast<char>('0' + byte % 10);  // 250 = 25 * 10: no bias
  }
  return code;
}

bool isValidPairingCode(std::string_view code) {
  return code.size() >= 6 && code.size() <= 12 && code.find_first_not_of("0123456789") == std::string_view::npos;
}

struct WebXrServer::Impl : std::enable_shared_from_this<WebXrServer::Impl> {
  struct Session : std::enable_shared_from_this<Session> {
    Session(Impl& owner, asio::ip::tcp::socket socket, WebXrClientId client)
        : server(owner),
          stream(std::move(socket), owner.tls),
          deadline(stream.get_executor()),
          pause(stream.get_executor()),
          id(client),
          frames(owner.options.max_client_message_bytes),
          tokens(owner.options.max_client_messages_per_second) {}

    Impl& server;
    SslStream stream;
    asio::steady_timer deadline;
    asio::steady_timer pause;
    WebXrClientId id;
    std::string request;
    WsFrameReader frames;
    std::array<std::uint8_t, 16384> buffer{};
    double tokens;
    Clock::time_point tokens_at = Clock::now();
    bool websocket = false;
    bool paired = false;
    bool closed = false;
    bool closing = false;  // a close frame or a response is the last thing written
    std::deque<WsFrameBytes> queue;
    std::size_t queued_bytes = 0;
    bool writing = false;

    void start() {
      auto self = shared_from_this();
      deadline.expires_after(std::chrono::duration_cast<Clock::duration>(
          std::chrono::duration<double>(server.options.handshake_timeout_s)));
      deadline.async_wait([self](const asio::error_code& ec) {
        if (!ec && !self->paired) self->close();
      });
      stream.async_handshake(asio::ssl::stream_base::server, [self](const asio::error_code& ec) {
        if (ec) {
          self->close();
          return;
        }
        self->readRequest();
      });
    }

    void readRequest() {
      auto self = shared_from_this();
      asio::async_read_until(stream, asio::dynamic_buffer(request, kMaxRequestHeadBytes), "\r\n\r\n",
                             [self](const asio::error_code& ec, std::size_t head_bytes) {
                               if (ec) {
                                 self->close();
                                 return;
                               }
                               self->handleRequest(head_bytes);
                             });
    }

    void handleRequest(std::size_t head_bytes) {
      HttpRequest r;
      try {
        r = parseHttpRequestHead(std::string_view(request).substr(0, head_bytes));
      } catch (const std::exception&) {
        respond(400, "Bad Request", "text/plain", "malformed request\n");
        return;
      }
      if (r.method != "GET") {
        respond(405, "Method Not Allowed", "text/plain", "only GET\n");
        return;
      }
      if (r.path == "/ws") {
        upgrade(r, request.substr(head_bytes));
        return;
      }
      const auto file = server.servedFile(r.path);
      std::error_code ec;
      if (!file || !fs::is_regular_file(file->path, ec) || fs::file_size(file->path, ec) > kMaxServedFileBytes) {
        ++server.counters.not_found;
        respond(404, "Not Found", "text/plain", "not found\n");
        return;
      }
      ++server.counters.files_served;
      respond(200, "OK", file->content_type, readWholeFile(file->path));
    }

    void upgrade(const HttpRequest& r, const std::string& early_bytes) {
      const auto key = r.header("sec-websocket-key");
      const auto upgrade_header = r.header("upgrade");
      std::string upgrade_value = upgrade_header.value_or("");
      std::transform(upgrade_value.begin(), upgrade_value.end(), upgrade_value.begin(),
                     [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
      if (!key || upgrade_value != "websocket" || r.header("sec-websocket-version").value_or("") != "13") {
        respond(400, "Bad Request", "text/plain", "a WebSocket version 13 upgrade is expected on /ws\n");
        return;
      }
      // A page from another site must not reach the stream through the headset's browser.
      if (const auto origin = r.header("origin");
          origin && !originMatchesHost(*origin, r.header("host").value_or(""))) {
        respond(403, "Forbidden", "text/plain", "cross-origin WebSocket refused\n");
        return;
      }
      websocket = true;
      const std::string response =
          "HTTP/1.1 101 Switching Protocols\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
          "Sec-WebSocket-Accept: " +
          websocketAcceptKey(*key) + "\r\n\r\n";
      queueBytes(std::make_shared<const std::vector<std::uint8_t>>(response.begin(), response.end()));
      try {
        consumeFrames(std::span(reinterpret_cast<const std::uint8_t*>(early_bytes.data()), early_bytes.size()));
      } catch (const ProtocolViolation& e) {
        violation(e);
        return;
      }
      if (!closed && !closing) readFrames();
    }

    static bool originMatchesHost(const std::string& origin, const std::string& host) {
      const auto scheme_end = origin.find("://");
      return scheme_end != std::string::npos && origin.substr(scheme_end + 3) == host;
    }

    void readFrames() {
      auto self = shared_from_this();
      stream.async_read_some(asio::buffer(buffer), [self](const asio::error_code& ec, std::size_t n) {
        if (ec || self->closed) {
          self->close();
          return;
        }
        try {
          self->consumeFrames(std::span(self->buffer.data(), n));
        } catch (const ProtocolViolation& e) {
          self->violation(e);
          return;
        }
        if (!self->closed && !self->closing) self->readWhenAllowed();
      });
    }

    // Token bucket: over the rate, the next read waits until a message is allowed again.
    void readWhenAllowed() {
      const double rate = server.options.max_client_messages_per_second;
      const auto now = Clock::now();
      tokens = std::min(rate, tokens + rate * std::chrono::duration<double>(now - tokens_at).count());
      tokens_at = now;
      if (tokens >= 0.0) {
        readFrames();
        return;
      }
      auto self = shared_from_this();
      pause.expires_after(
          std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(-tokens / rate + 1e-3)));
      pause.async_wait([self](const asio::error_code& ec) {
        if (!ec && !self->closed) self->readWhenAllowed();
      });
    }

    void consumeFrames(std::span<const std::uint8_t> bytes) {
      std::vector<WsFrame> complete;
      frames.feed(bytes, complete);
      for (auto& frame : complete) {
        if (closed || closing) return;
        switch (frame.opcode) {
          case WsOpcode::kPing:
            queueBytes(
                std::make_shared<const std::vector<std::uint8_t>>(encodeWsFrame(WsOpcode::kPong, frame.payload)));
            break;
          case WsOpcode::kPong: break;
          case WsOpcode::kClose: closeWith(1000, ""); return;
          case WsOpcode::kBinary: throw ProtocolViolation(1003, "binary messages are not accepted from a client");
          case WsOpcode::kText:
            tokens -= 1.0;
            text(std::string(frame.payload.begin(), frame.payload.end()));
            break;
        }
      }
    }

    void text(const std::string& message) {
      if (paired) {
        ++server.counters.client_messages;
        if (server.on_message) server.on_message(id, message);
        return;
      }
      std::string code;
      try {
        const auto json = nlohmann::json::parse(message);
        if (json.value("type", "") == "pair") code = json.value("code", "");
      } catch (const std::exception&) {
      }
      const auto now = Clock::now();
      if (now < server.locked_until) {
        refusePairing("too many wrong pairing codes: pairing is locked for a minute");
        return;
      }
      if (code.empty() || !constantTimeEquals(code, server.options.pairing_code)) {
        if (++server.failed_pairings >= server.options.max_failed_pairings) {
          server.failed_pairings = 0;
          server.locked_until = now + std::chrono::duration_cast<Clock::duration>(
                                          std::chrono::duration<double>(server.options.pairing_lockout_s));
          logger()->warn("WebXR: {} wrong pairing codes; pairing locked for {} s", server.options.max_failed_pairings,
                         server.options.pairing_lockout_s);
        }
        refusePairing(code.empty() ? "the first message must be the pairing code" : "wrong pairing code");
        return;
      }
      if (server.pairedCount() >= server.options.max_clients) {
        refusePairing("the workstation serves " + std::to_string(server.options.max_clients) + " headsets already");
        return;
      }
      server.failed_pairings = 0;
      paired = true;
      server.paired_clients = server.pairedCount();
      deadline.cancel();
      ++server.counters.paired;
      queueBytes(textFrame(R"({"type":"paired"})"));
      if (server.on_paired) server.on_paired(id);
    }

    void refusePairing(const std::string& reason) {
      ++server.counters.pairings_refused;
      queueBytes(textFrame(nlohmann::json{{"type", "refused"}, {"reason", reason}}.dump()));
      closeWith(1008, "pairing refused");
    }

    void violation(const ProtocolViolation& e) {
      ++server.counters.clients_dropped;
      logger()->warn("WebXR client {}: {}; disconnected", id, e.what());
      closeWith(e.code(), e.what());
    }

    void respond(int status, const char* reason, const char* content_type, const std::string& body) {
      const std::string response = httpResponse(status, reason, content_type, body);
      queueBytes(std::make_shared<const std::vector<std::uint8_t>>(response.begin(), response.end()));
      closing = true;
    }

    void closeWith(std::uint16_t code, std::string_view reason) {
      if (closing) return;
      queueBytes(std::make_shared<const std::vector<std::uint8_t>>(encodeWsClose(code, reason)));
      closing = true;
    }

    // I/O thread only.
    void queueBytes(WsFrameBytes bytes) {
      if (closed) return;
      if (closing) return;  // nothing after the last response or close frame
      queued_bytes += bytes->size();
      if (queued_bytes > server.options.max_queued_bytes) {
        ++server.counters.clients_dropped;
        logger()->warn("WebXR client {} does not read what it is sent ({} bytes waiting); disconnected", id,
                       queued_bytes);
        close();
        return;
      }
      queue.push_back(std::move(bytes));
      if (!writing) writeNext();
    }

    void writeNext() {
      if (queue.empty()) {
        writing = false;
        if (closing) shutdown();
        return;
      }
      writing = true;
      auto self = shared_from_this();
      asio::async_write(stream, asio::buffer(*queue.front()), [self](const asio::error_code& ec, std::size_t n) {
        // Closed meanwhile (the page hung up while this was on its way): the queue is gone with it.
        if (ec || self->closed) {
          self->close();
          return;
        }
        ++self->server.counters.frames_sent;
        self->server.counters.bytes_sent += n;
        self->queued_bytes -= self->queue.front()->size();
        self->queue.pop_front();
        self->writeNext();
      });
    }

    void shutdown() {
      auto self = shared_from_this();
      deadline.expires_after(std::chrono::seconds(2));
      deadline.async_wait([self](const asio::error_code& ec) {
        if (!ec) self->close();
      });
      stream.async_shutdown([self](const asio::error_code&) { self->close(); });
    }

    void close() {
      if (closed) return;
      closed = true;
      asio::error_code ignored;
      deadline.cancel();
      pause.cancel();
      stream.lowest_layer().close(ignored);
      queue.clear();
      server.forget(id, paired);
    }
  };

  explicit Impl(WebXrServerOptions o) : options(std::move(o)), tls(asio::ssl::context::tls_server), acceptor(io) {}

  std::optional<ServedFile> servedFile(const std::string& path) const {
    if (path == "/" || path == "/index.html")
      return ServedFile{options.web_root / "index.html", "text/html; charset=utf-8"};
    if (path == "/client.js") return ServedFile{options.web_root / "client.js", "text/javascript"};
    if (path == "/style.css") return ServedFile{options.web_root / "style.css", "text/css"};
    // The two files of Debian's three.js the page imports, at the paths their own relative imports expect.
    if (path == "/three/build/three.module.js")
      return ServedFile{options.three_root / "build/three.module.js", "text/javascript"};
    if (path == "/three/examples/jsm/controls/OrbitControls.js") {
      return ServedFile{options.three_root / "examples/jsm/controls/OrbitControls.js", "text/javascript"};
    }
    return std::nullopt;
  }

  std::size_t pairedCount() const {
    return static_cast<std::size_t>(std::count_if(sessions.begin(), sessions.end(), [](const auto& entry) {
      return entry.second->paired && !entry.second->closed;
    }));
  }

  void forget(WebXrClientId id, bool was_paired) {
    sessions.erase(id);
    paired_clients = pairedCount();
    if (was_paired && on_disconnect) on_disconnect(id);
  }

  void accept() {
    auto self = shared_from_this();
    acceptor.async_accept([self](const asio::error_code& ec, asio::ip::tcp::socket socket) {
      if (ec) {
        if (ec != asio::error::operation_aborted) self->accept();
        return;
      }
      ++self->counters.connections;
      ::fcntl(socket.native_handle(), F_SETFD, FD_CLOEXEC);
      const WebXrClientId id = ++self->next_id;
      auto session = std::make_shared<Session>(*self, std::move(socket), id);
      self->sessions[id] = session;
      session->start();
      self->accept();
    });
  }

  WebXrServerOptions options;
  asio::io_context io;
  asio::ssl::context tls;
  asio::ip::tcp::acceptor acceptor;
  std::thread thread;
  std::atomic<std::uint16_t> bound_port{0};
  PairedHandler on_paired;
  MessageHandler on_message;
  DisconnectHandler on_disconnect;
  // I/O thread only:
  std::map<WebXrClientId, std::shared_ptr<Session>> sessions;
  WebXrClientId next_id = 0;
  int failed_pairings = 0;
  Clock::time_point locked_until{};
  std::atomic<std::size_t> paired_clients{0};
  struct Counters {
    std::atomic<std::uint64_t> connections{0}, files_served{0}, not_found{0}, paired{0}, pairings_refused{0},
        clients_dropped{0}, client_messages{0}, frames_sent{0}, bytes_sent{0};
  } counters;
};

WebXrServer::WebXrServer(WebXrServerOptions options) {
  if (!isValidPairingCode(options.pairing_code)) {
    throw InvalidArgumentError("the WebXR pairing code must be 6 to 12 digits");
  }
  if (!fs::is_regular_file(options.web_root / "index.html")) {
    throw InvalidArgumentError("the WebXR client's page is not in " + options.web_root.string() +
                               " (index.html missing: is MR-SNS installed completely?)");
  }
  if (!fs::is_regular_file(options.three_root / "build/three.module.js")) {
    throw InvalidArgumentError("three.js is not in " + options.three_root.string() +
                               " (install Debian's libjs-three: apt-get install libjs-three)");
  }
  if (options.certificate.certificate_pem.empty() || options.certificate.private_key_pem.empty()) {
    throw InvalidArgumentError("the WebXR server needs a certificate (ensureSelfSignedCertificate)");
  }
  impl_ = std::make_shared<Impl>(std::move(options));
}

WebXrServer::~WebXrServer() {
  stop();
}

void WebXrServer::onPaired(PairedHandler handler) {
  impl_->on_paired = std::move(handler);
}
void WebXrServer::onMessage(MessageHandler handler) {
  impl_->on_message = std::move(handler);
}
void WebXrServer::onDisconnect(DisconnectHandler handler) {
  impl_->on_disconnect = std::move(handler);
}

void WebXrServer::start() {
  auto& impl = *impl_;
  try {
    impl.tls.set_options(asio::ssl::context::default_workarounds | asio::ssl::context::no_sslv2 |
                         asio::ssl::context::no_sslv3 | asio::ssl::context::no_tlsv1 | asio::ssl::context::no_tlsv1_1);
    impl.tls.use_certificate_chain_file(impl.options.certificate.certificate_pem.string());
    impl.tls.use_private_key_file(impl.options.certificate.private_key_pem.string(), asio::ssl::context::pem);
  } catch (const std::system_error& e) {
    throw FormatError("OpenSSL refused the WebXR certificate " + impl.options.certificate.certificate_pem.string() +
                      ": " + e.what());
  }
  try {
    const asio::ip::tcp::endpoint endpoint(asio::ip::make_address(impl.options.bind_address), impl.options.port);
    impl.acceptor.open(endpoint.protocol());
    impl.acceptor.set_option(asio::ip::tcp::acceptor::reuse_address(true));
    impl.acceptor.bind(endpoint);
    impl.acceptor.listen();
    // A program the workstation starts (mrsns-sim, a browser) must not inherit the listening socket.
    ::fcntl(impl.acceptor.native_handle(), F_SETFD, FD_CLOEXEC);
  } catch (const std::system_error& e) {
    throw NetworkError("cannot listen for the WebXR client on " + impl.options.bind_address + ":" +
                       std::to_string(impl.options.port) + ": " + e.what());
  }
  impl.bound_port = impl.acceptor.local_endpoint().port();
  impl.accept();
  impl.thread = std::thread([self = impl_] { self->io.run(); });
}

void WebXrServer::stop() {
  if (!impl_ || !impl_->thread.joinable()) return;
  auto closed = std::make_shared<std::promise<void>>();
  asio::post(impl_->io, [self = impl_, closed] {
    asio::error_code ignored;
    self->acceptor.close(ignored);
    auto sessions = self->sessions;
    for (auto& [id, session] : sessions) session->close();
    closed->set_value();
  });
  closed->get_future().wait_for(std::chrono::seconds(2));
  impl_->io.stop();
  impl_->thread.join();
  // The aborted operations' handlers still hold their sessions (and the accept handler this Impl): let them run
  // and let go, or each stop would keep a server's worth of memory.
  impl_->io.restart();
  impl_->io.poll();
}

std::uint16_t WebXrServer::port() const {
  return impl_->bound_port;
}

std::string WebXrServer::url() const {
  std::string host = impl_->options.bind_address;
  if (host == "0.0.0.0" || host == "::") {
    std::array<char, 256> name{};
    host = ::gethostname(name.data(), name.size() - 1) == 0 ? std::string(name.data()) : "localhost";
  }
  return "https://" + host + ":" + std::to_string(port()) + "/";
}

std::size_t WebXrServer::pairedClients() const {
  return impl_->paired_clients;
}

WebXrServerStats WebXrServer::stats() const {
  const auto& c = impl_->counters;
  return {c.connections,     c.files_served,    c.not_found,   c.paired,    c.pairings_refused,
          c.clients_dropped, c.client_messages, c.frames_sent, c.bytes_sent};
}

void WebXrServer::send(WebXrClientId client, WsFrameBytes frame) {
  asio::post(impl_->io, [self = impl_, client, frame = std::move(frame)]() mutable {
    const auto it = self->sessions.find(client);
    if (it == self->sessions.end()) return;
    const auto session = it->second;  // a queue over its limit closes the session, which erases this entry
    if (session->paired) session->queueBytes(std::move(frame));
  });
}

void WebXrServer::broadcast(WsFrameBytes frame) {
  asio::post(impl_->io, [self = impl_, frame = std::move(frame)] {
    auto sessions = self->sessions;  // a queue over its limit closes (and erases) its session
    for (auto& [id, session] : sessions) {
      if (session->paired) session->queueBytes(frame);
    }
  });
}

}  // namespace mrsns::webxr
