// A tracker buffer recorded live from a PlusServer, frame by frame to disk.
#include "live_tracking_recording.h"

#include <chrono>
#include <cmath>
#include <optional>
#include <map>
#include <mutex>
#include <thread>

#include "mrsns/core/error.h"
#include "mrsns/io/sequence_appender.h"
#include "mrsns/tracking/igtl_source.h"
#include "step_internal.h"

namespace mrsns::workflow::detail {

namespace {

constexpr double kMaxFillAge_s = 0.1;

// Groups the stream's updates by timestamp into frames; a tool missing from a frame is filled from its latest
// sample when that is recent enough.
class FrameAssembler {
 public:
  /// Returns the finished frame when `u` starts a new timestamp.
  std::optional<TrackedFrame> add(const tracking::ToolUpdate& u) {
    std::optional<TrackedFrame> done;
    if (pending_ && u.timestamp != pending_->timestamp) done = finish();
    if (!pending_) {
      pending_.emplace();
      pending_->timestamp = u.timestamp;
    }
    pending_->transforms[u.name] = FrameTransform{u.to_T_from.matrix(), u.status};
    latest_[u.name] = u;
    return done;
  }
  std::optional<TrackedFrame> flush() {
    if (!pending_) return std::nullopt;
    return finish();
  }

 private:
  TrackedFrame finish() {
    TrackedFrame f = std::move(*pending_);
    pending_.reset();
    for (const auto& [name, u] : latest_) {
      if (f.transforms.count(name) != 0) continue;
      if (std::abs(f.timestamp - u.timestamp) <= kMaxFillAge_s) {
        f.transforms[name] = FrameTransform{u.to_T_from.matrix(), u.status};
      }
    }
    return f;
  }
  std::optional<TrackedFrame> pending_;
  std::map<std::string, tracking::ToolUpdate> latest_;
};

}  // namespace

LiveTrackingRecording recordLiveTracking(const LiveTrackingOptions& options, const LiveTrackingMonitor& monitor,
                                         const StepContext& context) {
  const auto igtl = plusClientOptions(options.host, options.port);
  io::SequenceAppender appender(options.recording, io::SequenceAppender::trackerOnlyLayout());
  tracking::IgtlTrackingSource source(std::make_shared<TransformRepository>(), igtl);

  std::mutex mutex;
  FrameAssembler assembler;
  std::vector<TrackedFrame> incoming;  // assembled on the source's thread, appended on this one
  source.setUpdateCallback([&](std::span<const tracking::ToolUpdate> updates) {
    std::lock_guard lock(mutex);
    for (const auto& u : updates) {
      if (auto f = assembler.add(u)) incoming.push_back(std::move(*f));
    }
  });

  LiveTrackingRecording out;
  std::string write_error;
  auto drain = [&] {
    std::vector<TrackedFrame> batch;
    {
      std::lock_guard lock(mutex);
      batch.swap(incoming);
    }
    for (auto& f : batch) {
      if (!appender.append(f) && write_error.empty()) write_error = appender.lastError();
      out.frames.push_back(std::move(f));
    }
  };
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  source.start();
  try {
    while (true) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      drain();
      if (!write_error.empty()) throw FileError("recording the tracking failed: " + write_error);
      const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
      if (out.frames.empty() && elapsed > options.connect_timeout_s) {
        const auto status = source.status();
        throw NetworkError("no tracking from the PlusServer at " + options.host + ":" + std::to_string(options.port) +
                           " in " + std::to_string(static_cast<int>(elapsed)) + " s" +
                           (status.message.empty() ? std::string() : " (" + status.message + ")") +
                           ": check that it runs and streams the tools' TRANSFORM messages");
      }
      std::string message;
      if (!out.frames.empty() && monitor(out.frames, message)) {
        out.complete = true;
        context.report(0.5, message);
        break;
      }
      if (elapsed > options.max_duration_s) break;
      context.report(std::min(0.5, 0.05 + 0.45 * elapsed / options.max_duration_s),
                     message.empty() ? "waiting for tracking from " + options.host + ":" + std::to_string(options.port)
                                     : message);
      if (context.cancelled()) throw Cancelled{};
    }
  } catch (...) {
    source.stop();
    appender.sync();
    throw;
  }
  source.stop();
  {
    std::lock_guard lock(mutex);
    if (auto f = assembler.flush()) incoming.push_back(std::move(*f));
  }
  drain();
  if (!appender.sync() && write_error.empty()) write_error = appender.lastError();
  if (!write_error.empty()) throw FileError("recording the tracking failed: " + write_error);
  out.device_identity = source.deviceIdentity();
  out.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return out;
}

nlohmann::json recordedFigures(const LiveTrackingRecording& r, const std::string& file,
                               const LiveTrackingOptions& options) {
  return {{"file", file},
          {"frames", r.frames.size()},
          {"seconds", r.seconds},
          {"complete", r.complete},
          {"device_identity", r.device_identity},
          {"host", options.host},
          {"port", options.port}};
}

}  // namespace mrsns::workflow::detail
