#pragma once
// The ultrasound video of a navigation run (the images a PlusServer sends,
// or a playback with images), recorded crash-safe beside the tracking
// stream. Frames arrive on the tracking source's thread and are written on
// this recorder's own thread, so neither the source nor the loop that feeds
// the robot's supervisor ever waits for the disk. A full queue drops its
// oldest frame (counted) rather than block a real-time caller.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>

#include "mrsns/core/tracked_frame.h"
#include "mrsns/tracking/tracking_source.h"
#include "queued_writer.h"

namespace mrsns::io {
class SequenceAppender;
}

namespace mrsns::workflow::detail {

struct VideoRecorderStats {
  std::uint64_t recorded = 0;  ///< frames written
  std::uint64_t synced = 0;    ///< frames durable on disk
  std::uint64_t dropped = 0;   ///< frames not recorded (queue full, or a size other than the first frame's)
  std::string error;           ///< the first problem, when there was one
};

class VideoRecorder {
 public:
  /// The file (.mhd + .raw) is created with the first frame, whose geometry
  /// and pixel format every later frame must have.
  VideoRecorder(std::filesystem::path path, double sync_interval_s, std::size_t max_queued = 32);
  ~VideoRecorder();
  VideoRecorder(const VideoRecorder&) = delete;
  VideoRecorder& operator=(const VideoRecorder&) = delete;

  /// Queues a frame. Any thread; never blocks long, never throws.
  void push(const tracking::TrackedImage& image) noexcept;
  /// Writes what is queued, syncs and ends the thread. Idempotent.
  void stop() noexcept;
  [[nodiscard]] VideoRecorderStats stats() const;
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }

 private:
  void write(const tracking::TrackedImage& image);
  void finish();

  std::filesystem::path path_;
  double sync_interval_s_;
  std::unique_ptr<io::SequenceAppender> appender_;  // the writer thread's alone, as layout_
  TrackedSequence layout_;
  mutable std::mutex mutex_;  // guards stats_
  VideoRecorderStats stats_;
  std::unique_ptr<QueuedWriter<tracking::TrackedImage>> writer_;  // last: its thread uses the members above
};

}  // namespace mrsns::workflow::detail
