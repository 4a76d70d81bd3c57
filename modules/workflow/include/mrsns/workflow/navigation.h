#pragma once
// The navigation loop of paper 001 (Fig. 3): tracking -> transform
// repository -> deformation -> safety supervisor -> hologram stream ->
// scene, on its own threads, every tracking batch recorded crash-safe to a
// PLUS sequence. Real time: nothing here throws once started; problems
// become events and status.
#include <Eigen/Geometry>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "mrsns/core/mesh.h"
#include "mrsns/core/plane_intersection.h"
#include "mrsns/core/transform_repository.h"
#include "mrsns/registration/screw_path.h"
#include "mrsns/tracking/hologram_streamer.h"
#include "mrsns/tracking/tracking_source.h"

namespace mrsns::igtlink {
class Server;
}

namespace mrsns::webxr {
class WebXrHologramService;
struct WebXrServiceOptions;
}  // namespace mrsns::webxr

namespace mrsns::workflow {

namespace detail {
class LiveSoftTissue;
class NavigationRobot;
class VideoRecorder;
class TrackingRecorder;
}  // namespace detail

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

/// A 30 mm path 60 mm in front of the patient reference (plan frame = patient frame): what the robot follows
/// when no plan is given.
registration::ScrewPath defaultNavigationPlan();

/// The robot in the loop (paper 001 Fig. 3: tracking -> supervisor -> robot). With "simulated" the loop owns a
/// robot::SimulatedArm, a robot::ControlLoop and its robot::SafetySupervisor, ticked at control_rate_hz on
/// their own thread; every tracking batch feeds the supervisor's tracking inputs, so a lost, stale or
/// disconnected tracker stops the arm through the supervisor (see doc/README.md, "The robot in the loop").
///
/// With "ur" the loop drives a UR controller (a real one, or robot::UrSimulator) through robot::UrRtdeArm: RTDE
/// state, URScript commands on the real-time interface, the dashboard for unlocking. It connects in the
/// NavigationLoop constructor (NetworkError naming host:port before any thread starts); a connection lost
/// while running is a supervisor stop (RobotDisconnected), never a throw. The base is where the robot stands:
/// tracker_T_robot_base (RobotBaseToTracker, the robot calibration) is required.
struct NavigationRobotOptions {
  std::string robot = "none";  ///< "none" | "simulated" | "ur"
  /// The planned path in the plan (CT) frame and the registration plan -> patient reference.
  registration::ScrewPath plan = defaultNavigationPlan();
  Eigen::Isometry3d patient_T_plan = Eigen::Isometry3d::Identity();
  std::string patient_transform = "PatientToTracker";
  /// The drill marker on the robot flange. The simulated robot's marker is seen by the loop on the
  /// simulated arm, in every tracking batch, with the batch's timestamp (and recorded with it).
  std::string tool_transform = "DrillToTracker";
  double control_rate_hz = 500.0;
  /// Enable the supervisor and start the placement (approach, align, advance) once tracking is good.
  bool auto_start = true;
  double advance_speed_mm_s = 5.0;
  /// Watchdog of the control thread. The supervisor's own defaults (2 ms, 2 missed cycles) assume a
  /// real-time kernel; a shared desktop misses cycles under load, and the UR controller stops the arm
  /// itself when servoJ targets stop arriving, so the loop allows more by default.
  double max_cycle_time_s = 0.02;
  std::uint64_t max_missed_cycles = 25;

