#pragma once
// Crash-safe recording of a PLUS sequence as it arrives: a MetaImage header
// (.mhd) beside uncompressed pixels (.raw). Each frame's pixels are appended
// to the .raw at once; every `sync_interval_s` the .raw is fsync'ed and the
// header, listing every frame written so far, is replaced atomically
// (temporary file, fsync, rename). After a kill -9 or power loss the .mhd on
// disk is always a complete, readable sequence holding every frame appended
// up to the last sync: at most `sync_interval_s` of data is lost. Pixel bytes
// beyond the frames the header lists are ignored by readers.
//
// Tracker-only streams (no image) are stored as PLUS stores its tracker
// buffers: DimSize = 0 0 N, no pixel data (the .raw stays empty).
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "mrsns/core/tracked_frame.h"

namespace mrsns::io {

struct SequenceAppenderOptions {
  /// Longest time (s) between syncs: the most a crash can lose.
  double sync_interval_s = 0.5;
};

class SequenceAppender {
 public:
  /// Starts a new recording at `path` (.mhd; the pixels go to the .raw of the
  /// same name). `layout` gives the geometry, pixel format, orientation and
  /// global fields (its frames are ignored). Throws InvalidArgumentError for
  /// another extension or an empty geometry (0x0 frames are a tracker buffer, not empty), FileError when the files
  /// cannot be created, and refuses to overwrite an existing recording.
  SequenceAppender(const std::filesystem::path& path, const TrackedSequence& layout,
                   const SequenceAppenderOptions& options = {});
  /// Layout for a stream of transforms only (0x0 frames, as PLUS's tracker buffers).
  static TrackedSequence trackerOnlyLayout();
  /// Syncs and closes.
  ~SequenceAppender();
  SequenceAppender(const SequenceAppender&) = delete;
  SequenceAppender& operator=(const SequenceAppender&) = delete;

  /// Appends one frame (its pixels must be frameBytes() long; an empty pixel
  /// vector is stored as zeros, for transform-only frames). Syncs when the
  /// interval has passed. Never throws (real-time callers): returns false and
  /// keeps the reason in lastError() when the frame is malformed or the disk
  /// fails; frames already synced stay readable.
  bool append(const TrackedFrame& frame) noexcept;
  /// Makes everything appended so far durable now. Never throws; false on failure.
  bool sync() noexcept;

  [[nodiscard]] std::size_t framesAppended() const { return frames_.size(); }
  [[nodiscard]] std::size_t framesSynced() const { return synced_frames_; }
  [[nodiscard]] const std::string& lastError() const { return error_; }
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }
  [[nodiscard]] const std::filesystem::path& dataPath() const { return data_path_; }

 private:
  void writeHeader();
  std::filesystem::path path_;
  std::filesystem::path data_path_;
  SequenceAppenderOptions options_;
  TrackedSequence layout_;
  std::vector<TrackedFrame> frames_;  // metadata only
  std::vector<std::uint8_t> zeros_;
  int data_fd_ = -1;
  std::size_t synced_frames_ = 0;
  std::chrono::steady_clock::time_point last_sync_;
  std::string error_;
};

}  // namespace mrsns::io
