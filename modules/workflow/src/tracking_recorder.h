#pragma once
// The tracking stream of a navigation run, recorded crash-safe (a PLUS
// tracker buffer) on this recorder's own thread. The navigation loop feeds
// the robot's safety supervisor: it must never wait for the disk, whose
// fsync can take a second on a loaded machine, or the supervisor would see
// stale poses and stop the arm for a reason that is not the patient's.
// Unlike the video, tracking frames are small and none may be lost: the
// queue holds minutes of them, and only a disk that stays stalled that long
// makes it drop (counted, with the reason).
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>

#include "mrsns/core/tracked_frame.h"
#include "queued_writer.h"

namespace mrsns::io {
class SequenceAppender;
}

namespace mrsns::workflow::detail {

struct TrackingRecorderStats {
  std::uint64_t recorded = 0;  ///< frames written
  std::uint64_t synced = 0;    ///< frames durable on disk
  std::uint64_t dropped = 0;   ///< frames not recorded (queue full or a write failed)
  std::string error;           ///< the first problem, when there was one
};

class TrackingRecorder {
 public:
  /// Creates the recording now (throws as io::SequenceAppender: an existing
  /// file, an unwritable folder), so a run never starts without it.
  /// `max_queued`: 36000 frames is ten minutes at 60 Hz.
  TrackingRecorder(const std::filesystem::path& path, double sync_interval_s, std::size_t max_queued = 36000);
  ~TrackingRecorder();
  TrackingRecorder(const TrackingRecorder&) = delete;
  TrackingRecorder& operator=(const TrackingRecorder&) = delete;

  /// Queues a frame. Any thread; never blocks on the disk, never throws.
  void push(TrackedFrame frame) noexcept;
  /// Writes everything queued, syncs and ends the thread. Idempotent.
  void stop() noexcept;
  [[nodiscard]] TrackingRecorderStats stats() const;

 private:
  void write(TrackedFrame& frame);
  void finish();

  std::unique_ptr<io::SequenceAppender> appender_;  // the writer thread's alone once it runs
  std::size_t max_queued_;
  mutable std::mutex mutex_;  // guards stats_
  TrackingRecorderStats stats_;
  std::unique_ptr<QueuedWriter<TrackedFrame>> writer_;  // last: its thread uses the members above
};

}  // namespace mrsns::workflow::detail
