#include "mrsns/igtlink/server.h"

#include <asio.hpp>
#include <random>
#include <fstream>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <deque>
#include <map>
#include <mutex>
#include <set>
#include <thread>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/igtlink/framer.h"

namespace mrsns::igtlink {
namespace {

using Clock = std::chrono::steady_clock;
using Bytes = std::shared_ptr<const std::vector<std::uint8_t>>;

struct QueuedMessage {
  Bytes bytes;
  Channel channel;
};

}  // namespace

struct Server::Impl : std::enable_shared_from_this<Server::Impl> {
  struct Session : std::enable_shared_from_this<Session> {
    Session(Impl& owner, asio::ip::tcp::socket s, ClientId client_id)
        : server(owner),
          socket(std::move(s)),
          timer(socket.get_executor()),
          id(client_id),
          pause_timer(socket.get_executor()),
          framer(owner.options.decode),
          tokens(owner.inbound.max_messages_per_s) {
      framer.setBodyLimit(owner.inbound.max_body_size);
    }

    Impl& server;
    asio::ip::tcp::socket socket;
    asio::steady_timer timer;
    ClientId id;
    asio::steady_timer pause_timer;  // resumes reading a client that sent too many messages
    MessageFramer framer;
    std::array<std::uint8_t, 65536> read_buffer{};
    Clock::time_point last_progress = Clock::now();
    // Token bucket of InboundLimits::max_messages_per_s (I/O thread only).
    double tokens;
    Clock::time_point tokens_at = Clock::now();
    bool paused = false;

    std::mutex queue_mutex;  // guards the fields below (producers on other threads)
    std::deque<QueuedMessage> queue;
    std::size_t stream_queued = 0;
    std::size_t reliable_bytes = 0;
    bool writing = false;
    bool closed = false;

    void start() {
      read();
      watchdog();
    }

    void read() {
      auto self = shared_from_this();
      socket.async_read_some(asio::buffer(read_buffer), [self](const asio::error_code& ec, std::size_t n) {
        if (ec) {
          self->close();
          return;
        }
        self->consume(n);
        if (!self->isClosed()) self->readWhenAllowed();
      });
    }

    // Reads on at once, or after the pause that brings a client that sent too
    // many messages back to its rate.
    void readWhenAllowed() {
      const double rate = server.inbound.max_messages_per_s;
      if (rate <= 0.0) {
        read();
        return;
      }
      const auto now = Clock::now();
      tokens = std::min(rate, tokens + rate * std::chrono::duration<double>(now - tokens_at).count());
      tokens_at = now;
      if (tokens >= 0.0) {
        read();
        return;
      }
      server.pauses.fetch_add(1);
      paused = true;
      pause_timer.expires_after(std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(-tokens / rate)));
      pause_timer.async_wait([self = shared_from_this()](const asio::error_code& ec) {
        self->paused = false;
        if (ec || self->isClosed()) return;
        self->last_progress = Clock::now();  // the pause is ours, not a stalled client
        self->readWhenAllowed();
      });
    }

    void consume(std::size_t n) {
      try {
        framer.push(std::span<const std::uint8_t>(read_buffer.data(), n));
      } catch (const Error& e) {
        protocolError(e.what());
        return;
      }
      for (;;) {
        std::optional<Message> message;
        try {
          message = framer.next();
        } catch (const Error& e) {
          if (framer.failed()) {
            protocolError(e.what());
            return;
          }
          server.malformed.fetch_add(1);
          logger()->warn("OpenIGTLink client {}: skipped a malformed message: {}", id, e.what());
          last_progress = Clock::now();
          continue;
        }
        if (!message) break;
        last_progress = Clock::now();
        tokens -= 1.0;
        server.received.fetch_add(1);
        if (server.on_message) server.on_message(id, *message);
      }
      if (framer.bufferedBytes() == 0) last_progress = Clock::now();
    }

    void protocolError(const std::string& what) {
      server.protocol_closed.fetch_add(1);
      server.malformed.fetch_add(1);
      logger()->warn("OpenIGTLink client {}: closing the connection: {}", id, what);
      close();
    }