  // robot "ur": the controller's address and ports (UR defaults, as robot::UrRtdeArmOptions has them).
  std::string ur_host = "127.0.0.1";
  int ur_rtde_port = 30004;
  int ur_script_port = 30003;
  int ur_dashboard_port = 29999;
  double ur_connect_timeout_s = 2.0;
  /// robot "ur": a controller silent this long counts as disconnected (and its cycle counter as stalled). RTDE
  /// streams at the control rate; a loaded desktop delays packages by a few periods, a closed socket is seen at
  /// once whatever this says.
  double ur_silence_s = 0.05;
  /// robot "ur": where the robot base stands in the tracker frame (RobotBaseToTracker, the robot calibration).
  /// Required with "ur"; the simulated arm is docked at the patient instead.
  std::optional<Eigen::Isometry3d> tracker_T_robot_base;
  /// robot "ur": true: the loop computes the drill marker from the arm's reported pose as the tracker would see
  /// it (a simulated tracker, which has no arm to see); false: the tracker reports tool_transform itself.
  bool simulate_drill_marker = true;
  /// The drill on the flange: its marker's mounting (MarkerToFlange, the robot calibration) and its tip (the
  /// drill calibration's tip, the drill's axis along the flange's z: a pivot finds the tip, not the axis).
  /// Set from the session when a UR is driven with a PlusServer's tracking (required then); otherwise the
  /// simulated drill of the robot module's test scene.
  std::optional<Eigen::Isometry3d> flange_T_marker;
  std::optional<Eigen::Isometry3d> flange_T_tip;
  /// The drill (tip and shaft) keeps this far from the soft tissue (NavigationOptions::soft_tissue), plus
  /// soft_tissue_margin_sd standard deviations of the posterior surface where it is nearest.
  double soft_tissue_margin_mm = 2.0;
  double soft_tissue_margin_sd = 2.0;
  /// The shaft checked behind the tip; negative: from the tip back to the flange (|flange_T_tip|).
  double drill_shaft_length_mm = -1.0;
};

/// The soft tissue followed on the source's live ultrasound (paper 001 Algorithm 1): every frame the source
/// delivers is placed in the CT by Eq. 4 (CT <- patient <- tracker <- probe at the frame's time, with the
/// temporal calibration, <- image by the spatial calibration), its lumen segmented from the current shape's
/// contours, and the posterior shape model updated. The posterior near the planned paths, with its standard
/// deviation, is what the robot's supervisor keeps the drill away from. Off while shape_model is empty.
/// Nothing here throws once navigation runs: a frame, a calibration or a model that does not fit is refused
/// with a message (NavigationStatus::soft_tissue) and navigation goes on without the deformation.
struct SoftTissueOptions {
  std::filesystem::path shape_model;  ///< statismo .h5 (the session's soft-tissue model)
  Eigen::Isometry3d ct_T_model = Eigen::Isometry3d::Identity();
  /// The CT's extent (CT frame, mm): a model whose mean shape lies mostly outside it is in another frame
  /// and is refused. Unset: not checked.
  std::optional<Eigen::AlignedBox3d> ct_bounds;
  /// The registration CT -> patient reference (CTToPatient).
  Eigen::Isometry3d patient_T_ct = Eigen::Isometry3d::Identity();
  std::string patient_transform = "PatientToTracker";
  std::string probe_transform = "ProbeToTracker";
  /// ImageToProbe of the spatial calibration: pixel (i, j, 0, 1) -> probe mm (the pixel spacing included).
  Eigen::Matrix4d probe_T_pixel = Eigen::Matrix4d::Identity();
  /// The calibration's frame size: frames of another size are refused (0: not checked).
  int image_width = 0;
  int image_height = 0;
  /// The probe the calibration was made with (its transform name); a source whose probe is named otherwise
  /// is refused. Empty: not checked.
  std::string calibrated_probe;
  /// PLUS's TrackerLagSec (the temporal calibration): the tracker stamps the instant a frame shows at the
  /// frame's time + lag.
  double tracker_lag_s = 0.0;
  /// Observation noise sigma of the posterior (mm): segmentation, calibration and tracking together.
  double observation_sd_mm = 1.0;
  /// Observations not renewed within this many frames are forgotten (ShapeTrackerOptions::
  /// max_observation_age_frames): the tissue moves while it is imaged. 0 keeps them all (the paper).
  int observation_lifetime_frames = 20;
  /// Vertices within this distance (of the prior mean) of a planned path are handed to the supervisor.
  double supervisor_radius_mm = 40.0;
  /// The hologram stream's model showing the soft tissue (the shape model's mean, the same vertices in the
  /// same order, CT frame): its vertices are moved on the headsets (NDARRAY vertex updates, at most 5 a
  /// second). Empty: the headsets see the mean.
  std::string hologram_model;
};

/// Where the simulated cart is wheeled (tracker_T_robot_base, i.e. RobotBaseToTracker): the planned entry
/// 45 mm in front of the drill tip of an arm at base_T_flange, the planned direction a few degrees off the
/// drill's. The simulated arm docks so; tests and simulations use it as the robot calibration of a UR arm
/// that can reach the plan.
Eigen::Isometry3d simulatedDocking(const NavigationRobotOptions& options, const Eigen::Isometry3d& tracker_T_patient,
                                   const Eigen::Isometry3d& base_T_flange);

/// One transition of the robot's safety supervisor (robot::TransitionRecord as text).
struct NavigationRobotTransition {
  std::uint64_t cycle = 0;
  double time_s = 0.0;  ///< loop clock (since start())
  std::string from, to, reason, command, detail;
  std::string tracking;  ///< for a stop: what the workflow saw lost ("tracking lost: PatientToTracker INVALID")
};

struct NavigationOptions {
  DeviceOptions devices;
  NavigationRobotOptions robot;
  SoftTissueOptions soft_tissue;
  /// Tracking stream recording (.mhd + .raw, crash-safe); empty: none.
  std::filesystem::path recording;
  /// The ultrasound video the source delivers (PlusServer IMAGE messages, a playback with images), recorded
  /// crash-safe (.mhd + .raw, every frame with its ImageTo<Frame> matrix) on its own thread. Empty: beside
  /// `recording` as <stem>_video.mhd (none without a recording). The file appears with the first frame.
  std::filesystem::path video_recording;
  double sync_interval_s = 0.5;
  /// Transforms the supervisor needs Ok while the robot moves: losing one
  /// stops the robot.
  std::vector<std::string> required_transforms = {"PatientToTracker", "ProbeToTracker"};
  /// No tracking batch for this long also stops the robot (tracker silent). With a robot this is the
  /// supervisor's max_tracking_age_s: a pose older than this is stale.
  double silence_timeout_s = 0.25;
  /// Stream holograms to HMD clients on 127.0.0.1:hologram_port (0 picks a
  /// free port) when models are given.
  bool stream_holograms = false;
  int hologram_port = 0;
  /// Where the hologram server listens: the local machine unless the user
  /// names an interface (an HMD on the network).
  std::string hologram_address = "127.0.0.1";
  /// Tracked transforms also streamed under their own names ("StylusToTracker"), so a client sees the
  /// tools move before an HMD calibration places the models (HologramStreamOptions::forward_transforms).
  std::vector<std::string> hologram_forward_transforms;
  /// The headset client the stream is set up for (tracking::hologramClientPresets(): "slicer",
  /// "openigtlink-unity", "hololens2-pedicle", "unity-metres").
  std::string hologram_client = "slicer";
  /// The scene callback runs at most this often.
  double scene_rate_hz = 30.0;
};

/// The posterior at one frame, for the record (scored from outside against the truth).
struct SoftTissueSample {
  double timestamp = 0.0;  ///< the frame's time (the source's clock)
  Eigen::VectorXd coefficients;
  int observations = 0;
  int contours = 0;
  /// The frame's arrival from the source -> this posterior's surface handed to the supervisor (or, without a
  /// robot, the posterior updated); the control loop installs it at its next cycle.
  double frame_to_margin_ms = 0.0;
};

/// The last frame used, for display: its pixels, where it lies and the lumens found in it.
struct LiveUltrasoundFrame {
  tracking::TrackedImage image;
  Eigen::Matrix4d ct_T_pixel = Eigen::Matrix4d::Identity();
  std::vector<Polyline3d> lumens_ct;  ///< segmentation outlines, CT mm
  std::uint64_t index = 0;            ///< 1, 2, ... (0: none yet)
};

/// One processed tracking batch: when it arrived (loop clock) and how long recording, supervising and
/// streaming it took.
struct NavigationLatencySample {
  double time_s = 0.0;
  double latency_ms = 0.0;
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
  std::uint64_t hologram_vertex_updates = 0;  ///< the soft tissue's vertices sent to the headsets (live soft tissue)
  std::uint16_t hologram_port = 0;   ///< 0: not streaming
  std::size_t hologram_clients = 0;  ///< clients that have the models and get the transforms
  bool operator_stopped = false;     ///< the last stop was the operator's (stopRobot), navigation goes on
  bool robot_stopped = false;
  std::string stop_reason;
  std::string recorder_error;
  /// The ultrasound video (NavigationOptions::video_recording): frames written, durable, not recorded.
  std::filesystem::path video_recording;  ///< empty until a frame has been written
  std::uint64_t video_frames_recorded = 0;
  std::uint64_t video_frames_synced = 0;
  std::uint64_t video_frames_dropped = 0;
  std::string video_error;
  /// The live soft tissue (NavigationOptions::soft_tissue): "off", "waiting for frames", "tracking", or
  /// "refused: <why>" (navigation goes on without the deformation).
  std::string soft_tissue = "off";
  std::uint64_t us_frames_received = 0;
  std::uint64_t us_frames_used = 0;     ///< segmented and given to the posterior
  std::uint64_t us_frames_skipped = 0;  ///< a newer frame came before this one was processed
  std::uint64_t us_frames_refused = 0;  ///< wrong size or format, no probe pose at the frame's time
  std::uint64_t us_frames_off_tissue = 0;  ///< the image plane does not cut the soft tissue
  std::uint64_t soft_tissue_updates = 0;   ///< posterior updates handed to the supervisor
  int soft_tissue_observations = 0;
  double soft_tissue_sd_max_mm = std::numeric_limits<double>::quiet_NaN();  ///< near the planned paths
  /// Frame arrival -> the supervisor's margin updated (or, without a robot, the posterior updated), last frame.
  double us_frame_to_margin_ms = std::numeric_limits<double>::quiet_NaN();
  tracking::SourceStatus source;
  double max_batch_gap_s = 0.0;
  double mean_loop_latency_ms = 0.0;  ///< batch arrival -> processed (record, supervise, stream)

