#include "ur_tcp.h"

#include <asio.hpp>
#include <chrono>
#include <optional>

#include "mrsns/core/error.h"

namespace mrsns::robot::detail {
namespace {

std::chrono::steady_clock::duration toDuration(double s) {
  return std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(s));
}

}  // namespace

struct TcpConnection::Impl {
  asio::io_context io;
  asio::ip::tcp::socket socket{io};
  std::string what;
  std::string peer;
  std::string pending;  // bytes after the last line returned by readLine

  // Runs the context until `done` or the timeout; on timeout cancels the operation and lets its handler run.
  bool runFor(double timeout_s, const bool& done) {
    io.restart();
    io.run_for(toDuration(timeout_s));
    if (done) return true;
    asio::error_code ignored;
    socket.cancel(ignored);
    io.restart();
    io.run();
    return false;
  }

  [[noreturn]] void fail(const std::string& action, const asio::error_code& ec) {
    throw NetworkError(what + " at " + peer + ": " + action + " failed: " + ec.message());
  }
};

TcpConnection::TcpConnection(const std::string& host, std::uint16_t port, double timeout_s, std::string what)
    : impl_(std::make_unique<Impl>()) {
  impl_->what = std::move(what);
  impl_->peer = host + ":" + std::to_string(port);
  asio::error_code ec;
  const auto address = asio::ip::make_address(host, ec);
  if (ec) {
    throw InvalidArgumentError(impl_->what + ": '" + host +
                               "' is not an IP address (give the controller's numeric address, e.g. 192.168.1.10)");
  }
  bool done = false;
  asio::error_code result;
  impl_->socket.async_connect(asio::ip::tcp::endpoint(address, port), [&](const asio::error_code& e) {
    result = e;
    done = true;
  });
  if (!impl_->runFor(timeout_s, done)) {
    throw NetworkError(impl_->what + " at " + impl_->peer + ": no connection within " + std::to_string(timeout_s) +
                       " s (is the controller on and reachable?)");
  }
  if (result) impl_->fail("connect", result);
  impl_->socket.set_option(asio::ip::tcp::no_delay(true), ec);
}

TcpConnection::~TcpConnection() {
  close();
}

void TcpConnection::write(std::span<const std::uint8_t> bytes, double timeout_s) {
  bool done = false;
  asio::error_code result;
  asio::async_write(impl_->socket, asio::buffer(bytes.data(), bytes.size()),
                    [&](const asio::error_code& e, std::size_t) {
                      result = e;
                      done = true;
                    });
  if (!impl_->runFor(timeout_s, done)) {
    close();
    throw NetworkError(impl_->what + " at " + impl_->peer + ": write timed out after " + std::to_string(timeout_s) +
                       " s");
  }
  if (result) {
    close();
    impl_->fail("write", result);
  }
}

void TcpConnection::write(std::string_view text, double timeout_s) {
  write(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()), timeout_s);
}

std::size_t TcpConnection::readSome(std::span<std::uint8_t> buffer, double timeout_s) {
  if (!impl_->pending.empty()) {
    const auto n = std::min(buffer.size(), impl_->pending.size());
    std::copy_n(impl_->pending.begin(), n, buffer.begin());
    impl_->pending.erase(0, n);
    return n;
  }
  bool done = false;
  asio::error_code result;
  std::size_t got = 0;
  impl_->socket.async_read_some(asio::buffer(buffer.data(), buffer.size()),
                                [&](const asio::error_code& e, std::size_t n) {
                                  result = e;
                                  got = n;
                                  done = true;
                                });
  const bool in_time = impl_->runFor(timeout_s, done);
  if (result == asio::error::operation_aborted && !in_time) return got;
  if (result) {
    close();
    impl_->fail(result == asio::error::eof ? "read (the peer closed the connection)" : "read", result);
  }
  return got;
}

std::string TcpConnection::readLine(double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + toDuration(timeout_s);
  for (;;) {
    const auto nl = impl_->pending.find('\n');
    if (nl != std::string::npos) {
      std::string line = impl_->pending.substr(0, nl);
      impl_->pending.erase(0, nl + 1);
      if (!line.empty() && line.back() == '\r') line.pop_back();
      return line;
    }
    if (impl_->pending.size() > 4096) {
      throw NetworkError(impl_->what + " at " + impl_->peer + ": reply line longer than 4096 bytes (wrong port?)");
    }
    const double left = std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0) {
      throw NetworkError(impl_->what + " at " + impl_->peer + ": no reply line within " + std::to_string(timeout_s) +
                         " s");
    }
    std::array<std::uint8_t, 1024> chunk{};
    std::string saved;
    saved.swap(impl_->pending);  // readSome would hand the pending bytes back first
    const auto n = readSome(chunk, left);
    impl_->pending = std::move(saved);
    impl_->pending.append(reinterpret_cast<const char*>(chunk.data()), n);
  }
}

void TcpConnection::close() {
  if (!impl_ || !impl_->socket.is_open()) return;
  asio::error_code ignored;
  impl_->socket.shutdown(asio::ip::tcp::socket::shutdown_both, ignored);
  impl_->socket.close(ignored);
}

bool TcpConnection::isOpen() const {
  return impl_->socket.is_open();
}
const std::string& TcpConnection::peer() const {
  return impl_->peer;
}

}  // namespace mrsns::robot::detail
