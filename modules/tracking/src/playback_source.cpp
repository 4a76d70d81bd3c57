#include "mrsns/tracking/playback_source.h"

#include <algorithm>
#include <cmath>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"

namespace mrsns::tracking {

PlaybackTrackingSource::PlaybackTrackingSource(std::shared_ptr<TransformRepository> repository,
                                               const std::filesystem::path& sequence, PlaybackOptions options)
    : TrackingSource(std::move(repository)), path_(sequence), options_(std::move(options)), reader_(sequence) {
  if (!(options_.speed >= 0.0) || !std::isfinite(options_.speed)) {
    throw InvalidArgumentError("playback: speed must be >= 0 (0 = as fast as possible), got " +
                               std::to_string(options_.speed));
  }
  const auto& frames = reader_.header().frames;
  if (frames.empty()) throw InvalidArgumentError("playback: '" + sequence.string() + "' holds no frames");
  const double span = frames.back().timestamp - frames.front().timestamp;
  const double mean_interval = frames.size() > 1 ? span / static_cast<double>(frames.size() - 1) : 1.0;
  loop_period_ = span + mean_interval;
}

PlaybackTrackingSource::~PlaybackTrackingSource() {
  stop();
}

std::string PlaybackTrackingSource::name() const {
  return "playback:" + path_.filename().string();
}

std::vector<std::string> PlaybackTrackingSource::toolNames() const {
  return reader_.header().transformNames();
}

std::optional<TrackedImage> PlaybackTrackingSource::latestImage() const {
  std::lock_guard lock(image_mutex_);
  return image_;
}

std::size_t PlaybackTrackingSource::frameCount() const {
  return reader_.frameCount();
}
const TrackedSequence& PlaybackTrackingSource::header() const {
  return reader_.header();
}

std::uint64_t PlaybackTrackingSource::framesPlayed() const {
  std::lock_guard lock(mutex_);
  return played_;
}

std::uint64_t PlaybackTrackingSource::loopsCompleted() const {
  std::lock_guard lock(mutex_);
  return loops_;
}

double PlaybackTrackingSource::mediaTime(std::size_t index) const {
  return reader_.header().frames[index].timestamp + static_cast<double>(loops_) * loop_period_;
}

bool PlaybackTrackingSource::publishFrame(std::size_t index) noexcept {
  const auto& header = reader_.header();
  if (index >= header.frames.size()) return false;
  const auto& frame = header.frames[index];
  double offset = 0.0;
  {
    std::lock_guard lock(mutex_);
    offset = static_cast<double>(loops_) * loop_period_;
  }
  const double timestamp = frame.timestamp + offset;
  batch_.clear();
  for (const auto& [name, transform] : frame.transforms) {
    ToolUpdate u;
    u.name = name;
    u.to_T_from = Eigen::Isometry3d(transform.matrix);
    u.status = transform.status;
    u.timestamp = timestamp;
    batch_.push_back(std::move(u));
  }
  if (options_.load_images && header.frameBytes() > 0) {  // a tracker buffer has no images to load
    try {
      TrackedImage image;
      image.name = options_.image_name;
      image.frame = options_.image_frame;
      image.timestamp = timestamp;
      image.geometry = header.geometry;
      image.format = header.pixel_format;
      image.pixels.resize(header.frameBytes());
      {
        std::lock_guard lock(reader_mutex_);
        reader_.readFramePixels(index, image.pixels);
      }
      publishImage(image);
      std::lock_guard lock(image_mutex_);
      image_ = std::move(image);
    } catch (const std::exception& e) {
      logger()->warn("playback: frame {} of '{}' has no readable image: {}", index, path_.string(), e.what());
    }
  }
  publish(batch_);
  return true;
}

void PlaybackTrackingSource::reanchor() {
  anchor_wall_ = std::chrono::steady_clock::now();
  anchor_media_ = next_ < frameCount() ? mediaTime(next_) : 0.0;
}

void PlaybackTrackingSource::start() {
  {
    std::lock_guard lock(mutex_);
    if (running_) return;
    running_ = true;
    changed_ = false;
    reanchor();
  }
  setState(SourceState::Running);
  thread_ = std::thread([this] { run(); });
}

void PlaybackTrackingSource::stop() {
  {
    std::lock_guard lock(mutex_);
    running_ = false;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  setState(SourceState::Stopped);
}

void PlaybackTrackingSource::pause() {
  {
    std::lock_guard lock(mutex_);
    paused_ = true;
    changed_ = true;
  }
  setState(SourceState::Paused);
  wake_.notify_all();
}

void PlaybackTrackingSource::resume() {
  {
    std::lock_guard lock(mutex_);
    paused_ = false;
    changed_ = true;
  }
  setState(SourceState::Running);
  wake_.notify_all();
}

void PlaybackTrackingSource::seekFrame(std::size_t index) {
  {
    std::lock_guard lock(mutex_);
    next_ = std::min(index, frameCount() - 1);
    changed_ = true;
  }
  wake_.notify_all();
}

void PlaybackTrackingSource::seekTime(double timestamp) {
  const auto& frames = reader_.header().frames;
  const auto it = std::lower_bound(frames.begin(), frames.end(), timestamp,
                                   [](const TrackedFrame& f, double t) { return f.timestamp < t; });
  seekFrame(static_cast<std::size_t>(it - frames.begin()));
}

void PlaybackTrackingSource::setSpeed(double speed) {
  if (!(speed >= 0.0) || !std::isfinite(speed)) {
    throw InvalidArgumentError("playback: speed must be >= 0 (0 = as fast as possible)");
  }
  {
    std::lock_guard lock(mutex_);
    options_.speed = speed;
    changed_ = true;
  }
  wake_.notify_all();
}

void PlaybackTrackingSource::run() {
  std::unique_lock lock(mutex_);
  while (running_) {
    if (changed_) {
      changed_ = false;
      reanchor();
    }
    if (paused_) {
      wake_.wait(lock, [this] { return !running_ || changed_; });
      continue;
    }
    if (next_ >= frameCount()) {
      if (!options_.loop) {
        lock.unlock();
        setState(SourceState::Finished);
        lock.lock();
        wake_.wait(lock, [this] { return !running_ || changed_; });
        if (running_ && !paused_) {
          lock.unlock();
          setState(SourceState::Running);
          lock.lock();
        }
        continue;
      }
      next_ = 0;
      ++loops_;
      reanchor();
    }
    if (options_.speed > 0.0) {
      const double wait_s = (mediaTime(next_) - anchor_media_) / options_.speed;
      const auto due = anchor_wall_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                          std::chrono::duration<double>(wait_s));
      if (wake_.wait_until(lock, due, [this] { return !running_ || changed_; })) continue;
    }
    const std::size_t index = next_++;
    ++played_;
    lock.unlock();
    publishFrame(index);
    lock.lock();
  }
}

}  // namespace mrsns::tracking
