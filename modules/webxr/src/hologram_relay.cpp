#include "mrsns/webxr/hologram_relay.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <deque>
#include <limits>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <vector>

#include "mrsns/core/log.h"
#include "mrsns/core/wall_clock.h"
#include "mrsns/igtlink/client.h"
#include "mrsns/igtlink/header.h"
#include "mrsns/igtlink/message.h"
#include "mrsns/igtlink/ndarray.h"
#include "mrsns/igtlink/polydata_mesh.h"
#include "mrsns/igtlink/status.h"
#include "mrsns/igtlink/string_message.h"
#include "mrsns/igtlink/transform.h"

namespace mrsns::webxr {
namespace {

using Json = nlohmann::json;

constexpr std::size_t kLatencyWindow = 2000;  // recent reports the percentiles are taken over
constexpr std::size_t kMaxConfirmationBytes = 256;

/// A binary message of the page: u32 (little endian) length of a JSON header,
/// the header, zero padding to a multiple of 4, then the arrays it announces.
WsFrameBytes binaryMessage(const Json& header, const std::vector<std::vector<std::uint8_t>>& arrays) {
  const std::string text = header.dump();
  std::vector<std::uint8_t> bytes(4);
  const auto n = static_cast<std::uint32_t>(text.size());
  for (int i = 0; i < 4; ++i) bytes[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(n >> (8 * i));
  bytes.insert(bytes.end(), text.begin(), text.end());
  bytes.resize((bytes.size() + 3) / 4 * 4, 0);
  for (const auto& array : arrays) bytes.insert(bytes.end(), array.begin(), array.end());
  return binaryFrame(bytes);
}

template <typename T, typename Source>
std::vector<std::uint8_t> littleEndianArray(const Source& values, std::size_t count) {
  static_assert(std::endian::native == std::endian::little, "the page's arrays are little endian");
  std::vector<std::uint8_t> bytes(count * sizeof(T));
  for (std::size_t i = 0; i < count; ++i) {
    const T v = static_cast<T>(values(i));
    std::memcpy(bytes.data() + i * sizeof(T), &v, sizeof(T));
  }
  return bytes;
}

WsFrameBytes meshMessage(const std::string& name, const TriangleMesh& mesh) {
  const auto nv = static_cast<std::size_t>(mesh.vertices.rows());
  const auto nf = static_cast<std::size_t>(mesh.faces.rows());
  const bool colors = mesh.colors.rows() == mesh.vertices.rows() && nv > 0;
  std::vector<std::vector<std::uint8_t>> arrays;
  arrays.push_back(littleEndianArray<float>(
      [&](std::size_t i) { return mesh.vertices(static_cast<Eigen::Index>(i / 3), static_cast<Eigen::Index>(i % 3)); },
      nv * 3));
  arrays.push_back(littleEndianArray<std::uint32_t>(
      [&](std::size_t i) { return mesh.faces(static_cast<Eigen::Index>(i / 3), static_cast<Eigen::Index>(i % 3)); },
      nf * 3));
  if (colors) {
    arrays.push_back(littleEndianArray<float>(
        [&](std::size_t i) { return mesh.colors(static_cast<Eigen::Index>(i / 3), static_cast<Eigen::Index>(i % 3)); },
        nv * 3));
  }
  return binaryMessage(Json{{"type", "mesh"}, {"name", name}, {"vertices", nv}, {"faces", nf}, {"colors", colors}},
                       arrays);
}

double percentile(std::vector<double> values, double q) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto k = static_cast<std::size_t>(std::ceil(q * static_cast<double>(values.size()))) - 1;
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

}  // namespace

struct HologramRelay::Impl {
  Impl(WebXrServer& s, HologramRelayOptions o) : server(s), options(std::move(o)) {
    igtlink::ClientOptions client_options;
    client_options.host = options.stream_host;
    client_options.port = options.stream_port;
    client_options.backoff_max_s = 1.0;
    client = std::make_unique<igtlink::Client>(client_options);
  }

  // --- the stream (client thread) ---------------------------------------------------------------------------------

