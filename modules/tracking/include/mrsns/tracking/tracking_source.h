#pragma once
// One interface for every tracker: OpenIGTLink (PlusServer), playback of PLUS
// sequence files and the simulator. A source writes each tool's transform,
// status and acquisition timestamp into a TransformRepository and, for the
// streaming path, hands the same batch to an optional callback.
//
// Real-time code never throws: once started, a source reports problems
// through status() and the per-transform statuses (Invalid for a lost or
// stale tool), never by exception. Only construction and start() validate
// their arguments and throw typed mrsns::Error subclasses.
#include <Eigen/Geometry>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "mrsns/core/tracked_frame.h"
#include "mrsns/core/transform_repository.h"
#include "mrsns/core/transform_status.h"

namespace mrsns::tracking {

/// One transform reported by a tracker at one instant.
struct ToolUpdate {
  std::string name;  ///< PLUS style, e.g. "StylusToTracker"
  Eigen::Isometry3d to_T_from = Eigen::Isometry3d::Identity();
  TransformStatus status = TransformStatus::Ok;
  double timestamp = 0.0;  ///< acquisition time, seconds (the source's clock)
};

/// State of a source as a whole.
enum class SourceState {
  Stopped,     ///< not started, or stopped
  Connecting,  ///< waiting for the device (network sources)
  Running,     ///< delivering updates
  Paused,      ///< playback paused
  Finished,    ///< playback reached the end (no looping)
  Error,       ///< cannot deliver; see SourceStatus::message
};

std::string_view toString(SourceState state);

struct SourceStatus {
  SourceState state = SourceState::Stopped;
  std::string message;         ///< what is wrong, when anything is
  std::uint64_t updates = 0;   ///< batches published since start
  std::uint64_t rejected = 0;  ///< transforms the repository refused (e.g. not rigid)
};

/// The latest image of a tracked imaging device (ultrasound), with what is
/// needed to place it: `ijk_to_frame` maps pixel indices (i, j, k) to mm in
/// `frame` (for PLUS's "Image_Reference" device: frame "Reference", so the
/// matrix is ImageToReference times the pixel scaling).
struct TrackedImage {
  std::string name;
  double timestamp = 0.0;
  std::string frame;
  Eigen::Matrix4d ijk_to_frame = Eigen::Matrix4d::Identity();
  ImageFrameGeometry geometry;
  FramePixelFormat format;
  std::vector<std::uint8_t> pixels;  ///< row-major, i fastest, components interleaved
};

/// Called once per published batch (all the tools of one tracker frame), on
/// the source's thread. Must not block for long and must not throw.
using UpdateCallback = std::function<void(std::span<const ToolUpdate>)>;
/// Called once per image the source receives (an ultrasound frame), on the
/// source's thread, so a recorder sees every frame, not just the latest.
/// Must not block for long and must not throw.
using ImageCallback = std::function<void(const TrackedImage&)>;

class TrackingSource {
 public:
  /// Throws InvalidArgumentError for a null repository.
  explicit TrackingSource(std::shared_ptr<TransformRepository> repository);
  virtual ~TrackingSource();
  TrackingSource(const TrackingSource&) = delete;
  TrackingSource& operator=(const TrackingSource&) = delete;

  /// Starts delivering (returns at once; threads are the source's own).
  virtual void start() = 0;
  /// Stops and joins its threads. Idempotent.
  virtual void stop() = 0;
  [[nodiscard]] virtual std::string name() const = 0;
  /// The transform names this source provides ("ProbeToTracker", ...), as far
  /// as known (a network source learns them as they arrive).
  [[nodiscard]] virtual std::vector<std::string> toolNames() const = 0;
  [[nodiscard]] SourceStatus status() const;
  /// The latest image, if the source delivers images and one has arrived.
  [[nodiscard]] virtual std::optional<TrackedImage> latestImage() const { return std::nullopt; }
  /// What the device says it is (a PlusServer's answer to GET_STATUS), empty when it has not said. A device
  /// whose identity starts with "mrsns-sim" is the simulated operating room: its results are simulated.
  [[nodiscard]] virtual std::string deviceIdentity() const { return {}; }

  /// Set before start().
  void setUpdateCallback(UpdateCallback callback);
  /// Set before start(); sources without images never call it.
  void setImageCallback(ImageCallback callback);
  [[nodiscard]] TransformRepository& repository() { return *repository_; }
  [[nodiscard]] std::shared_ptr<TransformRepository> sharedRepository() const { return repository_; }

 protected:
  /// Writes every update into the repository (a transform that is not rigid
  /// is counted as rejected and its edge, if any, marked Invalid), then calls
  /// the callback. Never throws.
  void publish(std::span<const ToolUpdate> updates) noexcept;
  /// Calls the image callback. Never throws.
  void publishImage(const TrackedImage& image) noexcept;
  void setState(SourceState state, std::string message = {}) noexcept;

 private:
  std::shared_ptr<TransformRepository> repository_;
  UpdateCallback callback_;
  ImageCallback image_callback_;
  mutable std::mutex status_mutex_;
  SourceStatus status_;
};

}  // namespace mrsns::tracking
