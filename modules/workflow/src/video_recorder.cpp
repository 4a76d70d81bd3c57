#include "video_recorder.h"

#include <exception>

#include "mrsns/core/log.h"
#include "mrsns/io/sequence_appender.h"

namespace mrsns::workflow::detail {

namespace {

bool sameLayout(const TrackedSequence& layout, const tracking::TrackedImage& image) {
  return layout.geometry.size == image.geometry.size && layout.pixel_format.scalar == image.format.scalar &&
         layout.pixel_format.components == image.format.components;
}

std::string sizeText(const std::array<std::int64_t, 3>& s) {
  return std::to_string(s[0]) + "x" + std::to_string(s[1]) + "x" + std::to_string(s[2]);
}

}  // namespace

VideoRecorder::VideoRecorder(std::filesystem::path path, double sync_interval_s, std::size_t max_queued)
    : path_(std::move(path)), sync_interval_s_(sync_interval_s) {
  writer_ = std::make_unique<QueuedWriter<tracking::TrackedImage>>(
      max_queued, WhenFull::DropOldest, [this](tracking::TrackedImage& image) { write(image); },
      [this] { finish(); });
}

VideoRecorder::~VideoRecorder() {
  stop();
}

void VideoRecorder::push(const tracking::TrackedImage& image) noexcept {
  try {
    if (writer_->push(image) == Pushed::Dropped) {
      std::lock_guard lock(mutex_);
      ++stats_.dropped;
      if (stats_.error.empty()) stats_.error = "video frames arrive faster than the disk takes them: oldest dropped";
    }
  } catch (const std::exception& e) {  // out of memory for a copy: count it, carry on
    std::lock_guard lock(mutex_);
    ++stats_.dropped;
    if (stats_.error.empty()) stats_.error = std::string("video frame not queued: ") + e.what();
  }
}

void VideoRecorder::stop() noexcept {
  writer_->stop();
}

VideoRecorderStats VideoRecorder::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

void VideoRecorder::finish() {
  if (!appender_) return;
  appender_->sync();
  std::lock_guard lock(mutex_);
  stats_.synced = appender_->framesSynced();
}

void VideoRecorder::write(const tracking::TrackedImage& image) {
  const auto fail = [this](const std::string& why) {
    std::lock_guard lock(mutex_);
    ++stats_.dropped;
    if (stats_.error.empty()) {
      stats_.error = why;
      logger()->warn("navigation video '{}': {}", path_.string(), why);
    }
  };
  if (!appender_) {
    layout_.geometry = image.geometry;
    layout_.pixel_format = image.format;
    layout_.custom_header_fields = {{"VideoDevice", image.name}};
    try {
      appender_ = std::make_unique<io::SequenceAppender>(path_, layout_, io::SequenceAppenderOptions{sync_interval_s_});
    } catch (const std::exception& e) {
      fail(std::string("cannot record the video: ") + e.what());
      return;
    }
  }
  if (!sameLayout(layout_, image)) {
    fail("a frame of " + sizeText(image.geometry.size) + " pixels after frames of " + sizeText(layout_.geometry.size) +
         " (or another pixel type): such frames are not recorded");
    return;
  }
  TrackedFrame frame;
  frame.timestamp = image.timestamp;
  frame.pixels = image.pixels;
  frame.image_status = "OK";
  // Where the image lies: its pixel-to-frame matrix, as PLUS's ImageTo<Frame> (pixel indices -> mm).
  if (!image.frame.empty() && image.frame != "Image") {
    frame.transforms["ImageTo" + image.frame] = FrameTransform{image.ijk_to_frame, TransformStatus::Ok};
  }
  if (!appender_->append(frame)) {
    fail(appender_->lastError());
    return;
  }
  std::lock_guard lock(mutex_);
  ++stats_.recorded;
  stats_.synced = appender_->framesSynced();
}

}  // namespace mrsns::workflow::detail
