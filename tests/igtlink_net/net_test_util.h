#pragma once
// Helpers for loopback tests: waiting with a deadline, raw sockets that
// misbehave on purpose.
#include <asio.hpp>
#include <chrono>
#include <functional>
#include <thread>

#include "mrsns/igtlink/codec.h"
#include "mrsns/igtlink/message.h"

namespace mrsns::igtlink::test {

/// Polls `done` every millisecond until it holds or `timeout_s` passes.
inline bool waitFor(const std::function<bool()>& done, double timeout_s = 5.0) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < deadline) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return done();
}

inline Message transformMessage(const std::string& device, double x, double timestamp = 0.0) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(x, 2.0, 3.0);
  return makeMessage(device, TransformContent::fromIsometry(pose), timestamp);
}

inline Message stringMessage(const std::string& device, const std::string& text) {
  return makeMessage(device, StringContent{kEncodingUsAscii, text});
}

/// A blocking TCP connection for sending arbitrary bytes.
class RawConnection {
 public:
  explicit RawConnection(std::uint16_t port) : socket_(io_) {
    socket_.connect(asio::ip::tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
  }
  void send(const std::vector<std::uint8_t>& bytes) {
    asio::error_code ec;
    asio::write(socket_, asio::buffer(bytes), ec);
  }
  /// True when the peer has closed the connection (read returns EOF/error within timeout).
  bool closedByPeer(double timeout_s = 3.0) {
    socket_.non_blocking(true);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    std::array<std::uint8_t, 4096> buffer{};
    while (std::chrono::steady_clock::now() < deadline) {
      asio::error_code ec;
      socket_.read_some(asio::buffer(buffer), ec);
      if (ec == asio::error::would_block) {
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        continue;
      }
      if (ec) return true;
    }
    return false;
  }
  asio::ip::tcp::socket& socket() { return socket_; }

 private:
  asio::io_context io_;
  asio::ip::tcp::socket socket_;
};

}  // namespace mrsns::igtlink::test
