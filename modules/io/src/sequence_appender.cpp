// Crash-safe sequence recording: append pixels, rewrite the header atomically.
#include "mrsns/io/sequence_appender.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "mrsns/core/error.h"
#include "sequence_internal.h"

namespace mrsns::io {

namespace fs = std::filesystem;

namespace {

bool writeAll(int fd, const std::uint8_t* data, std::size_t size) {
  while (size > 0) {
    const auto n = ::write(fd, data, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    data += n;
    size -= static_cast<std::size_t>(n);
  }
  return true;
}

}  // namespace

TrackedSequence SequenceAppender::trackerOnlyLayout() {
  TrackedSequence layout;
  layout.geometry.dimensions = 2;
  layout.geometry.size = {0, 0, 1};  // PLUS's tracker buffer: DimSize = 0 0 N, no pixels
  layout.pixel_format = FramePixelFormat{PixelType::UInt8, 1};
  return layout;
}

SequenceAppender::SequenceAppender(const fs::path& path, const TrackedSequence& layout,
                                   const SequenceAppenderOptions& options)
    : path_(path), options_(options), layout_(layout) {
  if (path.extension() != ".mhd") {
    throw InvalidArgumentError("recording '" + path.string() +
                               "' must end in .mhd (header) so the pixels can be appended to a .raw beside it");
  }
  if (!(options.sync_interval_s > 0.0)) {
    throw InvalidArgumentError("sync interval must be > 0 s for recording '" + path.string() + "'");
  }
  layout_.frames.clear();
  {
    // Validate the layout with one zero frame: the same checks as writeSequence.
    TrackedSequence probe = layout_;
    probe.frames.push_back(TrackedFrame{});
    probe.frames.back().pixels.assign(probe.frameBytes(), 0);
    detail::checkWritable(probe, path.string());
  }
  zeros_.assign(layout_.frameBytes(), 0);
  data_path_ = path;
  data_path_.replace_extension(".raw");
  std::error_code ec;
  if (fs::exists(path_, ec) || fs::exists(data_path_, ec)) {
    throw FileError("recording '" + path_.string() + "' already exists: choose a new name (nothing was overwritten)");
  }
  data_fd_ = ::open(data_path_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (data_fd_ < 0) {
    throw FileError("cannot create recording data '" + data_path_.string() + "': " + std::strerror(errno));
  }
  writeHeader();  // an empty but valid sequence from the first instant
  if (!error_.empty()) {
    ::close(data_fd_);
    throw FileError(error_);
  }
  last_sync_ = std::chrono::steady_clock::now();
}

SequenceAppender::~SequenceAppender() {
  sync();
  if (data_fd_ >= 0) ::close(data_fd_);
}

bool SequenceAppender::append(const TrackedFrame& frame) noexcept {
  try {
    const std::size_t bytes = layout_.frameBytes();
    if (!frame.pixels.empty() && frame.pixels.size() != bytes) {
      error_ = "frame with " + std::to_string(frame.pixels.size()) + " pixel bytes, the recording takes " +
               std::to_string(bytes);
      return false;
    }
    const auto& pixels = frame.pixels.empty() ? zeros_ : frame.pixels;
    if (!writeAll(data_fd_, pixels.data(), pixels.size())) {
      error_ = "writing '" + data_path_.string() + "' failed: " + std::strerror(errno);
      return false;
    }
    TrackedFrame meta = frame;
    meta.pixels.clear();
    frames_.push_back(std::move(meta));
    const auto now = std::chrono::steady_clock::now();
    if (std::chrono::duration<double>(now - last_sync_).count() >= options_.sync_interval_s) return sync();
    return true;
  } catch (const std::exception& e) {
    error_ = e.what();
    return false;
  }
}

bool SequenceAppender::sync() noexcept {
  last_sync_ = std::chrono::steady_clock::now();
  if (data_fd_ < 0 || synced_frames_ == frames_.size()) return error_.empty();
  // Pixels first: the header must never list a frame whose pixels may not be on disk.
  if (::fdatasync(data_fd_) != 0) {
    error_ = "syncing '" + data_path_.string() + "' failed: " + std::strerror(errno);
    return false;
  }
  const std::size_t before = synced_frames_;
  writeHeader();
  return synced_frames_ > before || frames_.empty();
}

void SequenceAppender::writeHeader() {
  try {
    TrackedSequence header = layout_;
    header.frames = frames_;
    const std::string text =
        detail::formatMetaImageHeader(header, false, std::nullopt, data_path_.filename().string(), nullptr);
    const fs::path temp = path_.string() + ".tmp";
    const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) {
      error_ = "cannot write recording header '" + temp.string() + "': " + std::strerror(errno);
      return;
    }
    const bool ok = writeAll(fd, reinterpret_cast<const std::uint8_t*>(text.data()), text.size()) && ::fsync(fd) == 0;
    ::close(fd);
    if (!ok || ::rename(temp.c_str(), path_.c_str()) != 0) {
      error_ = "writing recording header '" + path_.string() + "' failed: " + std::strerror(errno);
      return;
    }
    synced_frames_ = frames_.size();
  } catch (const std::exception& e) {
    error_ = std::string("recording header '") + path_.string() + "': " + e.what();
  }
}

}  // namespace mrsns::io