  void onStream(const igtlink::Message& message) {
    const std::string& type = message.header.type;
    const std::string& device = message.header.device_name;
    const double sample_time = igtlink::timestampToSeconds(message.header.timestamp);
    std::lock_guard lock(mutex);
    try {
      if (const auto* transform = message.as<igtlink::TransformContent>()) {
        Json m = Json::array();
        for (int r = 0; r < 4; ++r) {
          for (int c = 0; c < 4; ++c) m.push_back(transform->matrix(r, c));
        }
        ++transforms_relayed;
        const auto frame = textFrame(
            Json{{"type", "transform"}, {"name", device}, {"m", m}, {"t", sample_time}, {"seq", transforms_relayed}}
                .dump());
        transforms[device] = frame;
        server.broadcast(frame);
      } else if (const auto* polydata = message.as<igtlink::PolyDataContent>()) {
        const auto frame = meshMessage(device, igtlink::meshFromPolyData(*polydata));
        meshes[device] = frame;
        vertices.erase(device);  // a new mesh replaces earlier vertex updates
        server.broadcast(frame);
      } else if (const auto* status = message.as<igtlink::StatusContent>()) {
        const bool ok = status->code == static_cast<std::uint16_t>(igtlink::StatusCode::kOk);
        const auto frame = textFrame(
            Json{{"type", "status"},
                 {"name", device},
                 {"ok", ok},
                 {"text", ok ? "" : status->error_name + (status->message.empty() ? "" : ": " + status->message)}}
                .dump());
        statuses[device] = frame;
        server.broadcast(frame);
      } else if (const auto* text = message.as<igtlink::StringContent>(); text != nullptr && device == "Prompt") {
        prompt = textFrame(
            Json{{"type", "prompt"}, {"text", text->text}}.dump(-1, ' ', false, Json::error_handler_t::replace));
        server.broadcast(prompt);
      } else if (type == "NDARRAY") {
        const auto* raw = message.as<igtlink::RawContent>();
        if (raw == nullptr) return;
        const auto array = igtlink::decodeNdArray(raw->bytes);
        if (array.size.size() != 2 || array.size[1] != 3) return;
        const std::size_t n = array.size[0];
        const auto frame =
            binaryMessage(Json{{"type", "vertices"}, {"name", device}, {"count", n}},
                          {littleEndianArray<float>([&](std::size_t i) { return array.values[i]; }, n * 3)});
        vertices[device] = frame;
        server.broadcast(frame);
      }
    } catch (const std::exception& e) {
      logger()->warn("WebXR relay: {} '{}' not relayed: {}", type, device, e.what());
    }
  }

  void onStreamConnection(bool connected) {
    std::lock_guard lock(mutex);
    stream_connected = connected;
    if (connected) forgetScene();  // the streamer sends the whole scene again on connect
    server.broadcast(streamState());
  }

  WsFrameBytes streamState() const {  // mutex held
    return textFrame(Json{{"type", "stream"}, {"connected", stream_connected}}.dump());
  }

  // --- the pages (WebXR server thread) ------------------------------------------------------------------------------

  void onPaired(WebXrClientId page) {
    std::lock_guard lock(mutex);
    // The relay is the stream's headset only while a page is paired, so the stream's "headset connected"
    // (readyClients) means a page someone has paired.
    if (++paired_pages == 1 && started) client->start();
    server.send(page, textFrame(Json{{"type", "hello"}, {"units", "mm"}, {"frame", "Hologram"}}.dump()));
    server.send(page, streamState());
    for (const auto& [name, frame] : meshes) server.send(page, frame);
    for (const auto& [name, frame] : vertices) server.send(page, frame);
    for (const auto& [name, frame] : statuses) server.send(page, frame);
    for (const auto& [name, frame] : transforms) server.send(page, frame);
    if (prompt) server.send(page, prompt);
    if (!latency_text.empty()) server.send(page, textFrame(latency_text));
  }

  void onPageGone() {
    {
      std::lock_guard lock(mutex);
      if (paired_pages == 0 || --paired_pages > 0) return;
    }
    client->stop();  // not under the mutex: the client's thread may be waiting for it
    std::lock_guard lock(mutex);
    if (paired_pages > 0) {  // a page paired meanwhile
      if (started) client->start();
      return;
    }
    stream_connected = false;
    forgetScene();
  }

  void forgetScene() {  // mutex held
    meshes.clear();
    vertices.clear();
    transforms.clear();
    statuses.clear();
    prompt.reset();
  }

