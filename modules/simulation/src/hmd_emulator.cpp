// The HMD emulator: an igtlink::Client on the hologram stream, the models it
// displays, and the headset's own drifting/jittering world frame.
#include "mrsns/simulation/hmd_emulator.h"

#include <chrono>
#include <cmath>
#include <deque>
#include <map>
#include <mutex>
#include <numbers>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/core/wall_clock.h"
#include "mrsns/igtlink/client.h"
#include "mrsns/igtlink/image.h"
#include "mrsns/igtlink/polydata_mesh.h"
#include "mrsns/tracking/unity_convention.h"

namespace mrsns::simulation {

namespace {

// splitmix64: a counter-based generator, so the headset's jitter at display
// frame k is a pure function of (seed, k).
std::uint64_t mix(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// Uniform in (0, 1), never 0 (log below).
double uniform(std::uint64_t h) {
  return (static_cast<double>(h >> 11) + 0.5) * 0x1.0p-53;
}

// Three independent standard normals from a key (Box-Muller on four uniforms).
Eigen::Vector3d gaussian3(std::uint64_t key) {
  double u[4];
  std::uint64_t state = key;
  for (double& v : u) {
    state = mix(state);
    v = uniform(state);
  }
  const double r0 = std::sqrt(-2.0 * std::log(u[0]));
  const double r1 = std::sqrt(-2.0 * std::log(u[2]));
  const double two_pi = 2.0 * std::numbers::pi;
  return {r0 * std::cos(two_pi * u[1]), r0 * std::sin(two_pi * u[1]), r1 * std::cos(two_pi * u[3])};
}

bool finiteRigid(const Eigen::Matrix4d& m) {
  if (!m.allFinite()) return false;
  if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-6) return false;
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  // float32 on the wire: orthonormal to ~1e-7; anything beyond 1e-4 is not a rotation.
  return (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-4 && r.determinant() > 0.0;
}

}  // namespace

struct HmdEmulator::Impl {
  HmdEmulatorOptions options;
  Eigen::Vector3d drift_direction = Eigen::Vector3d::UnitX();

  std::mutex lifecycle_mutex;  // guards client, clock; taken before `mutex`, never inside a handler
  std::unique_ptr<igtlink::Client> client;
  bool clock_started = false;
  std::chrono::steady_clock::time_point origin;
  std::uint64_t client_malformed_before = 0;  // malformed counted by clients already stopped

  mutable std::mutex mutex;  // guards everything below
  std::map<std::string, DisplayedModel> models;
  std::deque<std::string> prompts;
  HmdEmulatorStats counters;
  igtlink::HeaderVersion stream_version = igtlink::HeaderVersion::kV1;
  std::chrono::steady_clock::time_point clock_origin;  // copy of origin for the I/O thread

  Eigen::Isometry3d worldTHologram(double t_s) const {
    Eigen::Vector3d offset = drift_direction * (options.drift_mm_per_min * t_s / 60.0);
    if (options.jitter_mm > 0.0) {
      const auto frame = static_cast<std::int64_t>(std::floor(t_s * kHmdDisplayRateHz));
      const std::uint64_t key = mix(options.seed ^ mix(static_cast<std::uint64_t>(frame) + 0x6a09e667f3bcc909ULL));
      offset += gaussian3(key) * (options.jitter_mm / std::sqrt(3.0));
    }
    Eigen::Isometry3d w = Eigen::Isometry3d::Identity();
    w.translation() = offset;
    return w;
  }

  void hideAll(const char* status) {
    for (auto& [name, model] : models) {
      model.visible = false;
      model.status = status;
    }
  }

  DisplayedModel& model(const std::string& name) {
    auto [it, inserted] = models.try_emplace(name);
    if (inserted) it->second.name = name;
    return it->second;
  }

  void onConnection(bool connected) {
    std::lock_guard lock(mutex);
    counters.connected = connected;
    if (connected) {
      ++counters.connects;
    } else {
      hideAll("Disconnected");
    }
  }