    // Closes clients that stall in the middle of a message (slowloris).
    void watchdog() {
      auto self = shared_from_this();
      timer.expires_after(std::chrono::milliseconds(250));
      timer.async_wait([self](const asio::error_code& ec) {
        if (ec || self->isClosed()) return;
        const double stalled = std::chrono::duration<double>(Clock::now() - self->last_progress).count();
        if (!self->paused && self->framer.bufferedBytes() > 0 &&
            stalled > self->server.options.incomplete_message_timeout_s) {
          self->protocolError("message incomplete for " + std::to_string(stalled) + " s");
          return;
        }
        self->watchdog();
      });
    }

    bool isClosed() {
      std::lock_guard lock(queue_mutex);
      return closed;
    }

    // Called from any thread.
    void enqueue(const Bytes& bytes, Channel channel) {
      bool start_write = false;
      {
        std::lock_guard lock(queue_mutex);
        if (closed) return;
        if (channel == Channel::Stream) {
          if (stream_queued >= server.options.stream_queue_limit) {
            // Drop the oldest stream message not being written (index 0 is in flight when writing).
            for (auto it = queue.begin() + (writing ? 1 : 0); it != queue.end(); ++it) {
              if (it->channel == Channel::Stream) {
                queue.erase(it);
                --stream_queued;
                server.dropped.fetch_add(1);
                break;
              }
            }
          }
          ++stream_queued;
        } else {
          reliable_bytes += bytes->size();
          if (reliable_bytes > server.options.reliable_queue_limit_bytes) {
            server.slow_closed.fetch_add(1);
            logger()->warn("OpenIGTLink client {}: disconnected, {} bytes of models queued (client too slow)", id,
                           reliable_bytes);
            asio::post(socket.get_executor(), [self = shared_from_this()] { self->close(); });
            return;
          }
        }
        queue.push_back({bytes, channel});
        if (!writing) {
          writing = true;
          start_write = true;
        }
      }
      if (start_write) asio::post(socket.get_executor(), [self = shared_from_this()] { self->writeNext(); });
    }

    void writeNext() {
      Bytes bytes;
      {
        std::lock_guard lock(queue_mutex);
        if (closed || queue.empty()) {
          writing = false;
          return;
        }
        bytes = queue.front().bytes;
      }
      auto self = shared_from_this();
      asio::async_write(socket, asio::buffer(*bytes), [self, bytes](const asio::error_code& ec, std::size_t) {
        if (ec) {
          self->close();
          return;
        }
        {
          std::lock_guard lock(self->queue_mutex);
          if (!self->queue.empty()) {
            if (self->queue.front().channel == Channel::Stream) {
              --self->stream_queued;
            } else {
              self->reliable_bytes -= self->queue.front().bytes->size();
            }
            self->queue.pop_front();
          }
        }
        self->server.sent.fetch_add(1);
        self->writeNext();
      });
    }

    // Runs on the I/O thread.
    void close() {
      {
        std::lock_guard lock(queue_mutex);
        if (closed) return;
        closed = true;
        queue.clear();
      }
      asio::error_code ignored;
      socket.shutdown(asio::ip::tcp::socket::shutdown_both, ignored);
      socket.close(ignored);
      timer.cancel();
      pause_timer.cancel();
      server.removeSession(id);
    }
  };

  explicit Impl(ServerOptions o) : options(std::move(o)), acceptor(io), accept_retry(io) {}

  ServerOptions options;
  InboundLimits inbound;
  asio::io_context io;
  asio::ip::tcp::acceptor acceptor;
  asio::steady_timer accept_retry;  // back-off after a failed accept (e.g. out of file descriptors)
  std::thread thread;
  std::atomic<bool> is_running{false};
  std::uint16_t bound_port = 0;

  ConnectHandler on_connect;
  ConnectHandler on_disconnect;
  MessageHandler on_message;

  mutable std::mutex sessions_mutex;
  std::map<ClientId, std::shared_ptr<Session>> sessions;
  ClientId next_id = 1;

  std::atomic<std::uint64_t> accepted{0}, refused{0}, sent{0}, dropped{0}, received{0}, malformed{0},
      protocol_closed{0}, slow_closed{0}, pauses{0};