  void onPage(WebXrClientId page, const std::string& text) {
    Json message;
    try {
      message = Json::parse(text);
    } catch (const std::exception&) {
      return;  // counted by the server; nothing else to do with it
    }
    if (!message.is_object()) return;
    const std::string type = message.value("type", "");
    if (type == "confirm") {
      std::string confirmation = message.value("text", "confirmed");
      confirmation.resize(std::min(confirmation.size(), kMaxConfirmationBytes));
      auto out = igtlink::makeMessage("Confirm", igtlink::StringContent{igtlink::kEncodingUtf8, confirmation},
                                      unixTimeSeconds());
      if (client->send(out, igtlink::HeaderVersion::kV2)) {
        std::lock_guard lock(mutex);
        ++confirmations_forwarded;
      } else {
        server.send(
            page,
            textFrame(
                R"({"type":"prompt","text":"The workstation's stream is not connected: the confirmation was not delivered."})"));
      }
    } else if (type == "shown") {
      shown(page, message);
    }
  }

  void shown(WebXrClientId page, const Json& message) {
    const auto models = message.find("models");
    if (models == message.end() || !models->is_array()) return;
    for (const auto& entry : *models) {
      DisplayedPose pose;
      pose.client = page;
      try {
        pose.model = entry.at("name").get<std::string>();
        pose.sample_time = entry.at("t").get<double>();
        const auto& m = entry.at("m");
        if (!m.is_array() || m.size() != 16) continue;
        for (std::size_t i = 0; i < 16; ++i) pose.matrix[i] = m[i].get<double>();
      } catch (const std::exception&) {
        continue;
      }
      pose.latency_ms = (unixTimeSeconds() - pose.sample_time) * 1e3;
      displayed(pose);
    }
  }

  void displayed(const DisplayedPose& pose) {
    std::function<void(const DisplayedPose&)> handler;
    {
      std::lock_guard lock(mutex);
      ++display_reports;
      // Only the scene's own models count (a page cannot grow this with names of its own).
      if (meshes.count(pose.model) > 0) shown_models.insert(pose.model);
      if (std::isfinite(pose.latency_ms) && pose.latency_ms >= 0.0 && pose.latency_ms < 60e3) {
        latencies.push_back(pose.latency_ms);
        if (latencies.size() > kLatencyWindow) latencies.pop_front();
      }
      const double now = unixTimeSeconds();
      if (now - latency_sent_at >= 1.0 && !latencies.empty()) {
        latency_sent_at = now;
        const std::vector<double> recent(latencies.begin(), latencies.end());
        latency_text =
            Json{{"type", "latency"}, {"p50_ms", percentile(recent, 0.5)}, {"p99_ms", percentile(recent, 0.99)}}.dump();
        server.broadcast(textFrame(latency_text));
      }
      handler = on_displayed;
    }
    if (handler) handler(pose);
  }

  WebXrServer& server;
  HologramRelayOptions options;
  std::unique_ptr<igtlink::Client> client;

  mutable std::mutex mutex;  // guards everything below
  bool started = false;
  std::size_t paired_pages = 0;
  bool stream_connected = false;
  std::map<std::string, WsFrameBytes> meshes, vertices, transforms, statuses;
  WsFrameBytes prompt;
  std::uint64_t transforms_relayed = 0;
  std::uint64_t confirmations_forwarded = 0;
  std::uint64_t display_reports = 0;
  std::set<std::string> shown_models;  ///< the scene's models some page reported drawing
  std::deque<double> latencies;
  double latency_sent_at = 0.0;
  std::string latency_text;
  std::function<void(const DisplayedPose&)> on_displayed;
};

HologramRelay::HologramRelay(WebXrServer& server, HologramRelayOptions options)
    : impl_(std::make_shared<Impl>(server, std::move(options))) {
  // The server may outlive the relay: its handlers hold the relay weakly.
  std::weak_ptr<Impl> weak = impl_;
  server.onPaired([weak](WebXrClientId page) {
    if (auto impl = weak.lock()) impl->onPaired(page);
  });
  server.onMessage([weak](WebXrClientId page, const std::string& text) {
    if (auto impl = weak.lock()) impl->onPage(page, text);
  });
  server.onDisconnect([weak](WebXrClientId) {
    if (auto impl = weak.lock()) impl->onPageGone();
  });
  Impl* impl = impl_.get();  // the client is the Impl's own and stops before it goes
  impl->client->onMessage([impl](const igtlink::Message& message) { impl->onStream(message); });
  impl->client->onConnectionChange([impl](bool connected) { impl->onStreamConnection(connected); });
}

HologramRelay::~HologramRelay() {
  stop();
}

void HologramRelay::start() {
  std::lock_guard lock(impl_->mutex);
  impl_->started = true;
  if (impl_->paired_pages > 0) impl_->client->start();
}

void HologramRelay::stop() {
  {
    std::lock_guard lock(impl_->mutex);
    impl_->started = false;
  }
  impl_->client->stop();
}

void HologramRelay::onDisplayed(std::function<void(const DisplayedPose&)> handler) {
  std::lock_guard lock(impl_->mutex);
  impl_->on_displayed = std::move(handler);
}

HologramRelayStats HologramRelay::stats() const {
  std::lock_guard lock(impl_->mutex);
  HologramRelayStats s;
  s.stream_connected = impl_->stream_connected;
  s.models = impl_->meshes.size();
  s.transforms_relayed = impl_->transforms_relayed;
  s.confirmations_forwarded = impl_->confirmations_forwarded;
  s.display_reports = impl_->display_reports;
  s.models_shown = impl_->shown_models.size();
  const std::vector<double> recent(impl_->latencies.begin(), impl_->latencies.end());
  s.display_latency_p50_ms = percentile(recent, 0.5);
  s.display_latency_p99_ms = percentile(recent, 0.99);
  s.display_latency_max_ms =
      recent.empty() ? std::numeric_limits<double>::quiet_NaN() : *std::max_element(recent.begin(), recent.end());
  return s;
}

}  // namespace mrsns::webxr