  void onMessage(const igtlink::Message& m) noexcept {
    try {
      const double received = unixTimeSeconds();
      const double headset_t = std::chrono::duration<double>(std::chrono::steady_clock::now() - clock_origin).count();
      std::lock_guard lock(mutex);
      stream_version = m.header.version >= 2 ? igtlink::HeaderVersion::kV2 : igtlink::HeaderVersion::kV1;
      const std::string& type = m.header.type;
      const std::string& device = m.header.device_name;
      if (type == "POLYDATA") {
        onPolyData(m, device);
      } else if (type == "TRANSFORM") {
        const auto* content = m.as<igtlink::TransformContent>();
        if (content == nullptr || device.empty() || !finiteRigid(content->matrix)) {
          ++counters.malformed;
          return;
        }
        const Eigen::Matrix4d mm =
            options.unity ? tracking::transformFromUnity(content->matrix) : Eigen::Matrix4d(content->matrix);
        auto& shown = model(device);
        shown.hologram_T_model = Eigen::Isometry3d(mm);
        shown.world_T_model = worldTHologram(headset_t) * shown.hologram_T_model;
        shown.posed = true;
        shown.visible = true;
        shown.status = "TrackingOk";
        shown.sent_utc = m.header.timestampSeconds();
        shown.received_utc = received;
        shown.headset_time_s = headset_t;
        ++shown.updates;
        ++counters.transforms;
      } else if (type == "STATUS") {
        const auto* content = m.as<igtlink::StatusContent>();
        if (content == nullptr) {
          ++counters.malformed;
          return;
        }
        ++counters.statuses;
        if (device.empty()) return;  // a device-wide status (e.g. a PlusServer's), not a model's
        auto& shown = model(device);
        const bool ok = content->code == static_cast<std::uint16_t>(igtlink::StatusCode::kOk);
        shown.status = !content->error_name.empty() ? content->error_name
                                                    : (ok ? std::string("Ok") : "Code" + std::to_string(content->code));
        if (!ok) shown.visible = false;
      } else if (type == "STRING") {
        const auto* content = m.as<igtlink::StringContent>();
        if (content == nullptr) {
          ++counters.malformed;
          return;
        }
        prompts.push_back(content->text);
        while (prompts.size() > kMaxPrompts) prompts.pop_front();
        ++counters.prompts;
      } else {
        ++counters.other_messages;
      }
    } catch (const std::exception& e) {
      std::lock_guard lock(mutex);
      ++counters.malformed;
      logger()->warn("HMD emulator: cannot display {} '{}': {}", m.header.type, m.header.device_name, e.what());
    }
  }

