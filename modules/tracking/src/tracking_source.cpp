#include "mrsns/tracking/tracking_source.h"

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/core/rigid.h"

namespace mrsns::tracking {
namespace {

// Trackers and PLUS files print rotations with 6-7 digits, so their matrices
// miss the repository's 1e-6 orthonormality test by rounding alone; anything
// further off than this is a broken matrix, not a rounded one.
constexpr double kRoundingTolerance = 1e-3;

bool hasEdge(const TransformRepository& repository, const std::string& from, const std::string& to) {
  for (const auto& edge : repository.edges()) {
    if ((edge.from == from && edge.to == to) || (edge.from == to && edge.to == from)) return true;
  }
  return false;
}

}  // namespace

std::string_view toString(SourceState state) {
  switch (state) {
    case SourceState::Stopped: return "stopped";
    case SourceState::Connecting: return "connecting";
    case SourceState::Running: return "running";
    case SourceState::Paused: return "paused";
    case SourceState::Finished: return "finished";
    case SourceState::Error: return "error";
  }
  return "error";
}

TrackingSource::TrackingSource(std::shared_ptr<TransformRepository> repository) : repository_(std::move(repository)) {
  if (!repository_) throw InvalidArgumentError("tracking source: the transform repository is null; pass one");
}

TrackingSource::~TrackingSource() = default;

SourceStatus TrackingSource::status() const {
  std::lock_guard lock(status_mutex_);
  return status_;
}

void TrackingSource::setUpdateCallback(UpdateCallback callback) {
  callback_ = std::move(callback);
}

void TrackingSource::setImageCallback(ImageCallback callback) {
  image_callback_ = std::move(callback);
}

void TrackingSource::publishImage(const TrackedImage& image) noexcept {
  if (!image_callback_) return;
  try {
    image_callback_(image);
  } catch (const std::exception& e) {
    logger()->error("tracking: image callback threw: {}", e.what());
  }
}

void TrackingSource::setState(SourceState state, std::string message) noexcept {
  try {
    std::lock_guard lock(status_mutex_);
    status_.state = state;
    status_.message = std::move(message);
  } catch (...) {  // NOLINT: a status must never take the real-time loop down
  }
}

void TrackingSource::publish(std::span<const ToolUpdate> updates) noexcept {
  std::uint64_t rejected = 0;
  for (const auto& u : updates) {
    try {
      const Eigen::Matrix4d& m = u.to_T_from.matrix();
      if (u.status != TransformStatus::Ok) {
        // A lost tool often comes with a NaN, zero or stale matrix: keep the
        // last good pose and mark it, as PLUS does.
        const auto name = TransformName::parse(u.name);
        if (hasEdge(*repository_, name.from, name.to)) {
          repository_->setStatus(name.from, name.to, u.status, u.timestamp);
        } else {
          const bool usable = m.allFinite() && isRigid(m, kRoundingTolerance);
          repository_->setTransform(u.name, usable ? orthonormalize(m) : Eigen::Isometry3d::Identity(), u.status,
                                    u.timestamp);
        }
      } else if (isRigid(m, kRoundingTolerance)) {
        // Stored as given when the repository accepts it (orthonormal within
        // its 1e-6), else as the nearest rigid transform.
        bool stored = false;
        if (isRigid(m, 1e-6)) {
          try {
            repository_->setTransform(u.name, u.to_T_from, u.status, u.timestamp);
            stored = true;
          } catch (const InvalidArgumentError&) {  // determinant just outside 1 +- 1e-6
          }
        }
        if (!stored) repository_->setTransform(u.name, orthonormalize(m), u.status, u.timestamp);
      } else {
        ++rejected;
        const auto name = TransformName::parse(u.name);
        if (hasEdge(*repository_, name.from, name.to)) {
          repository_->setStatus(name.from, name.to, TransformStatus::Invalid, u.timestamp);
        }
      }
    } catch (const std::exception& e) {
      ++rejected;
      logger()->debug("tracking: transform '{}' not stored: {}", u.name, e.what());
    }
  }
  {
    std::lock_guard lock(status_mutex_);
    ++status_.updates;
    status_.rejected += rejected;
  }
  if (callback_) {
    try {
      callback_(updates);
    } catch (const std::exception& e) {
      logger()->error("tracking: update callback threw: {}", e.what());
    }
  }
}

}  // namespace mrsns::tracking
