// A tracked ultrasound sweep recorded live, frames paired with interpolated poses.
#include "live_us_recording.h"

#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <thread>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/tracking/igtl_source.h"
#include "step_internal.h"

namespace mrsns::workflow::detail {

namespace {

// A tool's pose at time t from its samples (sorted by time): interpolated between the valid samples around t when
// both lie within 0.1 s of it; nullopt otherwise (PLUS then reports the tool invalid in that frame).
std::optional<Eigen::Isometry3d> interpolateAt(const std::vector<std::pair<double, Eigen::Isometry3d>>& samples,
                                               double t) {
  constexpr double kMaxGap_s = 0.1;
  const auto after =
      std::lower_bound(samples.begin(), samples.end(), t, [](const auto& s, double x) { return s.first < x; });
  if (after != samples.end() && after->first == t) return after->second;
  if (after == samples.begin() || after == samples.end()) return std::nullopt;
  const auto before = after - 1;
  if (t - before->first > kMaxGap_s || after->first - t > kMaxGap_s) return std::nullopt;
  return interpolatePose(before->second, after->second, (t - before->first) / (after->first - before->first));
}

}  // namespace

LiveUsRecording recordLiveUltrasound(const LiveUsRecordingOptions& options, const StepContext& context) {
  const auto igtl = plusClientOptions(options.host, options.port);
  tracking::IgtlTrackingSource source(std::make_shared<TransformRepository>(), igtl);

  std::mutex mutex;
  std::map<std::string, std::vector<std::pair<double, Eigen::Isometry3d>>> poses;
  // Held by pointer: the network thread's callback and the loop that hands frames to the monitor share the
  // list under a lock, and neither copies a frame's pixels while holding it (a client that stalls its network
  // thread makes a PlusServer drop frames).
  std::vector<std::shared_ptr<tracking::TrackedImage>> images;
  LiveUsRecording out;
  using Clock = std::chrono::steady_clock;
  Clock::time_point last_image{};
  source.setUpdateCallback([&](std::span<const tracking::ToolUpdate> updates) {
    std::lock_guard lock(mutex);
    for (const auto& u : updates) {
      if (u.status != TransformStatus::Ok) continue;
      auto& v = poses[u.name];
      // Samples arrive in order per tool; one out of order (a resent sample) is dropped rather than sorted in.
      if (v.empty() || u.timestamp > v.back().first) v.emplace_back(u.timestamp, u.to_T_from);
      ++out.tool_samples;
    }
  });
  source.setImageCallback([&](const tracking::TrackedImage& image) {
    auto copy = std::make_shared<tracking::TrackedImage>(image);  // the pixels copied outside the lock
    std::lock_guard lock(mutex);
    if (!images.empty() &&
        (image.geometry.size != images.front()->geometry.size || !(image.format == images.front()->format))) {
      ++out.frames_refused;
      return;
    }
    if (images.size() >= options.max_frames) return;
    images.push_back(std::move(copy));
    last_image = Clock::now();
  });
  const auto start = Clock::now();
  source.start();
  std::size_t monitored = 0;
  std::string monitor_message;
  try {
    while (true) {
      const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
      std::size_t frames = 0;
      double idle = 0.0;
      std::vector<std::shared_ptr<tracking::TrackedImage>> fresh;
      {
        std::lock_guard lock(mutex);
        frames = images.size();
        if (frames > 0) idle = std::chrono::duration<double>(Clock::now() - last_image).count();
        if (options.on_frame) fresh.assign(images.begin() + static_cast<std::ptrdiff_t>(monitored), images.end());
      }
      // Outside the lock: the monitor may take a few ms a frame (segmentation) while frames keep arriving.
      for (const auto& image : fresh) {
        ++monitored;
        if (!out.complete && options.on_frame(*image, monitor_message)) out.complete = true;
      }
      if (frames == 0 && elapsed > options.connect_timeout_s) {
        throw NetworkError("no ultrasound frame from the PlusServer at " + options.host + ":" +
                           std::to_string(options.port) + " in " + std::to_string(static_cast<int>(elapsed)) +
                           " s: check that it runs and streams IMAGE messages");
      }
      if (out.complete) break;
      if (frames > 0 && (idle > options.idle_stop_s || frames >= options.max_frames)) break;
      if (elapsed > options.max_duration_s) break;
      context.report(std::min(0.25, 0.05 + 0.2 * elapsed / options.max_duration_s),
                     monitor_message.empty() ? "recording the sweep: " + std::to_string(frames) + " frames"
                                             : monitor_message);
      if (context.cancelled()) throw Cancelled{};
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  } catch (...) {
    source.stop();
    throw;
  }
  source.stop();
  out.device_identity = source.deviceIdentity();
  out.seconds = std::chrono::duration<double>(Clock::now() - start).count();

  std::lock_guard lock(mutex);
  if (images.empty()) throw NetworkError("the PlusServer sent no ultrasound frame");
  std::map<double, TrackedFrame> by_time;
  for (const auto& [name, samples] : poses) {
    for (const auto& [t, pose] : samples) {
      auto& f = by_time[t];
      f.timestamp = t;
      f.transforms[name] = FrameTransform{pose.matrix(), TransformStatus::Ok};
    }
  }
  out.tracker_frames.reserve(by_time.size());
  for (auto& [t, f] : by_time) out.tracker_frames.push_back(std::move(f));
  TrackedSequence& seq = out.sequence;
  const auto& first = *images.front();
  seq.geometry = first.geometry;
  seq.pixel_format = first.format;
  seq.orientation = "MF";  // PlusServer sends MF frames
  for (auto& image : images) {
    TrackedFrame f;
    f.timestamp = image->timestamp;
    f.pixels = std::move(image->pixels);  // the network is stopped: nothing else holds the frames now
    for (const auto& [name, samples] : poses) {
      const auto pose = interpolateAt(samples, f.timestamp);
      f.transforms[name] = pose ? FrameTransform{pose->matrix(), TransformStatus::Ok}
                                : FrameTransform{Eigen::Matrix4d::Identity(), TransformStatus::Invalid};
    }
    seq.frames.push_back(std::move(f));
  }
  return out;
}

}  // namespace mrsns::workflow::detail