  // Called with `mutex` held.
  void onPolyData(const igtlink::Message& m, const std::string& device) {
    const auto* content = m.as<igtlink::PolyDataContent>();
    if (content == nullptr || device.empty()) {
      ++counters.malformed;
      return;
    }
    TriangleMesh mesh = igtlink::meshFromPolyData(*content);  // FormatError -> malformed
    if (mesh.empty()) {
      ++counters.malformed;
      return;
    }
    if (options.unity) mesh = tracking::meshFromUnity(mesh);
    mesh.name = device;
    if (const auto units = m.metadataValue("Units"); units && *units != (options.unity ? "m" : "mm")) {
      ++counters.convention_mismatches;
      logger()->warn("HMD emulator: model '{}' arrives in '{}' but the emulator expects '{}' (check the unity option)",
                     device, *units, options.unity ? "m" : "mm");
    }
    auto& shown = model(device);
    shown.vertices = static_cast<std::size_t>(mesh.vertexCount());
    shown.mesh = std::make_shared<const TriangleMesh>(std::move(mesh));
    ++counters.meshes;
  }
};

HmdEmulator::HmdEmulator(HmdEmulatorOptions options) : impl_(std::make_shared<Impl>()) {
  if (options.host.empty())
    throw InvalidArgumentError("HMD emulator: the host is empty; give the workstation's address");
  if (options.port == 0) throw InvalidArgumentError("HMD emulator: port 0; give the hologram stream's port");
  auto check = [](double v, const char* what) {
    if (!std::isfinite(v) || v < 0.0) {
      throw InvalidArgumentError(std::string("HMD emulator: ") + what + " must be a finite number >= 0");
    }
  };
  check(options.drift_mm_per_min, "drift_mm_per_min");
  check(options.jitter_mm, "jitter_mm");
  check(options.reconnect_max_s, "reconnect_max_s");
  impl_->options = std::move(options);
  const Eigen::Vector3d g = gaussian3(mix(impl_->options.seed ^ 0xbb67ae8584caa73bULL));
  if (g.norm() > 1e-12) impl_->drift_direction = g.normalized();
}

HmdEmulator::~HmdEmulator() {
  stop();
}

void HmdEmulator::start() {
  std::lock_guard lifecycle(impl_->lifecycle_mutex);
  if (impl_->client) return;
  if (!impl_->clock_started) {
    impl_->origin = std::chrono::steady_clock::now();
    impl_->clock_started = true;
    std::lock_guard lock(impl_->mutex);
    impl_->clock_origin = impl_->origin;
  }
  igtlink::ClientOptions client_options;
  client_options.host = impl_->options.host;
  client_options.port = impl_->options.port;
  client_options.reconnect = true;
  client_options.backoff_initial_s = std::min(0.05, impl_->options.reconnect_max_s);
  client_options.backoff_max_s = impl_->options.reconnect_max_s;
  auto client = std::make_unique<igtlink::Client>(client_options);
  Impl* impl = impl_.get();  // the client is stopped before the Impl goes away
  client->onMessage([impl](const igtlink::Message& m) { impl->onMessage(m); });
  client->onConnectionChange([impl](bool connected) { impl->onConnection(connected); });
  client->start();  // NetworkError for an unresolvable host
  impl_->client = std::move(client);
}

void HmdEmulator::stop() {
  std::lock_guard lifecycle(impl_->lifecycle_mutex);
  if (!impl_->client) return;
  impl_->client->stop();
  impl_->client_malformed_before += impl_->client->stats().malformed_messages;
  impl_->client.reset();
  std::lock_guard lock(impl_->mutex);
  impl_->counters.connected = false;
  impl_->hideAll("Disconnected");
}

std::vector<DisplayedModel> HmdEmulator::displayed() const {
  std::lock_guard lock(impl_->mutex);
  std::vector<DisplayedModel> out;
  out.reserve(impl_->models.size());
  for (const auto& [name, model] : impl_->models) out.push_back(model);
  return out;
}

std::vector<std::string> HmdEmulator::prompts() const {
  std::lock_guard lock(impl_->mutex);
  return {impl_->prompts.begin(), impl_->prompts.end()};
}

std::vector<std::string> HmdEmulator::promptsSince(std::uint64_t& seen) const {
  std::lock_guard lock(impl_->mutex);
  const std::uint64_t total = impl_->counters.prompts;
  const auto fresh =
      static_cast<std::size_t>(std::min<std::uint64_t>(total - std::min(seen, total), impl_->prompts.size()));
  seen = total;
  return {impl_->prompts.end() - static_cast<std::ptrdiff_t>(fresh), impl_->prompts.end()};
}

bool HmdEmulator::confirm(const std::string& what) {
  if (what.empty() || what.size() > 65535) {
    throw InvalidArgumentError("HMD emulator: a confirmation must be 1 to 65535 bytes (e.g. \"cube-aligned\")");
  }
  igtlink::StringContent text;
  text.encoding = igtlink::kEncodingUsAscii;
  for (const char c : what) {
    if (static_cast<unsigned char>(c) >= 0x80) text.encoding = igtlink::kEncodingUtf8;
  }
  text.text = what;
  auto message = igtlink::makeMessage("Confirm", std::move(text), unixTimeSeconds());
  igtlink::HeaderVersion version = igtlink::HeaderVersion::kV1;
  {
    std::lock_guard lock(impl_->mutex);
    version = impl_->stream_version;
  }
  message.header.version = static_cast<std::uint16_t>(version);
  std::lock_guard lifecycle(impl_->lifecycle_mutex);
  if (!impl_->client || !impl_->client->send(message, version)) return false;
  std::lock_guard lock(impl_->mutex);
  ++impl_->counters.confirmations;
  return true;
}

bool HmdEmulator::sendImage(int width, int height, const std::vector<std::uint8_t>& pixels,
                            const std::string& intrinsics) {
  if (width <= 0 || height <= 0 || width > 65535 || height > 65535 ||
      pixels.size() != static_cast<std::size_t>(width) * static_cast<std::size_t>(height)) {
    throw InvalidArgumentError("HMD emulator: a photo needs 1-65535 pixels a side and width x height grey pixels");
  }
  igtlink::ImageContent image;
  image.components = 1;
  image.scalar_type = igtlink::ScalarType::kUint8;
  image.resizeWhole({static_cast<std::uint16_t>(width), static_cast<std::uint16_t>(height), 1});
  image.pixels = pixels;
  auto message = igtlink::makeMessage("HmdCamera", std::move(image), unixTimeSeconds());
  igtlink::HeaderVersion version = igtlink::HeaderVersion::kV1;
  {
    std::lock_guard lock(impl_->mutex);
    version = impl_->stream_version;
  }
  message.header.version = static_cast<std::uint16_t>(version);
  if (version == igtlink::HeaderVersion::kV2 && !intrinsics.empty()) {
    message.metadata.push_back({"CameraIntrinsics", igtlink::kEncodingUsAscii, intrinsics});
  }
  std::lock_guard lifecycle(impl_->lifecycle_mutex);
  if (!impl_->client || !impl_->client->send(message, version)) return false;
  std::lock_guard lock(impl_->mutex);
  ++impl_->counters.images_sent;
  return true;
}

HmdEmulatorStats HmdEmulator::stats() const {
  std::uint64_t client_malformed = 0;
  {
    std::lock_guard lifecycle(impl_->lifecycle_mutex);
    client_malformed = impl_->client_malformed_before;
    if (impl_->client) client_malformed += impl_->client->stats().malformed_messages;
  }
  std::lock_guard lock(impl_->mutex);
  HmdEmulatorStats s = impl_->counters;
  s.malformed += client_malformed;
  return s;
}

Eigen::Isometry3d HmdEmulator::headsetWorldTHologram(double t_s) const {
  return impl_->worldTHologram(t_s);
}

}  // namespace mrsns::simulation
