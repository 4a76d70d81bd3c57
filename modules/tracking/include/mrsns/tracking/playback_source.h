#pragma once
// Plays a PLUS tracked-frame sequence file through the same path as live
// data: each frame's transforms (with their statuses) go into the repository
// and to the update callback, timestamped as recorded; optionally its image.
// Real time, faster or slower (speed factor), as fast as possible, looping,
// seek to a time or frame, pause.
#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <mutex>
#include <thread>

#include "mrsns/io/sequence_file.h"
#include "mrsns/tracking/tracking_source.h"

namespace mrsns::tracking {

struct PlaybackOptions {
  /// 1 = real time, 2 = twice as fast, 0.5 = half speed; 0 = as fast as possible.
  double speed = 1.0;
  /// Start again at the first frame after the last one. Timestamps keep
  /// increasing: loop k adds k * (duration + mean frame interval).
  bool loop = false;
  /// Read each frame's pixels and keep the latest as latestImage() (costs an
  /// inflate per frame for compressed files).
  bool load_images = false;
  /// Name and frame of the image: PLUS images live in the "Image" frame in
  /// pixel units, so ijk_to_frame is the identity and ImageToReference comes
  /// from the repository once ImageToProbe (the calibration) is set.
  std::string image_name = "Image";
  std::string image_frame = "Image";
};

class PlaybackTrackingSource : public TrackingSource {
 public:
  /// Opens the file (header only). Throws FileError / FormatError from the
  /// reader, InvalidArgumentError for a negative or NaN speed or a file
  /// without frames.
  PlaybackTrackingSource(std::shared_ptr<TransformRepository> repository, const std::filesystem::path& sequence,
                         PlaybackOptions options = {});
  ~PlaybackTrackingSource() override;

  void start() override;
  void stop() override;
  [[nodiscard]] std::string name() const override;
  [[nodiscard]] std::vector<std::string> toolNames() const override;
  [[nodiscard]] std::optional<TrackedImage> latestImage() const override;

  void pause();
  void resume();
  /// Makes `index` the next frame played (clamped to the last frame).
  void seekFrame(std::size_t index);
  /// Seeks to the first frame at or after `timestamp` (file time, seconds).
  void seekTime(double timestamp);
  void setSpeed(double speed);

  /// Publishes frame `index` now, on the caller's thread (tests, stepping by
  /// hand; do not mix with start()). Returns false for an index out of range.
  bool publishFrame(std::size_t index) noexcept;

  [[nodiscard]] std::size_t frameCount() const;
  /// Frames published since start (all loops).
  [[nodiscard]] std::uint64_t framesPlayed() const;
  [[nodiscard]] std::uint64_t loopsCompleted() const;
  /// Metadata of every frame (no pixels).
  [[nodiscard]] const TrackedSequence& header() const;

 private:
  void run();
  void reanchor();
  double mediaTime(std::size_t index) const;

  std::filesystem::path path_;
  PlaybackOptions options_;
  mutable std::mutex reader_mutex_;
  io::SequenceReader reader_;
  double loop_period_ = 0.0;
  std::vector<ToolUpdate> batch_;

  mutable std::mutex mutex_;  // guards the playback position below
  std::condition_variable wake_;
  bool running_ = false;
  bool paused_ = false;
  bool changed_ = false;
  std::size_t next_ = 0;
  std::uint64_t loops_ = 0;
  std::uint64_t played_ = 0;
  std::chrono::steady_clock::time_point anchor_wall_;
  double anchor_media_ = 0.0;
  std::thread thread_;

  mutable std::mutex image_mutex_;
  std::optional<TrackedImage> image_;
};

}  // namespace mrsns::tracking
