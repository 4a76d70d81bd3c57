// The navigation loop: one worker thread fed by the tracking source's
// callback, so the source's thread never waits for the disk or the network.
#include <chrono>
#include <cmath>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/core/wall_clock.h"
#include "mrsns/igtlink/server.h"
#include "mrsns/tracking/hologram_client_preset.h"
#include "mrsns/webxr/webxr_hologram_service.h"
#include "mrsns/workflow/navigation.h"
#include "live_soft_tissue.h"
#include "navigation_robot.h"
#include "tracking_recorder.h"
#include "video_recorder.h"

namespace mrsns::workflow {

namespace {

std::string statusName(TransformStatus s) {
  switch (s) {
    case TransformStatus::Ok: return "OK";
    case TransformStatus::Missing: return "MISSING";
    default: return "INVALID";
  }
}

constexpr std::size_t kMaxLatencySamples = 250000;

}  // namespace

NavigationLoop::NavigationLoop(NavigationOptions options, std::vector<tracking::HologramModel> models)
    : options_(std::move(options)), repository_(std::make_shared<TransformRepository>()) {
  const auto& ro = options_.robot;
  if (ro.robot != "none" && ro.robot != "simulated" && ro.robot != "ur") {
    throw InvalidArgumentError("navigation: unknown robot '" + ro.robot +
                               "': use none or simulated (in-process UR5), or ur (a UR controller)");
  }
  DeviceOptions devices = options_.devices;
  if (ro.robot != "none") {
    // The drill marker is seen on the simulated arm by the loop, not scripted in the tracker: its dropout is
    // applied here.
    if (devices.dropout_tool == ro.tool_transform && devices.dropout_start_s >= 0.0) {
      drill_dropout_start_s_ = devices.dropout_start_s;
      drill_dropout_end_s_ = devices.dropout_start_s + devices.dropout_duration_s;
      devices.dropout_start_s = -1.0;
    }
    const auto tool = TransformName::parse(ro.tool_transform);
    const auto patient = TransformName::parse(ro.patient_transform);
    robot_tool_ = repository_->prepare(tool.from, tool.to);
    robot_patient_ = repository_->prepare(patient.from, patient.to);
    robot_ = std::make_unique<detail::NavigationRobot>(ro, options_.silence_timeout_s, options_.devices.noise_mm,
                                                       options_.devices.seed, [this] { return elapsed(); });
  }
  source_ = makeTrackingSource(devices, repository_);
  if (!options_.recording.empty()) {
    recorder_ = std::make_unique<detail::TrackingRecorder>(options_.recording, options_.sync_interval_s);
  }
  std::filesystem::path video = options_.video_recording;
  if (video.empty() && !options_.recording.empty()) {
    video = options_.recording.parent_path() / (options_.recording.stem().string() + "_video.mhd");
  }
  if (!video.empty()) video_ = std::make_unique<detail::VideoRecorder>(video, options_.sync_interval_s);
  if (!options_.soft_tissue.shape_model.empty()) {
    // The supervisor watches the soft tissue near the path the robot follows (in the plan, i.e. CT, frame).
    std::vector<registration::ScrewPath> paths;
    if (robot_) paths.push_back(ro.plan);
    soft_tissue_ = std::make_unique<detail::LiveSoftTissue>(
        options_.soft_tissue, std::move(paths), [this] { return elapsed(); },
        [this](const std::string& kind, const std::string& message) {
          std::lock_guard lock(mutex_);
          addEvent(elapsed(), kind, message);
        });
    if (!options_.soft_tissue.hologram_model.empty()) {
      soft_tissue_->setMeshSink([this](const std::shared_ptr<const TriangleMesh>& mesh) {
        std::lock_guard stream_lock(stream_mutex_);
        if (!streamer_ && !web_) return;
        try {
          if (web_) web_->updateMeshVertices(options_.soft_tissue.hologram_model, mesh->vertices);
          if (streamer_) streamer_->updateMeshVertices(options_.soft_tissue.hologram_model, mesh->vertices);
          ++hologram_vertex_updates_;
        } catch (const Error& e) {
          // A stream without that model (another client preset, a model of other vertices): said once.
          if (!hologram_vertex_error_.exchange(true)) logger()->warn("navigation: soft tissue on the headsets: {}", e.what());
        }
      });
    }
    if (robot_) {
      soft_tissue_->setSurfaceSink([r = robot_.get()](std::shared_ptr<const robot::SoftTissueSurface> surface,
                                                      double arrived_s) { r->setSoftTissue(std::move(surface), arrived_s); });
    }
  }
  if (video_ || soft_tissue_) {
    source_->setImageCallback([v = video_.get(), t = soft_tissue_.get()](const tracking::TrackedImage& image) {
      if (v) v->push(image);
      if (t) t->push(image);
    });
  }
  if (options_.stream_holograms && !models.empty()) streamHolograms(std::move(models), options_.hologram_port);
  for (const auto& name : options_.required_transforms) {
    const auto n = TransformName::parse(name);
    required_.push_back(repository_->prepare(n.from, n.to));
  }
  source_->setUpdateCallback([this](std::span<const tracking::ToolUpdate> updates) {
    // The probe poses that place the frames, at once: a frame must not wait for the loop's queue.
    if (soft_tissue_) soft_tissue_->observe(updates);
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

std::uint16_t NavigationLoop::streamHolograms(std::vector<tracking::HologramModel> models, int port,
                                              const std::string& client) {
  if (port < 0 || port > 65535) {
    throw InvalidArgumentError("navigation: hologram port " + std::to_string(port) +
                               " is not a TCP port: use 1-65535, or 0 for a free one");
  }
  stopHologramStream();
  igtlink::ServerOptions server_options;
  server_options.bind_address = options_.hologram_address;
  server_options.port = static_cast<std::uint16_t>(port);
  auto server = std::make_unique<igtlink::Server>(server_options);
  tracking::HologramStreamOptions stream_options;
  stream_options.forward_transforms = options_.hologram_forward_transforms;
  stream_options = tracking::withClientPreset(
      std::move(stream_options), tracking::hologramClientPreset(client.empty() ? options_.hologram_client : client));
  // Send-only: nothing a client sends reaches the repository, the supervisor or the robot.
  auto streamer = std::make_unique<tracking::HologramStreamer>(*server, repository_, std::move(models), stream_options);
  std::lock_guard stream_lock(stream_mutex_);
  if (running_) server->start();
  server_ = std::move(server);
  streamer_ = std::move(streamer);
  return running_ ? server_->port() : server_options.port;
}

void NavigationLoop::stopHologramStream() {
  std::unique_ptr<igtlink::Server> server;
  std::unique_ptr<tracking::HologramStreamer> streamer;
  {
    std::lock_guard stream_lock(stream_mutex_);
    server = std::move(server_);
    streamer = std::move(streamer_);
  }
  if (server) server->stop();
  streamer.reset();
}

webxr::WebXrHologramService& NavigationLoop::serveWebXr(std::vector<tracking::HologramModel> models,
                                                        webxr::WebXrServiceOptions options) {
  stopWebXr();
  // Send-only like the OpenIGTLink stream: a page's confirmation goes to options.stream.on_confirmation alone.
  auto web = std::make_unique<webxr::WebXrHologramService>(repository_, std::move(models), std::move(options));
  std::lock_guard stream_lock(stream_mutex_);
  if (running_) web->start();
  web_ = std::move(web);
  return *web_;
}

void NavigationLoop::stopWebXr() {
  std::unique_ptr<webxr::WebXrHologramService> web;
  {
    std::lock_guard stream_lock(stream_mutex_);
    web = std::move(web_);
  }
  if (web) web->stop();
}

void NavigationLoop::start() {
  if (running_.exchange(true)) return;
  start_ = std::chrono::steady_clock::now();
  {
    std::lock_guard stream_lock(stream_mutex_);
    if (server_) server_->start();
    if (web_) web_->start();
  }
  {
    std::lock_guard lock(mutex_);
    status_.running = true;
  }
  thread_ = std::thread([this] { run(); });
  if (soft_tissue_) soft_tissue_->start();
  source_->start();
}

void NavigationLoop::stop() {
  if (!running_.exchange(false)) return;
  // The robot first: a tracker that stops because the loop ends is not a tracker loss.
  if (robot_) robot_->stop();
  source_->stop();
  if (video_) video_->stop();  // every frame the source delivered is on disk
  if (soft_tissue_) soft_tissue_->stop();
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  if (robot_) pollRobot();
  {
    std::lock_guard stream_lock(stream_mutex_);
    if (server_) server_->stop();
    if (web_) web_->stop();
  }
  std::lock_guard lock(mutex_);
  if (recorder_) {
    recorder_->stop();  // every batch the loop processed is on disk
    const auto r = recorder_->stats();
    status_.frames_recorded = r.recorded;
    status_.frames_synced = r.synced;
    if (status_.recorder_error.empty() && !r.error.empty()) status_.recorder_error = r.error;
  }
  status_.running = false;
  status_.source = source_->status();
}

bool NavigationLoop::rearm() {
  if (!robot_) {
    std::lock_guard lock(mutex_);
    status_.robot_stopped = false;
    status_.operator_stopped = false;
    status_.stop_reason.clear();
    return true;
  }
  std::uint64_t stops_before = 0;
  {
    std::lock_guard lock(mutex_);
    stops_before = safety_stops_seen_;
  }
  std::string why;
  const bool ok = robot_->rearm(why);
  std::lock_guard lock(mutex_);
  if (ok) {
    // A stop that pollRobot() reported after the acknowledge (tracking lost
    // again at once) stands; one it has not read yet is set after this.
    if (safety_stops_seen_ == stops_before) {
      status_.robot_stopped = false;
      status_.operator_stopped = false;
      status_.stop_reason.clear();
    }
    addEvent(elapsed(), "rearmed", "supervisor acknowledged the stop: the robot waits in Ready");
  } else {
    addEvent(elapsed(), "rearm-refused", why);
  }
  return ok;
}

bool NavigationLoop::stopRobot(const std::string& reason) {
  const std::string text = "operator: " + (reason.empty() ? std::string("stop requested") : reason);
  std::string why;
  if (robot_ && !robot_->operatorStop(why)) {
    std::lock_guard lock(mutex_);
    addEvent(elapsed(), "stop-refused", why);
    return false;
  }
  StopHandler handler;
  {
    std::lock_guard lock(mutex_);
    addEvent(elapsed(), "operator-stop", "robot stopped: " + text + "; navigation goes on");
    // A safety stop already in force keeps its reason: the banner must still say what was lost.
    if (status_.robot_stopped) return true;
    status_.robot_stopped = true;
    status_.operator_stopped = true;
    status_.stop_reason = text;
    handler = stop_handler_;
  }
  if (handler) {
    try {
      handler(text);
    } catch (const std::exception& e) {
      std::lock_guard lock(mutex_);
      addEvent(elapsed(), "stop-handler-error", e.what());
    }
  }
  return true;
}

bool NavigationLoop::startRobot() {
  return robot_ && robot_->startPlacement();
}

void NavigationLoop::killTracker() {
  source_->stop();
  std::lock_guard lock(mutex_);
  addEvent(elapsed(), "source", "tracker killed (simulated tracker failure)");
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
    if (robot_) {
      robot_->setConnected(source_->status().state == tracking::SourceState::Running, elapsed());
      pollRobot();
    } else {
      supervise(elapsed(), silent);
    }
  }
}

void NavigationLoop::process(const std::vector<tracking::ToolUpdate>& batch, double arrived_s) {
  TrackedFrame frame;
  frame.timestamp = batch.empty() ? arrived_s : batch.front().timestamp;
  for (const auto& u : batch) {
    frame.transforms[u.name] = FrameTransform{u.to_T_from.matrix(), u.status};
  }
  frame.custom_fields["ArrivalTime"] = std::to_string(arrived_s);
  if (robot_) {
    std::optional<Eigen::Isometry3d> tracker_T_patient;
    for (const auto& u : batch) {
      if (u.name == options_.robot.patient_transform && u.status == TransformStatus::Ok)
        tracker_T_patient = u.to_T_from;
    }
    const bool visible = !(frame.timestamp >= drill_dropout_start_s_ && frame.timestamp < drill_dropout_end_s_);
    if (const auto drill = robot_->observeDrill(tracker_T_patient, frame.timestamp, visible)) {
      try {
        repository_->setTransform(drill->name, drill->to_T_from, drill->status, drill->timestamp);
        frame.transforms[drill->name] = FrameTransform{drill->to_T_from.matrix(), drill->status};
      } catch (const std::exception& e) {
        std::lock_guard lock(mutex_);
        addEvent(arrived_s, "robot-error", e.what());
      }
    }
    NavigationStatus robot_status;
    robot_->fillStatus(robot_status);
    frame.custom_fields["SupervisorState"] = robot_status.supervisor_state;
  }
  // The supervisor first: a loss must not wait for the disk.
  if (robot_) feedRobot(arrived_s, frame.timestamp);
  if (recorder_) {
    recorder_->push(frame);
    const auto r = recorder_->stats();
    std::lock_guard lock(mutex_);
    if (status_.recorder_error.empty() && !r.error.empty()) {
      status_.recorder_error = r.error;
      addEvent(arrived_s, "recorder-error", r.error);
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
  bool streamed = false;
  {
    std::lock_guard stream_lock(stream_mutex_);
    if (streamer_) {
      streamer_->update(unixTimeSeconds());
      streamed = true;
    }
    if (web_) {
      web_->update(unixTimeSeconds());
      streamed = true;
    }
  }
  if (streamed) {
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
  // Bounded (a day at 60 Hz would be 5 M samples): an hour at 60 Hz fits, older batches are thinned.
  if (latencies_.size() >= kMaxLatencySamples) {
    std::vector<NavigationLatencySample> thinned;
    thinned.reserve(kMaxLatencySamples / 2 + 1);
    for (std::size_t i = 0; i < latencies_.size(); i += 2) thinned.push_back(latencies_[i]);
    latencies_.swap(thinned);
  }
  latencies_.push_back(NavigationLatencySample{arrived_s, (done - arrived_s) * 1e3});
  status_.mean_loop_latency_ms = latency_sum_ms_ / static_cast<double>(status_.batches);
  if (recorder_) {
    const auto r = recorder_->stats();
    status_.frames_recorded = r.recorded;
    status_.frames_synced = r.synced;
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

void NavigationLoop::feedRobot(double arrived_s, double timestamp) {
  // Sample times onto the loop clock: the newest batch arrived now, older edges are older by their
  // timestamp difference (a PlusServer stamps in UTC, the simulator from its start).
  const double offset = arrived_s - timestamp;
  detail::TrackingFeed feed;
  auto watch = [&](TransformRepository::Query& query, bool& ok, double& time_s, Eigen::Isometry3d& pose) {
    const auto r = repository_->evaluate(query);
    ok = r.ok();
    time_s = std::isnan(r.timestamp) ? arrived_s : r.timestamp + offset;
    pose = r.to_T_from;
    if (!ok && feed.lost.empty())
      feed.lost = "tracking lost: " + query.from() + "To" + query.to() + " " + statusName(r.status);
  };
  watch(robot_patient_, feed.patient_ok, feed.patient_time_s, feed.tracker_T_patient);
  watch(robot_tool_, feed.tool_ok, feed.tool_time_s, feed.tracker_T_tool);
  for (auto& query : required_) {
    const std::string name = query.from() + "To" + query.to();
    if (name == options_.robot.tool_transform || name == options_.robot.patient_transform) continue;
    const auto r = repository_->evaluate(query);
    if (r.ok()) continue;
    feed.others_ok = false;
    if (feed.lost.empty()) feed.lost = "tracking lost: " + name + " " + statusName(r.status);
  }
  feed.connected = source_->status().state == tracking::SourceState::Running;
  robot_->feed(std::move(feed), arrived_s);
}

void NavigationLoop::pollRobot() {
  const auto log = robot_->transitions();
  for (; robot_transitions_seen_ < log.size(); ++robot_transitions_seen_) {
    const auto& t = log[robot_transitions_seen_];
    if (t.to == "Stopped" || t.to == "Fault") {
      const std::string reason =
          (t.tracking.empty() ? std::string() : t.tracking + "; ") + "supervisor " + t.reason + ": " + t.detail;
      StopHandler handler;
      {
        std::lock_guard lock(mutex_);
        ++safety_stops_seen_;
        status_.robot_stopped = true;
        status_.operator_stopped = false;
        status_.stop_reason = reason;
        addEvent(t.time_s, "safety-stop",
                 "robot stopped: " + reason + " (cycle " + std::to_string(t.cycle) + ", " + t.command + ")");
        handler = stop_handler_;
      }
      if (handler) {
        try {
          handler(reason);
        } catch (const std::exception& e) {
          std::lock_guard lock(mutex_);
          addEvent(t.time_s, "stop-handler-error", e.what());
        }
      }
    } else {
      std::lock_guard lock(mutex_);
      if (t.from == "Stopped" || t.from == "Fault") {
        status_.robot_stopped = false;
        status_.stop_reason.clear();
      }
      events_.push_back(NavigationEvent{t.time_s, "robot", t.from + " -> " + t.to + " (" + t.detail + ")"});
    }
  }
}

NavigationStatus NavigationLoop::status() const {
  std::uint16_t port = 0;
  std::size_t clients = 0;
  {
    std::lock_guard stream_lock(stream_mutex_);
    if (server_ && running_) port = server_->port();
    if (streamer_) clients = streamer_->readyClients();
  }
  std::lock_guard lock(mutex_);
  NavigationStatus s = status_;
  if (soft_tissue_) soft_tissue_->fillStatus(s);
  s.hologram_port = port;
  s.hologram_vertex_updates = hologram_vertex_updates_.load();
  s.hologram_clients = clients;
  s.source = source_->status();
  if (robot_) robot_->fillStatus(s);
  if (video_) {
    const auto v = video_->stats();
    s.video_frames_recorded = v.recorded;
    s.video_frames_synced = v.synced;
    s.video_frames_dropped = v.dropped;
    s.video_error = v.error;
    if (v.recorded > 0) s.video_recording = video_->path();
  }
  return s;
}

std::vector<NavigationRobotTransition> NavigationLoop::robotTransitions() const {
  return robot_ ? robot_->transitions() : std::vector<NavigationRobotTransition>{};
}

std::vector<NavigationLatencySample> NavigationLoop::latencySeries() const {
  std::lock_guard lock(mutex_);
  return latencies_;
}

std::vector<NavigationEvent> NavigationLoop::events() const {
  std::lock_guard lock(mutex_);
  return events_;
}

std::string NavigationLoop::deviceIdentity() const {
  return source_->deviceIdentity();
}

std::vector<SoftTissueSample> NavigationLoop::softTissueSeries() const {
  return soft_tissue_ ? soft_tissue_->samples() : std::vector<SoftTissueSample>{};
}

std::optional<LiveUltrasoundFrame> NavigationLoop::liveUltrasound() const {
  return soft_tissue_ ? soft_tissue_->latestFrame() : std::nullopt;
}

std::shared_ptr<const TriangleMesh> NavigationLoop::softTissueMesh() const {
  return soft_tissue_ ? soft_tissue_->currentMeshCt() : nullptr;
}

}  // namespace mrsns::workflow