  void accept() {
    acceptor.async_accept([self = shared_from_this()](const asio::error_code& ec, asio::ip::tcp::socket socket) {
      if (ec) {
        // Closed by stop(): done. Anything else (no file descriptor left,
        // a connection reset before it was taken) is retried after a pause:
        // at once, a closed acceptor or a process out of descriptors would
        // fail again at once and spin the I/O thread forever.
        if (ec == asio::error::operation_aborted || !self->acceptor.is_open()) return;
        self->accept_retry.expires_after(std::chrono::milliseconds(20));
        self->accept_retry.async_wait([self](const asio::error_code& wait_ec) {
          if (!wait_ec && self->acceptor.is_open()) self->accept();
        });
        return;
      }
      std::shared_ptr<Session> session;
      {
        std::lock_guard lock(self->sessions_mutex);
        if (self->sessions.size() >= self->options.max_clients) {
          self->refused.fetch_add(1);
          logger()->warn("OpenIGTLink server: refused a connection, {} clients already connected",
                         self->sessions.size());
          asio::error_code ignored;
          socket.close(ignored);
        } else {
          asio::error_code ignored;
          socket.set_option(asio::ip::tcp::no_delay(true), ignored);
          session = std::make_shared<Session>(*self, std::move(socket), self->next_id++);
          self->sessions.emplace(session->id, session);
          self->accepted.fetch_add(1);
        }
      }
      if (session) {
        session->start();
        if (self->on_connect) self->on_connect(session->id);
      }
      self->accept();
    });
  }

  void removeSession(ClientId id) {
    bool removed = false;
    {
      std::lock_guard lock(sessions_mutex);
      removed = sessions.erase(id) > 0;
    }
    if (removed && on_disconnect) on_disconnect(id);
  }

  std::vector<std::shared_ptr<Session>> snapshot() const {
    std::lock_guard lock(sessions_mutex);
    std::vector<std::shared_ptr<Session>> list;
    list.reserve(sessions.size());
    for (const auto& entry : sessions) list.push_back(entry.second);
    return list;
  }
};

Server::Server(ServerOptions options) : impl_(std::make_shared<Impl>(std::move(options))) {}

Server::~Server() {
  stop();
}

void Server::onConnect(ConnectHandler handler) {
  impl_->on_connect = std::move(handler);
}
void Server::onDisconnect(ConnectHandler handler) {
  impl_->on_disconnect = std::move(handler);
}
void Server::onMessage(MessageHandler handler) {
  impl_->on_message = std::move(handler);
}
void Server::limitInbound(InboundLimits limits) {
  if (limits.max_messages_per_s < 0.0 || !std::isfinite(limits.max_messages_per_s)) {
    throw InvalidArgumentError("OpenIGTLink server: max_messages_per_s must be 0 (unlimited) or positive");
  }
  impl_->inbound = std::move(limits);
}

void Server::start() {
  if (impl_->is_running) return;
  asio::error_code ec;
  const auto address = asio::ip::make_address(impl_->options.bind_address, ec);
  if (ec) {
    throw NetworkError("cannot listen on '" + impl_->options.bind_address +
                       "': not an IP address (use 127.0.0.1 for this machine only, or 0.0.0.0 for every interface)");
  }
  const asio::ip::tcp::endpoint endpoint(address, impl_->options.port);
  impl_->acceptor.open(endpoint.protocol(), ec);
  if (!ec) impl_->acceptor.set_option(asio::ip::tcp::acceptor::reuse_address(true), ec);
  if (!ec) impl_->acceptor.bind(endpoint, ec);
  if (!ec) impl_->acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) {
    asio::error_code ignored;
    impl_->acceptor.close(ignored);
    throw NetworkError("cannot listen on " + impl_->options.bind_address + ":" + std::to_string(impl_->options.port) +
                       ": " + ec.message() +
                       (ec == asio::error::address_in_use
                            ? " (another server, e.g. PlusServer or Slicer, uses this port: "
                              "stop it or choose another port)"
                            : ""));
  }
  impl_->bound_port = impl_->acceptor.local_endpoint().port();
  impl_->accept();
  impl_->is_running = true;
  impl_->thread = std::thread([impl = impl_] { impl->io.run(); });
  logger()->info("OpenIGTLink server listening on {}:{}", impl_->options.bind_address, impl_->bound_port);
}

