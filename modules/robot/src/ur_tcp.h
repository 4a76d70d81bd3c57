#pragma once
// A blocking TCP connection with a timeout on every operation, for the UR clients (dashboard, RTDE, script).
// Each connection owns its own Asio context, so one thread may read it while another writes a different one.
// Errors are NetworkError naming the peer; a read timeout is not an error (returns 0 bytes).
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>

namespace mrsns::robot::detail {

class TcpConnection {
 public:
  /// Connects to host:port within timeout_s; `what` names the peer in errors ("UR dashboard server").
  TcpConnection(const std::string& host, std::uint16_t port, double timeout_s, std::string what);
  ~TcpConnection();
  TcpConnection(const TcpConnection&) = delete;
  TcpConnection& operator=(const TcpConnection&) = delete;

  void write(std::span<const std::uint8_t> bytes, double timeout_s);
  void write(std::string_view text, double timeout_s);
  /// Up to buffer.size() bytes; 0 when nothing arrived within timeout_s. Throws NetworkError when the peer closed.
  std::size_t readSome(std::span<std::uint8_t> buffer, double timeout_s);
  /// One line without its CR/LF; throws NetworkError on timeout, close, or a line longer than 4096 bytes.
  std::string readLine(double timeout_s);
  void close();
  [[nodiscard]] bool isOpen() const;
  [[nodiscard]] const std::string& peer() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mrsns::robot::detail
