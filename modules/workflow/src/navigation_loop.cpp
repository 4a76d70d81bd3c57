// The navigation loop: one worker thread fed by the tracking source's
// callback, so the source's thread never waits for the disk or the network.
#include <chrono>

#include "mrsns/core/log.h"
#include "mrsns/igtlink/server.h"
#include "mrsns/io/sequence_appender.h"
#include "mrsns/workflow/navigation.h"

namespace mrsns::workflow {

namespace {

std::string statusName(TransformStatus s) {
  switch (s) {
    case TransformStatus::Ok: return "OK";
    case TransformStatus::Missing: return "MISSING";
    default: return "INVALID";
  }
}

double wallSeconds() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

}  // namespace

NavigationLoop::NavigationLoop(NavigationOptions options, std::vector<tracking::HologramModel> models)
    : options_(std::move(options)), repository_(std::make_shared<TransformRepository>()) {
  source_ = makeTrackingSource(options_.devices, repository_);
  if (!options_.recording.empty()) {
    io::SequenceAppenderOptions rec;
    rec.sync_interval_s = options_.sync_interval_s;
    recorder_ =
        std::make_unique<io::SequenceAppender>(options_.recording, io::SequenceAppender::trackerOnlyLayout(), rec);
  }
  if (options_.stream_holograms && !models.empty()) {
    igtlink::ServerOptions server_options;
    server_options.bind_address = "127.0.0.1";
    server_options.port = static_cast<std::uint16_t>(options_.hologram_port);
    server_ = std::make_unique<igtlink::Server>(server_options);
    streamer_ = std::make_unique<tracking::HologramStreamer>(*server_, repository_, std::move(models));
  }
  for (const auto& name : options_.required_transforms) {
    const auto n = TransformName::parse(name);
    required_.push_back(repository_->prepare(n.from, n.to));
  }
  source_->setUpdateCallback([this](std::span<const tracking::ToolUpdate> updates) {
    {
      std::lock_guard lock(mutex_);
      queue_.emplace_back(std::vector<tracking::ToolUpdate>(updates.begin(), updates.end()), elapsed());
    }
    wake_.notify_one();
  });
}

NavigationLoop::~NavigationLoop() {
  stop();
}

void NavigationLoop::setSceneCallback(SceneCallback callback) {
  scene_ = std::move(callback);
}
void NavigationLoop::setDeformationHook(DeformationHook hook) {
  deformation_ = std::move(hook);
}
void NavigationLoop::setStopHandler(StopHandler handler) {
  stop_handler_ = std::move(handler);
}

double NavigationLoop::elapsed() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void NavigationLoop::start() {
  if (running_.exchange(true)) return;
  start_ = std::chrono::steady_clock::now();
  if (server_) server_->start();
  {
    std::lock_guard lock(mutex_);
    status_.running = true;
    status_.hologram_port = server_ ? server_->port() : 0;
  }
  thread_ = std::thread([this] { run(); });
  source_->start();
}

void NavigationLoop::stop() {
  if (!running_.exchange(false)) return;
  source_->stop();
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  if (server_) server_->stop();
  std::lock_guard lock(mutex_);
  if (recorder_) {
    recorder_->sync();
    status_.frames_synced = recorder_->framesSynced();
  }
  status_.running = false;
  status_.source = source_->status();
}

void NavigationLoop::rearm() {
  std::lock_guard lock(mutex_);
  status_.robot_stopped = false;
  status_.stop_reason.clear();
}

void NavigationLoop::addEvent(double t, const std::string& kind, const std::string& message) {
  events_.push_back(NavigationEvent{t, kind, message});
  logger()->warn("navigation: {}: {}", kind, message);
}

void NavigationLoop::run() {
  // Drain what is queued even after stop(): the recording must hold every
  // batch the source published.
  while (true) {
    std::vector<std::pair<std::vector<tracking::ToolUpdate>, double>> batches;
    bool silent = false;
    {
      std::unique_lock lock(mutex_);
      wake_.wait_for(lock, std::chrono::milliseconds(20), [this] { return !queue_.empty() || !running_; });
      while (!queue_.empty()) {
        batches.push_back(std::move(queue_.front()));
        queue_.pop_front();
      }
      if (batches.empty() && !running_) break;
      const double now = elapsed();
      silent = batches.empty() && last_batch_s_ >= 0.0 && now - last_batch_s_ > options_.silence_timeout_s;
    }
    for (const auto& [batch, arrived] : batches) process(batch, arrived);
    supervise(elapsed(), silent);
  }
}

void NavigationLoop::process(const std::vector<tracking::ToolUpdate>& batch, double arrived_s) {
  TrackedFrame frame;
  frame.timestamp = batch.empty() ? arrived_s : batch.front().timestamp;
  for (const auto& u : batch) {
    frame.transforms[u.name] = FrameTransform{u.to_T_from.matrix(), u.status};
  }
  frame.custom_fields["ArrivalTime"] = std::to_string(arrived_s);
  if (recorder_ && !recorder_->append(frame)) {
    std::lock_guard lock(mutex_);
    if (status_.recorder_error.empty()) {
      status_.recorder_error = recorder_->lastError();
      addEvent(arrived_s, "recorder-error", recorder_->lastError());
    }
  }
  if (deformation_) {
    try {
      deformation_(*repository_, arrived_s);
      std::lock_guard lock(mutex_);
      ++status_.deformation_updates;
    } catch (const std::exception& e) {
      std::lock_guard lock(mutex_);
      addEvent(arrived_s, "deformation-error", e.what());
    }
  }
  if (streamer_) {
    streamer_->update(wallSeconds());
    std::lock_guard lock(mutex_);
    ++status_.hologram_updates;
  }
  const double done = elapsed();
  if (scene_ && (last_scene_s_ < 0.0 || done - last_scene_s_ >= 1.0 / options_.scene_rate_hz)) {
    last_scene_s_ = done;
    try {
      scene_(*repository_);
      std::lock_guard lock(mutex_);
      ++status_.scene_updates;
    } catch (const std::exception& e) {
      std::lock_guard lock(mutex_);
      addEvent(done, "scene-error", e.what());
    }
  }
  std::lock_guard lock(mutex_);
  if (last_batch_s_ >= 0.0) status_.max_batch_gap_s = std::max(status_.max_batch_gap_s, arrived_s - last_batch_s_);
  last_batch_s_ = arrived_s;
  ++status_.batches;
  latency_sum_ms_ += (done - arrived_s) * 1e3;
  status_.mean_loop_latency_ms = latency_sum_ms_ / static_cast<double>(status_.batches);
  if (recorder_) {
    status_.frames_recorded = recorder_->framesAppended();
    status_.frames_synced = recorder_->framesSynced();
  }
}

void NavigationLoop::supervise(double now_s, bool silent) {
  std::string reason;
  if (silent) {
    reason = "tracker silent for more than " + std::to_string(options_.silence_timeout_s) + " s";
  } else {
    for (auto& query : required_) {
      const auto r = repository_->evaluate(query);
      // Missing before the first sample is start-up, not a loss.
      if (r.status == TransformStatus::Missing && status_.batches == 0) continue;
      if (!r.ok()) {
        reason = "tracking lost: " + query.from() + "To" + query.to() + " " + statusName(r.status);
        break;
      }
    }
  }
  StopHandler handler;
  {
    std::lock_guard lock(mutex_);
    if (reason.empty() || status_.robot_stopped) return;
    status_.robot_stopped = true;
    status_.stop_reason = reason;
    addEvent(now_s, "safety-stop", "robot stopped: " + reason);
    handler = stop_handler_;
  }
  if (handler) {
    try {
      handler(reason);
    } catch (const std::exception& e) {
      std::lock_guard lock(mutex_);
      addEvent(now_s, "stop-handler-error", e.what());
    }
  }
}

NavigationStatus NavigationLoop::status() const {
  std::lock_guard lock(mutex_);
  NavigationStatus s = status_;
  s.source = source_->status();
  return s;
}

std::vector<NavigationEvent> NavigationLoop::events() const {
  std::lock_guard lock(mutex_);
  return events_;
}

}  // namespace mrsns::workflow
