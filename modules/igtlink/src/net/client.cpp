#include "mrsns/igtlink/client.h"

#include <algorithm>
#include <asio.hpp>
#include <atomic>
#include <chrono>
#include <deque>
#include <mutex>
#include <thread>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/igtlink/framer.h"

namespace mrsns::igtlink {

struct Client::Impl : std::enable_shared_from_this<Client::Impl> {
  explicit Impl(ClientOptions o)
      : options(std::move(o)), socket(io), timer(io), framer(options.decode), backoff_s(options.backoff_initial_s) {}

  ClientOptions options;
  asio::io_context io;
  asio::ip::tcp::socket socket;
  asio::steady_timer timer;
  asio::ip::tcp::resolver::results_type endpoints;
  std::thread thread;
  MessageFramer framer;
  std::array<std::uint8_t, 65536> read_buffer{};
  double backoff_s;
  std::atomic<bool> stopping{false};
  std::atomic<bool> is_connected{false};
  std::atomic<std::uint64_t> connects{0}, received{0}, malformed{0}, sent{0};

  MessageHandler on_message;
  ConnectionHandler on_connection;

  std::mutex write_mutex;
  std::deque<std::shared_ptr<const std::vector<std::uint8_t>>> write_queue;
  bool writing = false;

  void connect() {
    if (stopping) return;
    asio::async_connect(socket, endpoints, [self = shared_from_this()](const asio::error_code& ec, const auto&) {
      if (self->stopping) return;
      if (ec) {
        self->retry(ec.message());
        return;
      }
      asio::error_code ignored;
      // Retrying a local port nobody listens on, the system may pick that very port as the client's own and the
      // socket connects to itself (TCP simultaneous open), which also keeps the server it waits for from binding.
      const auto local = self->socket.local_endpoint(ignored);
      const auto remote = self->socket.remote_endpoint(ignored);
      if (local == remote) {
        self->socket.close(ignored);
        self->retry("connected to itself: nobody listens on that port");
        return;
      }
      self->socket.set_option(asio::ip::tcp::no_delay(true), ignored);
      self->framer.reset();
      self->backoff_s = self->options.backoff_initial_s;
      self->is_connected = true;
      self->connects.fetch_add(1);
      logger()->info("OpenIGTLink client connected to {}:{}", self->options.host, self->options.port);
      if (self->on_connection) self->on_connection(true);
      self->read();
    });
  }

  void retry(const std::string& reason) {
    if (stopping) return;
    if (!options.reconnect) {
      logger()->warn("OpenIGTLink client: {}:{}: {}", options.host, options.port, reason);
      return;
    }
    logger()->debug("OpenIGTLink client: {}:{}: {}; retrying in {:.2f} s", options.host, options.port, reason,
                    backoff_s);
    timer.expires_after(
        std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(backoff_s)));
    backoff_s = std::min(backoff_s * 2.0, options.backoff_max_s);
    timer.async_wait([self = shared_from_this()](const asio::error_code& ec) {
      if (!ec) self->connect();
    });
  }

  void disconnected(const std::string& reason) {
    asio::error_code ignored;
    socket.shutdown(asio::ip::tcp::socket::shutdown_both, ignored);
    socket.close(ignored);
    {
      std::lock_guard lock(write_mutex);
      write_queue.clear();
      writing = false;
    }
    if (is_connected.exchange(false) && on_connection) on_connection(false);
    retry(reason);
  }

  void read() {
    socket.async_read_some(asio::buffer(read_buffer),
                           [self = shared_from_this()](const asio::error_code& ec, std::size_t n) {
                             if (self->stopping) return;
                             if (ec) {
                               self->disconnected(ec.message());
                               return;
                             }
                             try {
                               self->framer.push(std::span<const std::uint8_t>(self->read_buffer.data(), n));
                             } catch (const Error& e) {
                               self->malformed.fetch_add(1);
                               self->disconnected(std::string("unframeable data from the server: ") + e.what());
                               return;
                             }
                             for (;;) {
                               std::optional<Message> message;
                               try {
                                 message = self->framer.next();
                               } catch (const Error& e) {
                                 self->malformed.fetch_add(1);
                                 if (self->framer.failed()) {
                                   self->disconnected(e.what());
                                   return;
                                 }
                                 logger()->warn("OpenIGTLink client: skipped a malformed message: {}", e.what());
                                 continue;
                               }
                               if (!message) break;
                               self->received.fetch_add(1);
                               if (self->on_message) self->on_message(*message);
                             }
                             self->read();
                           });
  }

  void writeNext() {
    std::shared_ptr<const std::vector<std::uint8_t>> bytes;
    {
      std::lock_guard lock(write_mutex);
      if (write_queue.empty()) {
        writing = false;
        return;
      }
      bytes = write_queue.front();
    }
    asio::async_write(socket, asio::buffer(*bytes),
                      [self = shared_from_this(), bytes](const asio::error_code& ec, std::size_t) {
                        if (ec) return;  // the read side notices and reconnects
                        {
                          std::lock_guard lock(self->write_mutex);
                          if (!self->write_queue.empty()) self->write_queue.pop_front();
                        }
                        self->sent.fetch_add(1);
                        self->writeNext();
                      });
  }
};

Client::Client(ClientOptions options) : impl_(std::make_shared<Impl>(std::move(options))) {}
Client::~Client() {
  stop();
}

void Client::onMessage(MessageHandler handler) {
  impl_->on_message = std::move(handler);
}
void Client::onConnectionChange(ConnectionHandler handler) {
  impl_->on_connection = std::move(handler);
}

void Client::start() {
  if (impl_->thread.joinable()) return;
  asio::ip::tcp::resolver resolver(impl_->io);
  asio::error_code ec;
  impl_->endpoints = resolver.resolve(impl_->options.host, std::to_string(impl_->options.port), ec);
  if (ec) {
    throw NetworkError("cannot resolve OpenIGTLink server '" + impl_->options.host + "': " + ec.message() +
                       " (check the host name, or use an IP address)");
  }
  impl_->stopping = false;
  impl_->connect();
  impl_->thread = std::thread([impl = impl_] {
    // Keep run() alive between reconnect attempts.
    auto guard = asio::make_work_guard(impl->io);
    impl->io.run();
  });
}

void Client::stop() {
  if (!impl_->thread.joinable()) return;
  impl_->stopping = true;
  asio::post(impl_->io, [impl = impl_] {
    asio::error_code ignored;
    impl->timer.cancel();
    impl->socket.shutdown(asio::ip::tcp::socket::shutdown_both, ignored);
    impl->socket.close(ignored);
    impl->io.stop();
  });
  impl_->thread.join();
  impl_->io.restart();
  impl_->is_connected = false;
}

bool Client::send(const Message& message, HeaderVersion version) {
  if (!impl_->is_connected) return false;
  auto bytes = std::make_shared<const std::vector<std::uint8_t>>(encodeMessage(message, version));
  bool start = false;
  {
    std::lock_guard lock(impl_->write_mutex);
    impl_->write_queue.push_back(std::move(bytes));
    if (!impl_->writing) {
      impl_->writing = true;
      start = true;
    }
  }
  if (start) asio::post(impl_->io, [impl = impl_] { impl->writeNext(); });
  return true;
}

bool Client::connected() const {
  return impl_->is_connected;
}

ClientStats Client::stats() const {
  return ClientStats{impl_->is_connected, impl_->connects, impl_->received, impl_->malformed, impl_->sent};
}

}  // namespace mrsns::igtlink
