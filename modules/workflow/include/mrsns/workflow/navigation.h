#pragma once
// The navigation loop of paper 001 (Fig. 3): tracking -> transform
// repository -> deformation -> safety supervisor -> hologram stream ->
// scene, on its own threads, every tracking batch recorded crash-safe to a
// PLUS sequence. Real time: nothing here throws once started; problems
// become events and status.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "mrsns/core/transform_repository.h"
#include "mrsns/tracking/hologram_streamer.h"
#include "mrsns/tracking/tracking_source.h"

namespace mrsns::io {
class SequenceAppender;
}
namespace mrsns::igtlink {
class Server;
}

namespace mrsns::workflow {

/// Which tracker to use: "simulated" (the default: patient, probe, stylus
/// and robot flange markers with tremor and noise), "plus" (a PlusServer or
/// any OpenIGTLink server at host:port) or "playback" (a PLUS sequence file).
struct DeviceOptions {
  std::string source = "simulated";
  std::string host = "127.0.0.1";
  int port = 18944;
  std::filesystem::path file;  ///< playback
  double playback_speed = 1.0;
  std::uint64_t seed = 1;
  double rate_hz = 60.0;
  double noise_mm = 0.25;
  /// Simulated tracker loss: `dropout_tool` invisible from dropout_start_s
  /// for dropout_duration_s (negative start: none).
  std::string dropout_tool = "PatientToTracker";
  double dropout_start_s = -1.0;
  double dropout_duration_s = 0.0;
};

/// The tools the simulated tracker reports.
std::vector<std::string> simulatedToolNames();

/// Builds the source `options` asks for. Throws InvalidArgumentError for an
/// unknown source or bad options, FileError for a missing playback file.
std::unique_ptr<tracking::TrackingSource> makeTrackingSource(const DeviceOptions& options,
                                                             std::shared_ptr<TransformRepository> repository);

struct NavigationOptions {
  DeviceOptions devices;
  /// Tracking stream recording (.mhd + .raw, crash-safe); empty: none.
  std::filesystem::path recording;
  double sync_interval_s = 0.5;
  /// Transforms the supervisor needs Ok while the robot moves: losing one
  /// stops the robot.
  std::vector<std::string> required_transforms = {"PatientToTracker", "ProbeToTracker"};
  /// No tracking batch for this long also stops the robot (tracker silent).
  double silence_timeout_s = 0.25;
  /// Stream holograms to HMD clients on 127.0.0.1:hologram_port (0 picks a
  /// free port) when models are given.
  bool stream_holograms = false;
  int hologram_port = 0;
  /// The scene callback runs at most this often.
  double scene_rate_hz = 30.0;
};

struct NavigationEvent {
  double time_s = 0.0;  ///< since start()
  std::string kind;     ///< "safety-stop", "tracking-restored", "recorder-error", "source"
  std::string message;
};

struct NavigationStatus {
  bool running = false;
  std::uint64_t batches = 0;
  std::uint64_t frames_recorded = 0;
  std::uint64_t frames_synced = 0;
  std::uint64_t scene_updates = 0;
  std::uint64_t deformation_updates = 0;
  std::uint64_t hologram_updates = 0;
  std::uint16_t hologram_port = 0;
  bool robot_stopped = false;
  std::string stop_reason;
  std::string recorder_error;
  tracking::SourceStatus source;
  double max_batch_gap_s = 0.0;
  double mean_loop_latency_ms = 0.0;  ///< batch arrival -> processed (record, supervise, stream)
};

class NavigationLoop {
 public:
  using SceneCallback = std::function<void(const TransformRepository&)>;
  using DeformationHook = std::function<void(const TransformRepository&, double time_s)>;
  using StopHandler = std::function<void(const std::string& reason)>;

  /// Builds the source and the recorder. Throws like makeTrackingSource and
  /// SequenceAppender.
  explicit NavigationLoop(NavigationOptions options, std::vector<tracking::HologramModel> models = {});
  ~NavigationLoop();
  NavigationLoop(const NavigationLoop&) = delete;
  NavigationLoop& operator=(const NavigationLoop&) = delete;

  /// Set before start(). Each runs on the loop thread and must not throw
  /// (an exception is caught and reported as an event).
  void setSceneCallback(SceneCallback callback);
  void setDeformationHook(DeformationHook hook);
  /// Called once when the supervisor stops the robot, with the reason.
  void setStopHandler(StopHandler handler);
  /// Persistent edges (calibrations, registration) before start().
  [[nodiscard]] TransformRepository& repository() { return *repository_; }

  void start();
  /// Stops the source and the loop, syncs the recording. Idempotent.
  void stop();
  /// The robot may move again once the required transforms are Ok.
  void rearm();

  [[nodiscard]] NavigationStatus status() const;
  [[nodiscard]] std::vector<NavigationEvent> events() const;

 private:
  void run();
  void process(const std::vector<tracking::ToolUpdate>& batch, double now_s);
  void supervise(double now_s, bool silent);
  void addEvent(double t, const std::string& kind, const std::string& message);
  double elapsed() const;

  NavigationOptions options_;
  std::shared_ptr<TransformRepository> repository_;
  std::unique_ptr<tracking::TrackingSource> source_;
  std::unique_ptr<io::SequenceAppender> recorder_;
  std::unique_ptr<igtlink::Server> server_;
  std::unique_ptr<tracking::HologramStreamer> streamer_;
  SceneCallback scene_;
  DeformationHook deformation_;
  StopHandler stop_handler_;
  std::vector<TransformRepository::Query> required_;

  mutable std::mutex mutex_;  // guards queue_, events_, status_
  std::condition_variable wake_;
  std::deque<std::pair<std::vector<tracking::ToolUpdate>, double>> queue_;
  std::vector<NavigationEvent> events_;
  NavigationStatus status_;
  double latency_sum_ms_ = 0.0;
  double last_batch_s_ = -1.0;
  double last_scene_s_ = -1.0;
  std::atomic<bool> running_{false};
  std::thread thread_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace mrsns::workflow