  // The robot (NavigationOptions::robot); with "none" only `robot` is set.
  std::string robot = "none";
  bool robot_docked = false;     ///< the arm's base is placed (first patient sample; "ur": from the calibration)
  std::string supervisor_state;  ///< robot::SupervisorState name: "Ready", "Advancing", "Stopped", ...
  std::string supervisor_stop;   ///< robot::StopReason name of the current stop ("PatientNotTracked"), else empty
  std::string last_transition;   ///< "cycle 812 Advancing -> Stopped (PatientNotTracked: ...) StopJ"
  std::string guidance_phase;    ///< robot::GuidancePhase name
  std::uint64_t robot_cycles = 0;
  std::uint64_t robot_missed_cycles = 0;  ///< control cycles skipped by the real-time thread (load)
  double arm_speed_rad_s = 0.0;           ///< largest joint speed now
  double flange_speed_mm_s = 0.0;
  double depth_mm = 0.0;  ///< commanded drill depth past the entry
  std::uint64_t motion_commands = 0;
  std::uint64_t motion_commands_after_stop =
      0;  ///< motion commands the arm accepted while the supervisor was Stopped/Fault, counted at the arm (must stay 0)
  std::uint64_t robot_stops = 0;
  /// Last stop: from the first lost or stale tracking sample (its arrival on the loop clock; for a stale
  /// pose, the moment it became older than the limit; for a disconnection, when the loop saw it) to the
  /// stop command, in control cycles and ms; -1 / NaN before a stop.
  std::int64_t stop_latency_cycles = -1;
  double stop_latency_ms = std::numeric_limits<double>::quiet_NaN();
  /// Last stop: stop command -> every joint at rest (controller time); NaN until at rest.
  double time_to_stop_s = std::numeric_limits<double>::quiet_NaN();
  double stop_time_limit_s = 0.0;  ///< the arm's stopping-time limit
};

class NavigationLoop {
 public:
  using SceneCallback = std::function<void(const TransformRepository&)>;
  using DeformationHook = std::function<void(const TransformRepository&, double time_s)>;
  using StopHandler = std::function<void(const std::string& reason)>;

