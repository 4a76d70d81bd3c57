#include "mrsns/tracking/hologram_streamer.h"

#include <cmath>
#include <optional>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/core/wall_clock.h"
#include "mrsns/igtlink/codec.h"
#include "mrsns/igtlink/image.h"
#include "mrsns/igtlink/ndarray.h"
#include "mrsns/igtlink/polydata_mesh.h"
#include "mrsns/tracking/unity_convention.h"

namespace mrsns::tracking {
namespace {

using Bytes = std::shared_ptr<const std::vector<std::uint8_t>>;

// The 32.32 header timestamp holds [0, 2^32) seconds.
bool usableTimestamp(double t) {
  return std::isfinite(t) && t >= 0.0 && t < 4294967295.0;
}

}  // namespace

HologramStreamer::HologramStreamer(igtlink::Server& server, std::shared_ptr<TransformRepository> repository,
                                   std::vector<HologramModel> models, HologramStreamOptions options)
    : server_(server), repository_(std::move(repository)), options_(std::move(options)) {
  if (!repository_) throw InvalidArgumentError("hologram stream: the transform repository is null");
  if (options_.hologram_frame.empty()) throw InvalidArgumentError("hologram stream: the hologram frame name is empty");
  std::set<std::string> names;
  auto checkName = [&names](const std::string& name, const char* what) {
    if (name.empty() || name.size() > igtlink::kDeviceNameSize) {
      throw InvalidArgumentError(std::string("hologram stream: ") + what + " name '" + name +
                                 "' must be 1 to 20 characters (an OpenIGTLink device name); rename it");
    }
    if (!names.insert(name).second) {
      throw InvalidArgumentError(std::string("hologram stream: ") + what + " name '" + name +
                                 "' is used twice; device names must be unique");
    }
  };
  for (const auto& model : models) {
    checkName(model.name, "model");
    if (model.mesh.empty()) {
      throw InvalidArgumentError("hologram stream: model '" + model.name + "' has no triangles; give a mesh");
    }
    if (model.frame.empty()) throw InvalidArgumentError("hologram stream: model '" + model.name + "' has no frame");
    Stream stream;
    stream.device = model.name;
    stream.query = repository_->prepare(model.frame, options_.hologram_frame);
    model_vertices_[model.name] = model.mesh.vertexCount();
    streams_.push_back(std::move(stream));
    if (options_.transforms_only) continue;  // the client has its models; none is encoded
    const TriangleMesh mesh = options_.unity ? meshToUnity(model.mesh) : model.mesh;
    auto message = igtlink::makeMessage(model.name, igtlink::polyDataFromMesh(mesh));
    if (options_.version == igtlink::HeaderVersion::kV2) {
      message.header.version = 2;
      message.metadata.push_back({"Frame", igtlink::kEncodingUsAscii, model.frame});
      message.metadata.push_back({"Units", igtlink::kEncodingUsAscii, options_.unity ? "m" : "mm"});
      message.metadata.push_back(
          {"Convention", igtlink::kEncodingUsAscii, options_.unity ? "Unity left-handed" : "right-handed"});
    }
    mesh_bytes_.push_back(
        std::make_shared<const std::vector<std::uint8_t>>(igtlink::encodeMessage(message, options_.version)));
  }
  for (const auto& name : options_.forward_transforms) {
    checkName(name, "forwarded transform");
    const auto frames = TransformName::parse(name);
    Stream stream;
    stream.device = name;
    stream.query = repository_->prepare(frames.from, frames.to);
    streams_.push_back(std::move(stream));
  }
  if (options_.max_streams > 0 && streams_.size() > options_.max_streams) {
    throw InvalidArgumentError("hologram stream: " + std::to_string(streams_.size()) +
                               " models and transforms to stream, but this client moves " +
                               std::to_string(options_.max_streams) +
                               " object(s) with whatever TRANSFORM it receives; stream only that many models");
  }
  server_.onConnect([this](igtlink::ClientId c) { onConnect(c); });
  server_.onDisconnect([this](igtlink::ClientId c) { onDisconnect(c); });
  server_.onMessage([this](igtlink::ClientId c, const igtlink::Message& m) { onClientMessage(c, m); });
  igtlink::InboundLimits limits;
  limits.max_body_size = [photos = static_cast<bool>(options_.on_camera_image)](const igtlink::Header& header) {
    return photos && header.type == "IMAGE" && header.device_name == kCameraImageDevice ? kMaxCameraImageBodyBytes
                                                                                        : kMaxClientMessageBodyBytes;
  };
  limits.max_messages_per_s = kMaxClientMessagesPerSecond;
  server_.limitInbound(std::move(limits));
}

HologramStreamer::~HologramStreamer() = default;

HologramStreamStats HologramStreamer::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

std::size_t HologramStreamer::readyClients() const {
  std::lock_guard lock(mutex_);
  return ready_.size();
}

Bytes HologramStreamer::statusBytes(const Stream& stream, double timestamp) const {
  igtlink::StatusContent status;
  if (stream.ok) {
    status.code = static_cast<std::uint16_t>(igtlink::StatusCode::kOk);
    status.error_name = "TrackingOk";
    status.message = stream.device + ": tracking ok";
  } else {
    status.code = static_cast<std::uint16_t>(igtlink::StatusCode::kNotReady);
    status.error_name = "TrackingLost";
    status.message = stream.device + ": tracking lost (a tool of its chain is invalid or missing)";
  }
  const auto message = igtlink::makeMessage(stream.device, status, usableTimestamp(timestamp) ? timestamp : 0.0);
  return std::make_shared<const std::vector<std::uint8_t>>(igtlink::encodeMessage(message, options_.version));
}

void HologramStreamer::sendToReady(const Bytes& bytes, igtlink::Channel channel) {
  for (const auto client : ready_) server_.sendEncoded(client, bytes, channel);
}

void HologramStreamer::update(double fallback_timestamp) noexcept {
  try {
    std::lock_guard lock(mutex_);
    ++stats_.updates;
    for (auto& stream : streams_) {
      const TransformResult result = repository_->evaluate(stream.query);
      const bool ok = result.ok();
      const double t = usableTimestamp(result.timestamp)
                           ? result.timestamp
                           : (usableTimestamp(fallback_timestamp) ? fallback_timestamp : 0.0);
      if ((stream.announced && ok != stream.ok) || (!stream.announced && !ok)) {
        stream.ok = ok;
        if (!options_.transforms_only) {
          sendToReady(statusBytes(stream, t), igtlink::Channel::Reliable);
          stats_.statuses_queued += ready_.size();
        }
        if (!ok) logger()->warn("hologram stream: tracking of '{}' lost", stream.device);
      }
      stream.ok = ok;
      stream.announced = true;
      if (!ok) {
        stream.last_sent = std::numeric_limits<double>::quiet_NaN();
        continue;
      }
      if (std::isfinite(result.timestamp) && result.timestamp == stream.last_sent) continue;
      stream.last_sent = result.timestamp;
      const Eigen::Matrix4d m =
          options_.unity ? transformToUnity(result.to_T_from.matrix()) : Eigen::Matrix4d(result.to_T_from.matrix());
      const auto message = igtlink::makeMessage(stream.device, igtlink::TransformContent{m}, t);
      const auto bytes =
          std::make_shared<const std::vector<std::uint8_t>>(igtlink::encodeMessage(message, options_.version));
      sendToReady(bytes, igtlink::Channel::Stream);
      stats_.transforms_queued += ready_.size();
    }
  } catch (const std::exception& e) {
    logger()->error("hologram stream: update failed: {}", e.what());
  }
}

void HologramStreamer::updateMeshVertices(const std::string& model,
                                          const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>& vertices) {
  const auto known = model_vertices_.find(model);
  if (known == model_vertices_.end()) {
    throw InvalidArgumentError("hologram stream: no model '" + model + "' to move the vertices of");
  }
  if (vertices.rows() != known->second) {
    throw InvalidArgumentError("hologram stream: model '" + model + "' has " + std::to_string(known->second) +
                               " vertices, not " + std::to_string(vertices.rows()));
  }
  if (vertices.rows() > 65535) {
    throw InvalidArgumentError("hologram stream: model '" + model + "' has " + std::to_string(vertices.rows()) +
                               " vertices, more than an NDARRAY dimension holds (65535): decimate it for the headset");
  }
  if (!vertices.allFinite()) throw InvalidArgumentError("hologram stream: a vertex of '" + model + "' is not finite");
  if (options_.transforms_only) return;
  igtlink::NdArrayFloat32 array;
  array.size = {static_cast<std::uint16_t>(vertices.rows()), 3};
  array.values.resize(static_cast<std::size_t>(vertices.rows()) * 3);
  // Unity clients: left-handed metres, as the meshes (unity_convention.h).
  const double scale = options_.unity ? 1e-3 : 1.0;
  const double flip_x = options_.unity ? -1.0 : 1.0;
  for (Eigen::Index i = 0; i < vertices.rows(); ++i) {
    array.values[static_cast<std::size_t>(3 * i)] = static_cast<float>(flip_x * scale * vertices(i, 0));
    array.values[static_cast<std::size_t>(3 * i + 1)] = static_cast<float>(scale * vertices(i, 1));
    array.values[static_cast<std::size_t>(3 * i + 2)] = static_cast<float>(scale * vertices(i, 2));
  }
  auto message =
      igtlink::makeMessage("NDARRAY", model, igtlink::RawContent{igtlink::encodeNdArray(array)}, unixTimeSeconds());
  if (options_.version == igtlink::HeaderVersion::kV2) {
    message.header.version = 2;
    message.metadata.push_back({"Content", igtlink::kEncodingUsAscii, "MeshVertices"});
    message.metadata.push_back({"Units", igtlink::kEncodingUsAscii, options_.unity ? "m" : "mm"});
  }
  const auto bytes =
      std::make_shared<const std::vector<std::uint8_t>>(igtlink::encodeMessage(message, options_.version));
  std::lock_guard lock(mutex_);
  latest_vertices_[model] = bytes;
  sendToReady(bytes, igtlink::Channel::Reliable);
  stats_.vertex_updates_queued += ready_.size();
}

void HologramStreamer::onConnect(igtlink::ClientId client) noexcept {
  try {
    std::lock_guard lock(mutex_);
    for (const auto& bytes : mesh_bytes_) {
      if (server_.sendEncoded(client, bytes, igtlink::Channel::Reliable)) ++stats_.meshes_queued;
    }
    // The deformed shape now, not the mesh's rest shape.
    for (const auto& [name, bytes] : latest_vertices_) {
      if (server_.sendEncoded(client, bytes, igtlink::Channel::Reliable)) ++stats_.vertex_updates_queued;
    }
    for (const auto& stream : streams_) {
      if (!options_.transforms_only && stream.announced && !stream.ok) {
        server_.sendEncoded(client, statusBytes(stream, 0.0), igtlink::Channel::Reliable);
        ++stats_.statuses_queued;
      }
    }
    if (!options_.transforms_only && !prompt_.empty() &&
        server_.sendEncoded(client, promptBytes(), igtlink::Channel::Reliable)) {
      ++stats_.prompts_queued;
    }
    ready_.insert(client);
    ++stats_.clients_served;
    logger()->info("hologram stream: client {} connected, {} model(s) queued", client, mesh_bytes_.size());
  } catch (const std::exception& e) {
    logger()->error("hologram stream: cannot serve client {}: {}", client, e.what());
  }
}

void HologramStreamer::onDisconnect(igtlink::ClientId client) noexcept {
  try {
    std::lock_guard lock(mutex_);
    ready_.erase(client);
    last_log_.erase(client);
  } catch (...) {  // NOLINT: erase of a present key cannot fail in practice
  }
}

Bytes HologramStreamer::promptBytes() const {
  igtlink::StringContent text;
  text.encoding = igtlink::kEncodingUsAscii;
  for (const char c : prompt_) {
    if (static_cast<unsigned char>(c) >= 0x80) text.encoding = igtlink::kEncodingUtf8;
  }
  text.text = prompt_;
  const auto message = igtlink::makeMessage("Prompt", std::move(text), unixTimeSeconds());
  return std::make_shared<const std::vector<std::uint8_t>>(igtlink::encodeMessage(message, options_.version));
}

void HologramStreamer::setPrompt(const std::string& text) {
  if (text.size() > 65535) throw InvalidArgumentError("hologram stream: a prompt is at most 65535 bytes");
  std::lock_guard lock(mutex_);
  prompt_ = text;
  if (options_.transforms_only) return;  // the client cannot show it
  sendToReady(promptBytes(), igtlink::Channel::Reliable);
  stats_.prompts_queued += ready_.size();
}

namespace {

// A photo the headset may send: one whole 8-bit grey 2D slice of a sensible size; anything else is not one.
std::optional<HeadsetCameraImage> cameraImage(const igtlink::Message& message) {
  const auto* image = message.as<igtlink::ImageContent>();
  if (image == nullptr || image->components != 1 || image->scalar_type != igtlink::ScalarType::kUint8) {
    return std::nullopt;
  }
  const int width = image->size[0], height = image->size[1];
  if (image->size[2] != 1 || width < kMinCameraImageSide || height < kMinCameraImageSide ||
      width > kMaxCameraImageSide || height > kMaxCameraImageSide || image->subvolume_size != image->size ||
      image->subvolume_offset != std::array<std::uint16_t, 3>{0, 0, 0} ||
      image->pixels.size() != static_cast<std::size_t>(width) * static_cast<std::size_t>(height)) {
    return std::nullopt;
  }
  HeadsetCameraImage out;
  out.width = width;
  out.height = height;
  out.pixels = image->pixels;
  out.sent_utc = igtlink::timestampToSeconds(message.header.timestamp);
  if (const auto k = message.metadataValue("CameraIntrinsics"); k && k->size() <= kMaxCameraIntrinsicsBytes) {
    out.intrinsics = *k;
  }
  return out;
}

}  // namespace

void HologramStreamer::onClientMessage(igtlink::ClientId client, const igtlink::Message& message) noexcept {
  try {
    if (options_.on_confirmation && message.header.type == "STRING" && message.header.device_name == "Confirm") {
      const auto* text = message.as<igtlink::StringContent>();
      if (text != nullptr && text->text.size() <= kMaxConfirmationBytes) {
        {
          std::lock_guard lock(mutex_);
          ++stats_.confirmations;
        }
        logger()->info("hologram stream: confirmation '{}' from client {}", text->text, client);
        options_.on_confirmation(client, text->text);
        return;
      }
    }
    if (options_.on_camera_image && message.header.type == "IMAGE" &&
        message.header.device_name == kCameraImageDevice) {
      if (auto image = cameraImage(message)) {
        {
          std::lock_guard lock(mutex_);
          ++stats_.camera_images;
        }
        logger()->debug("hologram stream: camera image {} x {} from client {}", image->width, image->height, client);
        options_.on_camera_image(client, std::move(*image));
        return;
      }
    }
    std::lock_guard lock(mutex_);
    ++stats_.client_messages_ignored;
    const auto now = std::chrono::steady_clock::now();
    auto [it, first] = last_log_.try_emplace(client, now);
    if (first || now - it->second > std::chrono::duration<double>(options_.client_log_interval_s)) {
      it->second = now;
      logger()->warn("hologram stream: ignoring {} '{}' from client {} (the stream is send-only)", message.header.type,
                     message.header.device_name, client);
    }
  } catch (...) {  // NOLINT: logging must not take the I/O thread down
  }
}

}  // namespace mrsns::tracking
