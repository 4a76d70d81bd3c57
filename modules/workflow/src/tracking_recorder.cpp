#include "tracking_recorder.h"

#include <algorithm>
#include <exception>

#include "mrsns/core/log.h"
#include "mrsns/io/sequence_appender.h"

namespace mrsns::workflow::detail {

TrackingRecorder::TrackingRecorder(const std::filesystem::path& path, double sync_interval_s, std::size_t max_queued)
    : appender_(std::make_unique<io::SequenceAppender>(path, io::SequenceAppender::trackerOnlyLayout(),
                                                       io::SequenceAppenderOptions{sync_interval_s})),
      max_queued_(std::max<std::size_t>(max_queued, 1)) {
  writer_ = std::make_unique<QueuedWriter<TrackedFrame>>(
      max_queued_, WhenFull::DropNewest, [this](TrackedFrame& f) { write(f); }, [this] { finish(); });
}

TrackingRecorder::~TrackingRecorder() {
  stop();
}

void TrackingRecorder::push(TrackedFrame frame) noexcept {
  try {
    // The newest is dropped, not the oldest: the file keeps a contiguous record up to the stall.
    if (writer_->push(std::move(frame)) == Pushed::Dropped) {
      std::lock_guard lock(mutex_);
      ++stats_.dropped;
      if (stats_.error.empty()) {
        stats_.error = "the disk has not taken a tracking frame for " + std::to_string(max_queued_) +
                       " frames: later frames are not recorded";
        logger()->warn("navigation recording: {}", stats_.error);
      }
    }
  } catch (const std::exception& e) {  // out of memory for the queue: count it, carry on
    std::lock_guard lock(mutex_);
    ++stats_.dropped;
    if (stats_.error.empty()) stats_.error = std::string("tracking frame not queued: ") + e.what();
  }
}

void TrackingRecorder::stop() noexcept {
  writer_->stop();
}

TrackingRecorderStats TrackingRecorder::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

void TrackingRecorder::write(TrackedFrame& frame) {
  const bool ok = appender_->append(frame);
  std::lock_guard lock(mutex_);
  if (ok) {
    ++stats_.recorded;
  } else {
    ++stats_.dropped;
    if (stats_.error.empty()) stats_.error = appender_->lastError();
  }
  stats_.synced = appender_->framesSynced();
}

void TrackingRecorder::finish() {
  const bool ok = appender_->sync();
  std::lock_guard lock(mutex_);
  if (!ok && stats_.error.empty()) stats_.error = appender_->lastError();
  stats_.synced = appender_->framesSynced();
}

}  // namespace mrsns::workflow::detail
