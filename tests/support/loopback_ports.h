#pragma once
// Loopback ports for tests that start servers in other processes: one the
// kernel just handed out (free a moment ago, nobody listening now), and
// whether something accepts connections on a port.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdint>
#include <fstream>
#include <random>

namespace mrsns::test {

/// A loopback port that was free a moment ago and has no listener now; 0 on failure.
inline int closedPort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return 0;
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = 0;
  socklen_t len = sizeof a;
  const bool ok = ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 &&
                  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) == 0;
  ::close(fd);
  return ok ? ntohs(a.sin_port) : 0;
}

/// True when a server could bind 127.0.0.1:port now.
inline bool bindable(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return false;
  const int one = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  const bool ok = ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  ::close(fd);
  return ok;
}

/// A port offset for a UR controller's four ports (29999, 30002, 30003, 30004 + offset) that are all free now
/// and lie below the system's ephemeral range, so no client's own end of a connection (many, while the suite
/// runs in parallel) is handed one of them meanwhile; 0 when none was found.
inline int freeUrPortOffset() {
  int ephemeral_low = 32768;
  std::ifstream("/proc/sys/net/ipv4/ip_local_port_range") >> ephemeral_low;
  const int highest = ephemeral_low - 1 - 30004;
  if (highest < 2) return 0;
  std::mt19937 rng(std::random_device{}());
  std::uniform_int_distribution<int> pick(1, highest);
  for (int attempt = 0; attempt < 200; ++attempt) {
    const int offset = pick(rng);
    if (bindable(29999 + offset) && bindable(30002 + offset) && bindable(30003 + offset) && bindable(30004 + offset)) {
      return offset;
    }
  }
  return 0;
}

/// True when a TCP connection to 127.0.0.1:port is accepted.
inline bool accepts(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return false;
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  const bool ok = ::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  ::close(fd);
  return ok;
}

}  // namespace mrsns::test
