// stop() must return even when accepts are failing at that moment: clients
// that connect and reset at once make accepts complete with errors
// (connection aborted), and such a completion still queued when stop()
// closes the acceptor used to re-arm an accept on the closed acceptor,
// which failed at once, forever (the I/O thread spun and stop() never
// returned; seen once in CI under load, in the hologram stream robustness
// test).
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <thread>

#include "mrsns/core/error.h"
#include "mrsns/igtlink/server.h"

namespace mrsns::igtlink {
namespace {

// Connects to the port and resets the connection at once (SO_LINGER 0).
void connectAndReset(std::uint16_t port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return;
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(port);
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0) {
    const linger reset{1, 0};
    ::setsockopt(fd, SOL_SOCKET, SO_LINGER, &reset, sizeof(reset));
  }
  ::close(fd);
}

// Runs `stop` on its own thread; a hang would block the test binary (and
// CI) forever, so after `limit` the process exits with a message instead.
void stopOrDie(Server& server, std::chrono::seconds limit) {
  std::mutex mutex;
  std::condition_variable cv;
  bool done = false;
  std::thread stopper([&] {
    server.stop();
    std::lock_guard lock(mutex);
    done = true;
    cv.notify_one();
  });
  std::unique_lock lock(mutex);
  if (!cv.wait_for(lock, limit, [&] { return done; })) {
    std::fprintf(stderr, "Server::stop() did not return within %lld s while clients reset their connections\n",
                 static_cast<long long>(limit.count()));
    std::_Exit(1);
  }
  lock.unlock();
  stopper.join();
}

TEST(IgtlServerStop, ReturnsWhileClientsConnectAndResetConcurrently) {
  for (int round = 0; round < 40; ++round) {
    ServerOptions options;
    options.port = 0;
    Server server(options);
    server.start();
    const std::uint16_t port = server.port();
    std::atomic<bool> done{false};
    std::vector<std::thread> clients;
    for (int t = 0; t < 4; ++t) {
      clients.emplace_back([&] {
        while (!done.load()) connectAndReset(port);
      });
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2 + round % 7));
    stopOrDie(server, std::chrono::seconds(20));
    EXPECT_FALSE(server.running());
    done = true;
    for (auto& c : clients) c.join();
  }
}

TEST(FreeLocalPort, IsBelowTheEphemeralRangeAndAServerCanTakeIt) {
  // A port told to a peer before its server starts: never one the system itself hands out meanwhile.
  int low = 32768;
  if (std::FILE* f = std::fopen("/proc/sys/net/ipv4/ip_local_port_range", "r")) {
    if (std::fscanf(f, "%d", &low) != 1) low = 32768;
    std::fclose(f);
  }
  for (int i = 0; i < 20; ++i) {
    const std::uint16_t port = freeLocalPort("127.0.0.1");
    EXPECT_LT(port, low);
    EXPECT_GE(port, 1024);
    ServerOptions options;
    options.port = port;
    Server server(options);
    server.start();
    EXPECT_EQ(server.port(), port);
    server.stop();
  }
  EXPECT_THROW(static_cast<void>(freeLocalPort("not an address")), NetworkError);
}

}  // namespace
}  // namespace mrsns::igtlink