void Server::stop() {
  if (!impl_->is_running.exchange(false)) return;
  asio::post(impl_->io, [impl = impl_] {
    asio::error_code ignored;
    impl->acceptor.close(ignored);
    impl->accept_retry.cancel();
    for (auto& session : impl->snapshot()) session->close();
  });
  // Closing cancels every pending operation, so run() returns.
  if (impl_->thread.joinable()) impl_->thread.join();
  impl_->io.restart();
}

std::uint16_t Server::port() const {
  return impl_->bound_port;
}
bool Server::running() const {
  return impl_->is_running;
}

void Server::broadcast(const Message& message, HeaderVersion version, Channel channel) {
  broadcastEncoded(std::make_shared<const std::vector<std::uint8_t>>(encodeMessage(message, version)), channel);
}

void Server::broadcastEncoded(std::shared_ptr<const std::vector<std::uint8_t>> bytes, Channel channel) {
  for (auto& session : impl_->snapshot()) session->enqueue(bytes, channel);
}

bool Server::send(ClientId client, const Message& message, HeaderVersion version, Channel channel) {
  return sendEncoded(client, std::make_shared<const std::vector<std::uint8_t>>(encodeMessage(message, version)),
                     channel);
}

bool Server::sendEncoded(ClientId client, std::shared_ptr<const std::vector<std::uint8_t>> bytes, Channel channel) {
  std::shared_ptr<Impl::Session> session;
  {
    std::lock_guard lock(impl_->sessions_mutex);
    const auto it = impl_->sessions.find(client);
    if (it == impl_->sessions.end()) return false;
    session = it->second;
  }
  session->enqueue(std::move(bytes), channel);
  return true;
}

std::size_t Server::queuedMessages() const {
  std::size_t n = 0;
  for (const auto& session : impl_->snapshot()) {
    std::lock_guard lock(session->queue_mutex);
    if (!session->closed) n += session->queue.size();
  }
  return n;
}

ServerStats Server::stats() const {
  ServerStats s;
  {
    std::lock_guard lock(impl_->sessions_mutex);
    s.clients = impl_->sessions.size();
  }
  s.connections_accepted = impl_->accepted;
  s.connections_refused = impl_->refused;
  s.messages_sent = impl_->sent;
  s.stream_messages_dropped = impl_->dropped;
  s.messages_received = impl_->received;
  s.malformed_messages = impl_->malformed;
  s.clients_closed_for_protocol_errors = impl_->protocol_closed;
  s.clients_closed_as_too_slow = impl_->slow_closed;
  s.inbound_pauses = impl_->pauses;
  return s;
}

std::uint16_t freeLocalPort(const std::string& address) {
  // Below the system's ephemeral range: a port the system hands out itself (to a server bound to port 0, to a
  // client's own end) could be taken before the server it is meant for binds, or a client retrying it could
  // connect to itself.
  int low = 32768;
  if (std::ifstream range("/proc/sys/net/ipv4/ip_local_port_range"); range) range >> low;
  const int top = std::clamp(low - 1, 2048, 65535);
  const int bottom = std::max(1024, top - 20000);
  // A port handed out earlier in this process is not handed out again: several
  // rooms started at once (tests run their seeds concurrently) would
  // otherwise race for the same free port between this check and their bind.
  static std::mutex handed_out_mutex;
  static std::set<std::uint16_t> handed_out;
  const std::lock_guard lock(handed_out_mutex);
  std::mt19937 rng(std::random_device{}());
  std::uniform_int_distribution<int> pick(bottom, top);
  std::string last_error = "no attempt";
  for (int attempt = 0; attempt < 200; ++attempt) {
    const auto port = static_cast<std::uint16_t>(pick(rng));
    if (handed_out.contains(port)) continue;
    try {
      asio::io_context io;
      asio::ip::tcp::acceptor acceptor(io);
      const asio::ip::tcp::endpoint endpoint(asio::ip::make_address(address), port);
      acceptor.open(endpoint.protocol());
      acceptor.bind(endpoint);
      handed_out.insert(port);
      return port;
    } catch (const std::exception& e) {
      last_error = e.what();
    }
  }
  throw NetworkError("no free TCP port on " + address + " between " + std::to_string(bottom) + " and " +
                     std::to_string(top) + ": " + last_error);
}

}  // namespace mrsns::igtlink