  /// Builds the source and the recorder. Throws like makeTrackingSource and
  /// io::SequenceAppender (the recording is created before the run starts).
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
  /// The robot may move again once the required transforms are Ok. With a robot: the supervisor's
  /// acknowledge (Stopped/Fault -> Ready), refused (false, with an event saying why) while tracking is
  /// still lost or the arm still moves. The robot then waits in Ready for startRobot().
  bool rearm();
  /// Starts (again) the placement along the plan: supervisor Ready -> Aligning. False without a robot,
  /// before docking, or when the supervisor refuses.
  bool startRobot();
  /// The operator's stop: the robot stops through its supervisor (robot::ControlLoop::pause, reason
  /// Operator: StopJ, the arm decelerates to rest and gets no motion command until re-armed) while tracking,
  /// recording, streaming and deformation go on. Without a robot it marks the stop, as a tracking stop does.
  /// False when the supervisor refused (already stopped) or the control loop did not answer.
  bool stopRobot(const std::string& reason);
  /// Serves `models` (and hologram_forward_transforms) from this loop's repository on
  /// options.hologram_address:port (0: a free port) while the loop runs; replaces a running stream.
  /// `client` names the headset client's preset (empty: options.hologram_client). Returns the port. Throws
  /// like igtlink::Server (port in use), HologramStreamer (bad models, more than the client can show) and
  /// tracking::hologramClientPreset (unknown client).
  std::uint16_t streamHolograms(std::vector<tracking::HologramModel> models, int port, const std::string& client = {});
  /// Ends the hologram stream (clients are disconnected); navigation goes on. Idempotent.
  void stopHologramStream();
  /// Serves the WebXR hologram client (webxr::WebXrHologramService: its own stream of `models` from this
  /// loop's repository, the soft tissue's vertex updates included) while the loop runs; replaces a running
  /// one. Returns the service (owned by the loop until stopWebXr). Throws like WebXrHologramService.
  webxr::WebXrHologramService& serveWebXr(std::vector<tracking::HologramModel> models,
                                          webxr::WebXrServiceOptions options);
  /// Ends the WebXR service (pages disconnected, they reconnect when it comes back). Idempotent.
  void stopWebXr();
  /// Simulated tracker failure: stops the tracking source while the loop and the robot keep running.
  void killTracker();

