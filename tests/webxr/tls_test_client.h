#pragma once
// A blocking TLS client for the WebXR server's tests: HTTP requests, the
// WebSocket upgrade, masked client frames (or any bytes), server frames read
// with a timeout.
#include <array>
#include <asio.hpp>
#include <asio/ssl.hpp>
#include <chrono>
#include <optional>
#include <string>
#include <vector>

namespace mrsns::test {

class TlsTestClient {
 public:
  explicit TlsTestClient(std::uint16_t port) : tls_(asio::ssl::context::tls_client), stream_(io_, tls_) {
    tls_.set_verify_mode(asio::ssl::verify_none);  // the server's certificate is self-signed
    stream_.lowest_layer().connect({asio::ip::make_address("127.0.0.1"), port});
    stream_.handshake(asio::ssl::stream_base::client);
  }

  /// How long readFrame waits for the server (Asio's blocking reads ignore SO_RCVTIMEO, so reads are
  /// asynchronous with a deadline).
  void setTimeout(double seconds) {
    timeout_ = std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::duration<double>(seconds));
  }

  /// The whole response (the server closes after one).
  std::string request(const std::string& head) {
    asio::write(stream_, asio::buffer(head));
    std::string response;
    asio::error_code ec;
    asio::read(stream_, asio::dynamic_buffer(response), ec);
    return response;
  }

  /// True when the server switched to the WebSocket protocol.
  bool upgrade() {
    const std::string head =
        "GET /ws HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
        "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n";
    asio::write(stream_, asio::buffer(head));
    asio::error_code ec;
    const std::size_t n = asio::read_until(stream_, asio::dynamic_buffer(pending_), "\r\n\r\n", ec);
    if (ec) return false;
    const bool ok = pending_.starts_with("HTTP/1.1 101");
    pending_.erase(0, n);
    return ok;
  }

  bool sendRaw(const std::vector<std::uint8_t>& bytes) {
    asio::error_code ec;
    asio::write(stream_, asio::buffer(bytes), ec);
    return !ec;
  }

  bool sendText(const std::string& text) {
    std::vector<std::uint8_t> f{0x81};
    const std::size_t n = text.size();
    if (n < 126) {
      f.push_back(static_cast<std::uint8_t>(0x80 | n));
    } else {
      f.push_back(0x80 | 126);
      f.push_back(static_cast<std::uint8_t>(n >> 8));
      f.push_back(static_cast<std::uint8_t>(n));
    }
    const std::uint8_t mask[4] = {0x12, 0x34, 0x56, 0x78};
    f.insert(f.end(), mask, mask + 4);
    for (std::size_t i = 0; i < n; ++i) f.push_back(static_cast<std::uint8_t>(text[i]) ^ mask[i % 4]);
    return sendRaw(f);
  }

  struct Frame {
    std::uint8_t opcode = 0;
    std::string payload;
  };
  /// The next server frame; nothing when the connection closed or the timeout passed.
  std::optional<Frame> readFrame() {
    if (!fill(2)) return std::nullopt;
    Frame frame;
    frame.opcode = static_cast<std::uint8_t>(pending_[0]) & 0x0F;
    std::uint64_t n = static_cast<std::uint8_t>(pending_[1]) & 0x7F;
    std::size_t header = 2;
    if (n == 126) {
      if (!fill(4)) return std::nullopt;
      n = (std::uint64_t{static_cast<std::uint8_t>(pending_[2])} << 8) | static_cast<std::uint8_t>(pending_[3]);
      header = 4;
    } else if (n == 127) {
      if (!fill(10)) return std::nullopt;
      n = 0;
      for (int i = 0; i < 8; ++i) n = (n << 8) | static_cast<std::uint8_t>(pending_[2 + static_cast<std::size_t>(i)]);
      header = 10;
    }
    if (!fill(header + n)) return std::nullopt;
    frame.payload = pending_.substr(header, n);
    pending_.erase(0, header + n);
    return frame;
  }

 private:
  bool fill(std::size_t n) {
    while (pending_.size() < n) {
      std::array<char, 65536> chunk{};
      asio::error_code ec = asio::error::would_block;
      std::size_t got = 0;
      stream_.async_read_some(asio::buffer(chunk), [&](const asio::error_code& e, std::size_t g) {
        ec = e;
        got = g;
      });
      io_.restart();
      io_.run_for(timeout_);
      if (ec == asio::error::would_block) {  // the deadline passed: give the read up
        asio::error_code ignored;
        stream_.lowest_layer().cancel(ignored);
        io_.restart();
        io_.run();
        return false;
      }
      if (ec) return false;
      pending_.append(chunk.data(), got);
    }
    return true;
  }

  asio::io_context io_;
  asio::ssl::context tls_;
  asio::ssl::stream<asio::ip::tcp::socket> stream_;
  std::chrono::milliseconds timeout_{5000};
  std::string pending_;
};

}  // namespace mrsns::test
