// PlusServer emulation over mrsns::igtlink::Server: per-client header
// version and TDATA subscription, TRANSFORM/TDATA/IMAGE encoded once per
// version and queued per client.
#include "mrsns/simulation/plus_server.h"

#include <chrono>
#include <map>
#include <mutex>
#include <optional>
#include <thread>

#include "mrsns/core/error.h"
#include "mrsns/igtlink/codec.h"
#include "mrsns/igtlink/server.h"

namespace mrsns::simulation {

namespace {

using Bytes = std::shared_ptr<const std::vector<std::uint8_t>>;

Bytes encode(const igtlink::Message& m, igtlink::HeaderVersion v) {
  return std::make_shared<const std::vector<std::uint8_t>>(igtlink::encodeMessage(m, v));
}

igtlink::Message withStatus(igtlink::Message m, bool valid) {
  m.metadata.push_back({"TransformStatus", igtlink::kEncodingUsAscii, valid ? "OK" : "INVALID"});
  return m;
}

}  // namespace

struct PlusServerEmulator::Impl {
  PlusServerOptions options;
  std::unique_ptr<igtlink::Server> server;
  std::uint16_t bound_port = 0;

  struct Client {
    igtlink::HeaderVersion version = igtlink::HeaderVersion::kV1;
    bool tdata = false;
    double tdata_interval_s = 0.0;
    double last_tdata = -1e300;
  };
  mutable std::mutex mutex;
  std::map<igtlink::ClientId, Client> clients;
  PlusServerStats stats;

  void onMessage(igtlink::ClientId id, const igtlink::Message& m) {
    const std::string& type = m.header.type;
    igtlink::HeaderVersion reply_version = igtlink::HeaderVersion::kV1;
    {
      std::lock_guard lock(mutex);
      auto it = clients.find(id);
      if (it == clients.end()) return;
      if (m.header.version >= 2 && options.max_header_version >= 2) it->second.version = igtlink::HeaderVersion::kV2;
      reply_version = it->second.version;
      ++stats.requests;
      if (type == "STT_TDATA") {
        it->second.tdata = true;
        const auto* request = m.as<igtlink::StartTrackingDataContent>();
        it->second.tdata_interval_s = request ? std::max(0, request->resolution_ms) / 1000.0 : 0.0;
      } else if (type == "STP_TDATA") {
        it->second.tdata = false;
      }
    }
    std::optional<igtlink::Message> reply;
    if (type == "STT_TDATA" || type == "STP_TDATA") {
      reply = igtlink::makeMessage("RTS_TDATA", m.header.device_name, igtlink::RtsStatus{0});
    } else if (type == "GET_STATUS") {
      igtlink::StatusContent status;
      status.message = options.robot_serial.empty()
                           ? std::string("mrsns-sim (simulated PlusServer)")
                           : "mrsns-sim (simulated PlusServer; UR controller serial " + options.robot_serial + ")";
      reply = igtlink::makeMessage("", status);
    }
    std::lock_guard lock(mutex);
    // The server may be stopping (a scheduled disconnect): then there is nobody to answer.
    if (reply && server) server->send(id, *reply, reply_version, igtlink::Channel::Reliable);
  }
};

PlusServerEmulator::PlusServerEmulator(PlusServerOptions options) : impl_(std::make_shared<Impl>()) {
  if (options.max_header_version < 1 || options.max_header_version > 2) {
    throw InvalidArgumentError("max_header_version must be 1 or 2");
  }
  impl_->options = std::move(options);
}

PlusServerEmulator::~PlusServerEmulator() {
  stop();
}

void PlusServerEmulator::start() {
  if (running()) return;
  igtlink::ServerOptions o;
  o.bind_address = impl_->options.bind_address;
  o.port = impl_->bound_port ? impl_->bound_port : impl_->options.port;
  // Clients of a tracker send only requests: a few KB is plenty.
  o.decode.max_body_size = 64 * 1024;
  // PlusServer writes to each client with blocking sends on the client's own thread: a client that stalls
  // for a moment (a loaded workstation: 100-150 ms off the CPU) delays its stream but loses nothing. The
  // queue holds about half a second of a full room (8 tools at 60 Hz and 30 frames/s) before the oldest
  // message goes; the default 16 lost a replayed frame in a loaded run.
  o.stream_queue_limit = 256;
  auto server = std::make_unique<igtlink::Server>(o);
  std::weak_ptr<Impl> weak = impl_;
  server->onConnect([weak](igtlink::ClientId id) {
    if (auto impl = weak.lock()) {
      std::lock_guard lock(impl->mutex);
      impl->clients[id] = Impl::Client{};
      ++impl->stats.clients_connected;
    }
  });
  server->onDisconnect([weak](igtlink::ClientId id) {
    if (auto impl = weak.lock()) {
      std::lock_guard lock(impl->mutex);
      impl->clients.erase(id);
    }
  });
  server->onMessage([weak](igtlink::ClientId id, const igtlink::Message& m) {
    if (auto impl = weak.lock()) impl->onMessage(id, m);
  });
  try {
    server->start();
  } catch (const NetworkError& e) {
    throw NetworkError("the simulated PlusServer cannot listen on " + o.bind_address + ":" + std::to_string(o.port) +
                       " (" + e.what() + "); stop whatever uses that port or set tracker.port in the scenario");
  }
  impl_->bound_port = server->port();
  std::lock_guard lock(impl_->mutex);
  impl_->server = std::move(server);
}

void PlusServerEmulator::stop() {
  std::unique_ptr<igtlink::Server> server;
  {
    std::lock_guard lock(impl_->mutex);
    server = std::move(impl_->server);
    impl_->clients.clear();
  }
  if (server) server->stop();
}

bool PlusServerEmulator::running() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->server != nullptr;
}