  [[nodiscard]] NavigationStatus status() const;
  [[nodiscard]] std::vector<NavigationEvent> events() const;
  /// Every processed batch's loop latency (the step's and the GUI's latency plots).
  [[nodiscard]] std::vector<NavigationLatencySample> latencySeries() const;
  /// The supervisor's transition log (empty without a robot).
  [[nodiscard]] std::vector<NavigationRobotTransition> robotTransitions() const;
  /// The live soft tissue (NavigationOptions::soft_tissue): the posterior after every update, the last frame
  /// used with its segmentation, and the posterior mean mesh in the CT frame (null when off or refused).
  [[nodiscard]] std::vector<SoftTissueSample> softTissueSeries() const;
  /// What the source's device says it is (mrsns-sim answers a STATUS request; PlusServer says nothing).
  [[nodiscard]] std::string deviceIdentity() const;
  [[nodiscard]] std::optional<LiveUltrasoundFrame> liveUltrasound() const;
  [[nodiscard]] std::shared_ptr<const TriangleMesh> softTissueMesh() const;

 private:
  void run();
  void process(const std::vector<tracking::ToolUpdate>& batch, double now_s);
  void supervise(double now_s, bool silent);
  void feedRobot(double arrived_s, double timestamp);
  void pollRobot();
  void addEvent(double t, const std::string& kind, const std::string& message);
  double elapsed() const;

  NavigationOptions options_;
  std::shared_ptr<TransformRepository> repository_;
  std::unique_ptr<tracking::TrackingSource> source_;
  std::unique_ptr<detail::TrackingRecorder> recorder_;
  std::unique_ptr<detail::VideoRecorder> video_;
  std::unique_ptr<igtlink::Server> server_;
  std::unique_ptr<tracking::HologramStreamer> streamer_;
  std::unique_ptr<webxr::WebXrHologramService> web_;
  mutable std::mutex stream_mutex_;  // guards server_, streamer_, web_ (the GUI may start or end them any time)
  SceneCallback scene_;
  DeformationHook deformation_;
  StopHandler stop_handler_;
  std::vector<TransformRepository::Query> required_;
  std::unique_ptr<detail::NavigationRobot> robot_;
  std::unique_ptr<detail::LiveSoftTissue> soft_tissue_;
  std::atomic<std::uint64_t> hologram_vertex_updates_{0};
  std::atomic<bool> hologram_vertex_error_{false};
  TransformRepository::Query robot_tool_, robot_patient_;
  std::size_t robot_transitions_seen_ = 0;
  // Safety stops reported so far (guarded by mutex_): rearm() clears the stop
  // only if no new one came in while the supervisor acknowledged.
  std::uint64_t safety_stops_seen_ = 0;
  double drill_dropout_start_s_ = std::numeric_limits<double>::infinity();
  double drill_dropout_end_s_ = -std::numeric_limits<double>::infinity();

  mutable std::mutex mutex_;  // guards queue_, events_, status_
  std::condition_variable wake_;
  std::deque<std::pair<std::vector<tracking::ToolUpdate>, double>> queue_;
  std::vector<NavigationEvent> events_;
  NavigationStatus status_;
  double latency_sum_ms_ = 0.0;
  std::vector<NavigationLatencySample> latencies_;
  double last_batch_s_ = -1.0;
  double last_scene_s_ = -1.0;
  std::atomic<bool> running_{false};
  std::thread thread_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace mrsns::workflow
