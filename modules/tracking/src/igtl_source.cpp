#include "mrsns/tracking/igtl_source.h"

#include <cmath>
#include <limits>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/wall_clock.h"

namespace mrsns::tracking {
namespace {

double messageTime(const igtlink::Message& message) {
  return message.header.timestamp == 0 ? unixTimeSeconds() : message.header.timestampSeconds();
}

// PLUS (v2) writes the tool status as metadata; v1 peers cannot, and a
// broken matrix is the only sign then.
TransformStatus statusOf(const igtlink::Message& message, const Eigen::Matrix4d& matrix) {
  if (const auto status = message.metadataValue("TransformStatus"); status && *status != "OK") {
    return TransformStatus::Invalid;
  }
  if (const auto valid = message.metadataValue("TransformValid"); valid && (*valid == "false" || *valid == "0")) {
    return TransformStatus::Invalid;
  }
  if (!matrix.allFinite() || !isRigid(matrix, 1e-3)) return TransformStatus::Invalid;
  return TransformStatus::Ok;
}

std::string transformName(const std::string& name, const std::string& reference) {
  try {
    (void)TransformName::parse(name);
    return name;
  } catch (const Error&) {
    return name + "To" + reference;
  }
}

PixelType pixelTypeOf(igtlink::ScalarType type) {
  switch (type) {
    case igtlink::ScalarType::kInt8: return PixelType::Int8;
    case igtlink::ScalarType::kUint8: return PixelType::UInt8;
    case igtlink::ScalarType::kInt16: return PixelType::Int16;
    case igtlink::ScalarType::kUint16: return PixelType::UInt16;
    case igtlink::ScalarType::kInt32: return PixelType::Int32;
    case igtlink::ScalarType::kUint32: return PixelType::UInt32;
    case igtlink::ScalarType::kFloat32: return PixelType::Float32;
    case igtlink::ScalarType::kFloat64: return PixelType::Float64;
  }
  return PixelType::UInt8;
}

TrackedImage imageFrom(const igtlink::Message& message, const igtlink::ImageContent& content) {
  TrackedImage image;
  image.name = message.header.device_name;
  const auto underscore = image.name.rfind('_');
  image.frame = underscore == std::string::npos ? image.name : image.name.substr(underscore + 1);
  image.timestamp = messageTime(message);
  Eigen::Matrix4d m = content.ijk_to_xyz;
  // Centre of the volume -> voxel (0,0,0): the wire holds the centre.
  Eigen::Vector3d half;
  for (int a = 0; a < 3; ++a) half[a] = (static_cast<double>(content.size[a]) - 1.0) / 2.0;
  m.block<3, 1>(0, 3) -= m.block<3, 3>(0, 0) * half;
  image.ijk_to_frame = m;
  image.geometry.dimensions = content.size[2] > 1 ? 3 : 2;
  for (int a = 0; a < 3; ++a) {
    image.geometry.size[a] = content.subvolume_size[a];
    image.geometry.spacing[a] = content.spacing()[a];
    image.geometry.origin[a] = m(a, 3);
  }
  image.geometry.direction = content.direction();
  image.format.scalar = pixelTypeOf(content.scalar_type);
  image.format.components = content.components;
  image.pixels = content.littleEndianPixels();
  return image;
}

}  // namespace

IgtlTrackingSource::IgtlTrackingSource(std::shared_ptr<TransformRepository> repository, IgtlSourceOptions options)
    : TrackingSource(std::move(repository)), options_(std::move(options)) {
  if (!(options_.stale_after_s >= 0.0)) {
    throw InvalidArgumentError("OpenIGTLink source: stale_after_s must be >= 0 (0 disables stale detection)");
  }
}

IgtlTrackingSource::~IgtlTrackingSource() {
  stop();
}

std::string IgtlTrackingSource::name() const {
  return "igtl:" + options_.client.host + ":" + std::to_string(options_.client.port);
}

std::vector<std::string> IgtlTrackingSource::toolNames() const {
  std::lock_guard lock(mutex_);
  std::vector<std::string> names;
  for (const auto& entry : tools_) names.push_back(entry.first);
  return names;
}

std::optional<TrackedImage> IgtlTrackingSource::latestImage() const {
  std::lock_guard lock(mutex_);
  return image_;
}

std::string IgtlTrackingSource::deviceIdentity() const {
  std::lock_guard lock(mutex_);
  return device_identity_;
}

IgtlSourceStats IgtlTrackingSource::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

bool IgtlTrackingSource::connected() const {
  return client_ && client_->connected();
}

void IgtlTrackingSource::start() {
  if (client_) return;
  client_ = std::make_unique<igtlink::Client>(options_.client);
  client_->onMessage([this](const igtlink::Message& m) { handleMessage(m); });
  client_->onConnectionChange([this](bool c) { onConnection(c); });
  setState(SourceState::Connecting,
           "connecting to " + options_.client.host + ":" + std::to_string(options_.client.port));
  try {
    client_->start();
  } catch (...) {
    client_.reset();
    setState(SourceState::Error, "cannot resolve " + options_.client.host);
    throw;
  }
  {
    std::lock_guard lock(watchdog_mutex_);
    running_ = true;
  }
  if (options_.stale_after_s > 0.0) watchdog_ = std::thread([this] { watchdog(); });
}

void IgtlTrackingSource::stop() {
  {
    std::lock_guard lock(watchdog_mutex_);
    running_ = false;
  }
  watchdog_wake_.notify_all();
  if (watchdog_.joinable()) watchdog_.join();
  if (client_) {
    client_->stop();
    client_.reset();
  }
  setState(SourceState::Stopped);
}

void IgtlTrackingSource::publishLocked(std::vector<ToolUpdate>& updates) {
  const auto now = Clock::now();
  for (const auto& u : updates) {
    auto& tool = tools_[u.name];
    tool.last_update = now;
    tool.valid = u.status == TransformStatus::Ok;
    if (!tool.valid) ++stats_.invalid_reports;
  }
  publish(updates);
}

void IgtlTrackingSource::handleMessage(const igtlink::Message& message) noexcept {
  try {
    std::vector<ToolUpdate> updates;
    std::lock_guard lock(mutex_);
    if (const auto* transform = message.as<igtlink::TransformContent>()) {
      ++stats_.transforms;
      ToolUpdate u;
      u.name = transformName(message.header.device_name, options_.tdata_reference);
      u.status = statusOf(message, transform->matrix);
      u.to_T_from = u.status == TransformStatus::Ok
                        ? Eigen::Isometry3d(transform->matrix)
                        : Eigen::Isometry3d(Eigen::Matrix4d::Constant(std::numeric_limits<double>::quiet_NaN()));
      u.timestamp = messageTime(message);
      updates.push_back(std::move(u));
    } else if (const auto* tdata = message.as<igtlink::TrackingDataContent>()) {
      ++stats_.tdata_messages;
      const double t = messageTime(message);
      for (const auto& element : tdata->elements) {
        ToolUpdate u;
        u.name = transformName(element.name, options_.tdata_reference);
        u.status = statusOf(message, element.matrix);
        u.to_T_from = u.status == TransformStatus::Ok
                          ? Eigen::Isometry3d(element.matrix)
                          : Eigen::Isometry3d(Eigen::Matrix4d::Constant(std::numeric_limits<double>::quiet_NaN()));
        u.timestamp = t;
        updates.push_back(std::move(u));
      }
    } else if (const auto* status = message.as<igtlink::StatusContent>()) {
      // A device's own description of itself; bounded, as it is shown to the user.
      device_identity_ = status->message.substr(0, 200);
      return;
    } else if (const auto* image = message.as<igtlink::ImageContent>()) {
      ++stats_.images;
      image_ = imageFrom(message, *image);
      publishImage(*image_);
      return;
    } else {
      ++stats_.ignored_messages;
      return;
    }
    publishLocked(updates);
    setState(SourceState::Running);
  } catch (const std::exception& e) {
    logger()->warn("OpenIGTLink source: message '{}' from '{}' ignored: {}", message.header.type,
                   message.header.device_name, e.what());
  }
}

void IgtlTrackingSource::markAll(TransformStatus status, const std::vector<std::string>& names) noexcept {
  try {
    if (names.empty()) return;
    std::vector<ToolUpdate> updates;
    const double t = unixTimeSeconds();
    for (const auto& name : names) {
      ToolUpdate u;
      u.name = name;
      u.status = status;
      u.to_T_from = Eigen::Isometry3d(Eigen::Matrix4d::Constant(std::numeric_limits<double>::quiet_NaN()));
      u.timestamp = t;
      updates.push_back(std::move(u));
    }
    for (const auto& name : names) tools_[name].valid = false;
    publish(updates);
  } catch (const std::exception& e) {
    logger()->error("OpenIGTLink source: cannot mark tools {}: {}", toString(status), e.what());
  }
}

void IgtlTrackingSource::onConnection(bool is_connected) noexcept {
  if (is_connected) {
    setState(SourceState::Running);
    logger()->info("OpenIGTLink source: connected to {}:{}", options_.client.host, options_.client.port);
    if (options_.identify_device && client_) {
      try {
        client_->send(igtlink::makeMessage("GET_STATUS", "", igtlink::GetRequest{}), options_.request_version);
      } catch (const std::exception& e) {
        logger()->error("OpenIGTLink source: cannot send GET_STATUS: {}", e.what());
      }
    }
    if (options_.request_tdata && client_) {
      igtlink::StartTrackingDataContent request;
      request.resolution_ms = options_.tdata_resolution_ms;
      request.coordinate_name = options_.tdata_reference;
      try {
        client_->send(igtlink::makeMessage("STT_TDATA", "", request), options_.request_version);
      } catch (const std::exception& e) {
        logger()->error("OpenIGTLink source: cannot send STT_TDATA: {}", e.what());
      }
    }
    return;
  }
  setState(SourceState::Connecting, "connection to " + options_.client.host + " lost; reconnecting");
  std::lock_guard lock(mutex_);
  std::vector<std::string> names;
  for (const auto& [name, tool] : tools_) {
    if (tool.valid) names.push_back(name);
  }
  markAll(TransformStatus::Invalid, names);
}

void IgtlTrackingSource::watchdog() {
  const auto stale = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(options_.stale_after_s));
  const auto period = stale / 4;
  std::unique_lock wlock(watchdog_mutex_);
  while (running_) {
    watchdog_wake_.wait_for(wlock, period, [this] { return !running_; });
    if (!running_) break;
    std::lock_guard lock(mutex_);
    const auto now = Clock::now();
    std::vector<std::string> names;
    for (const auto& [name, tool] : tools_) {
      if (tool.valid && now - tool.last_update > stale) names.push_back(name);
    }
    if (!names.empty()) {
      stats_.stale_events += names.size();
      logger()->warn("OpenIGTLink source: no update for {} s from {} tool(s) ({}...): marked invalid",
                     options_.stale_after_s, names.size(), names.front());
      markAll(TransformStatus::Invalid, names);
    }
  }
}

}  // namespace mrsns::tracking