std::uint16_t PlusServerEmulator::port() const {
  return impl_->bound_port;
}

void PlusServerEmulator::publishTools(const std::vector<MeasuredTool>& tools, double timestamp_utc) {
  std::lock_guard lock(impl_->mutex);
  if (!impl_->server || impl_->clients.empty()) return;
  const bool want_v2 = std::any_of(impl_->clients.begin(), impl_->clients.end(),
                                   [](const auto& c) { return c.second.version == igtlink::HeaderVersion::kV2; });
  struct Encoded {
    Bytes v1, v2;
  };
  std::vector<Encoded> transforms;
  igtlink::TrackingDataContent tdata;
  for (const auto& tool : tools) {
    if (tool.valid) {
      igtlink::TrackingElement e;
      e.name = tool.name;
      e.matrix = tool.tracker_T_tool;
      tdata.elements.push_back(e);
    }
    if (!tool.valid && impl_->options.send_valid_transforms_only) continue;
    const Eigen::Matrix4d matrix = tool.valid ? tool.tracker_T_tool : Eigen::Matrix4d::Identity();
    const auto m = igtlink::makeMessage(tool.name, igtlink::TransformContent{matrix}, timestamp_utc);
    Encoded enc;
    if (tool.valid) enc.v1 = encode(m, igtlink::HeaderVersion::kV1);
    if (want_v2) enc.v2 = encode(withStatus(m, tool.valid), igtlink::HeaderVersion::kV2);
    transforms.push_back(enc);
  }
  Bytes tdata_v1, tdata_v2;
  for (auto& [id, client] : impl_->clients) {
    const bool v2 = client.version == igtlink::HeaderVersion::kV2;
    for (const auto& enc : transforms) {
      const Bytes& bytes = v2 ? enc.v2 : enc.v1;
      if (bytes && impl_->server->sendEncoded(id, bytes, igtlink::Channel::Stream)) ++impl_->stats.transform_messages;
    }
    if (client.tdata && timestamp_utc - client.last_tdata >= client.tdata_interval_s - 1e-6) {
      Bytes& bytes = v2 ? tdata_v2 : tdata_v1;
      if (!bytes) {
        bytes = encode(igtlink::makeMessage("Tracker", tdata, timestamp_utc),
                       v2 ? igtlink::HeaderVersion::kV2 : igtlink::HeaderVersion::kV1);
      }
      if (impl_->server->sendEncoded(id, bytes, igtlink::Channel::Stream)) ++impl_->stats.tdata_messages;
      client.last_tdata = timestamp_utc;
    }
  }
}

void PlusServerEmulator::publishImage(const BModeFrame& frame, double timestamp_utc) {
  if (frame.width <= 0 || frame.height <= 0 ||
      frame.pixels.size() != static_cast<std::size_t>(frame.width) * static_cast<std::size_t>(frame.height)) {
    throw InvalidArgumentError("a B-mode frame's pixel count does not match its size");
  }
  igtlink::ImageContent image;
  image.scalar_type = igtlink::ScalarType::kUint8;
  image.endian = igtlink::PixelEndian::kLittle;
  image.coordinate = igtlink::ImageCoordinate::kLps;
  image.size = {static_cast<std::uint16_t>(frame.width), static_cast<std::uint16_t>(frame.height), 1};
  image.subvolume_size = image.size;
  image.pixels = frame.pixels;
  // The wire holds the volume's centre (OpenIGTLink), not pixel (0,0).
  Eigen::Matrix4d ijk = frame.frame_T_image;
  ijk.block<3, 1>(0, 0) *= frame.spacing_x_mm;
  ijk.block<3, 1>(0, 1) *= frame.spacing_y_mm;
  ijk.block<3, 1>(0, 3) +=
      ijk.block<3, 3>(0, 0) * Eigen::Vector3d(0.5 * (frame.width - 1), 0.5 * (frame.height - 1), 0.0);
  image.ijk_to_xyz = ijk;
  const auto m = igtlink::makeMessage(frame.device_name, image, timestamp_utc);
  std::lock_guard lock(impl_->mutex);
  if (!impl_->server || impl_->clients.empty()) return;
  Bytes v1, v2;
  for (const auto& [id, client] : impl_->clients) {
    const bool is_v2 = client.version == igtlink::HeaderVersion::kV2;
    Bytes& bytes = is_v2 ? v2 : v1;
    if (!bytes) bytes = encode(m, is_v2 ? igtlink::HeaderVersion::kV2 : igtlink::HeaderVersion::kV1);
    if (impl_->server->sendEncoded(id, bytes, igtlink::Channel::Stream)) ++impl_->stats.image_messages;
  }
}

bool PlusServerEmulator::waitUntilSent(double timeout_s) const {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (true) {
    {
      std::lock_guard lock(impl_->mutex);
      if (!impl_->server || impl_->server->queuedMessages() == 0) return true;
    }
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

PlusServerStats PlusServerEmulator::stats() const {
  std::lock_guard lock(impl_->mutex);
  PlusServerStats s = impl_->stats;
  s.clients = impl_->clients.size();
  return s;
}

}  // namespace mrsns::simulation
