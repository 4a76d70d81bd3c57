#pragma once
// The scenario of a simulated operating room: the world (camera, patient,
// phantom, robot), the tools and what the virtual operator does with them,
// the devices' noise models, the faults on schedule, or a recording to
// replay. Read from JSON (format "mrsns-scenario/1", doc/README.md); every
// unknown key is refused, so a typo never silently falls back to a default.
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace mrsns::simulation {

/// Frames a scenario pose can be given in. Reference, Phantom and CT follow
/// the patient's reference marker as it moves.
enum class PoseFrame { Tracker, Reference, Phantom, CT, RobotBase };

/// What a motion segment's pose places: the tool's marker, (for the probe)
/// its image plane, from which the marker follows through the true
/// ImageToProbe, or (for a pointer) its tip: the pose's origin is where the
/// tool's `tip_mm` goes, its axes are the marker's.
enum class PoseOf { Tool, Image, Tip };

/// TouchLandmarks and TraceBone are what a surgeon does for a registration;
/// the world expands them into holds and moves of the tool's tip once it
/// knows the patient (its fiducials, its bone surface).
enum class MotionKind { Hold, Move, Sweep, Pivot, Spin, UpDown, TouchLandmarks, TraceBone };

/// A landmark touched at the wrong place (a fault of a registration).
struct MisplacedTouch {
  int landmark = 1;  ///< 1-based, in the order touched
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  ///< mm, in the segment's frame
};

/// One step of the virtual operator's timeline for one tool.
struct MotionSegment {
  MotionKind kind = MotionKind::Hold;
  double duration_s = 1.0;
  PoseFrame frame = PoseFrame::Tracker;
  PoseOf pose_of = PoseOf::Tool;
  /// hold: where; move: target (minimum-jerk from the previous pose);
  /// sweep: the far end (back and forth from the previous pose).
  std::optional<Eigen::Isometry3d> pose;
  int cycles = 1;  ///< sweep: round trips
  /// pivot: the tip that stays put (tool frame); absent: the tool's tip_mm.
  std::optional<Eigen::Vector3d> tip_tool;
  double amplitude_deg = 20.0;                           ///< pivot: swing; spin: turn each way about the shaft
  double frequency_hz = 0.25;                            ///< pivot, spin and up_down
  bool one_axis = false;                                 ///< pivot about one axis only (a degenerate acquisition)
  double amplitude_mm = 10.0;                            ///< up_down
  Eigen::Vector3d axis_tool = Eigen::Vector3d::UnitZ();  ///< up_down direction (tool frame)
  /// touch_landmarks: the points touched in order (mm, in `frame`: CT or Phantom); empty: the patient's
  /// fiducials (CT) or the N-wire phantom definition's landmarks (Phantom).
  std::vector<Eigen::Vector3d> points;
  /// touch_landmarks, per landmark: travel_s to approach_mm above it along the tool's axis, 0.5 s down,
  /// dwell_s held on it, 0.5 s up.
  double travel_s = 1.5;
  double dwell_s = 2.0;
  double approach_mm = 20.0;
  std::vector<MisplacedTouch> misplaced;
  /// trace_bone: points of the exposed (posterior) bone surface under the landmarks' extent, visited in a
  /// serpentine over duration_s.
  int trace_points = 80;
  double trace_margin_mm = 5.0;  ///< the traced area extends this far beyond the landmarks
};

/// The operator's hand (paper 001 §II.C: physiological tremor 8-12 Hz).
struct HandModel {
  double tremor_rms_mm = 0.0;
  double tremor_min_hz = 8.0;
  double tremor_max_hz = 12.0;
  double tremor_rotation_rms_deg = 0.0;
  double drift_mm = 0.0;  ///< slow wander amplitude
  double drift_hz = 0.05;
  double slips_per_min = 0.0;  ///< sudden displacements that the hand corrects in ~0.5 s
  double slip_mm = 2.0;
  /// SD of how long each hold lasts around its scripted duration (s): people do not count.
  double dwell_jitter_s = 0.0;
  /// SD of the depth error at each target of a hold or move (mm, along the tool's z axis): where the operator
  /// believes the tip touches.
  double depth_misperception_mm = 0.0;
};

struct ToolSpec {
  std::string name;  ///< PLUS transform name, "StylusToTracker"
  /// Radius of the marker's footprint for line-of-sight tests (mm).
  double marker_radius_mm = 25.0;
  /// Where the pose starts (before the first segment), in `start_frame`.
  Eigen::Isometry3d start = Eigen::Isometry3d::Identity();
  PoseFrame start_frame = PoseFrame::Tracker;
  std::vector<MotionSegment> motion;
  HandModel hand;
  /// Tool tip in marker coordinates (truth, for scoring pivot calibration).
  std::optional<Eigen::Vector3d> tip_tool;
  /// The shaft's direction in marker coordinates, towards the tip (truth, for scoring spin calibration): what a
  /// spin turns the tool about. Absent: from the marker's origin to the tip (a marker on the shaft's line).
  std::optional<Eigen::Vector3d> shaft_tool;
  [[nodiscard]] Eigen::Vector3d shaft() const {
    if (shaft_tool) return *shaft_tool;
    return tip_tool && tip_tool->norm() > 0.0 ? Eigen::Vector3d(tip_tool->normalized()) : Eigen::Vector3d::UnitZ();
  }
};

/// A sphere that blocks the camera's view (the operator's head or hand).
/// Attached to a tool it moves with it (offset in that tool's frame).
struct Occluder {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  double radius_mm = 80.0;
  std::string attached_to;  ///< tool name, or empty (fixed in the tracker frame)
};

/// An optical tracker's measurement volume: a frustum along -z of the
/// tracker frame (NDI convention: the volume lies at negative z).
struct MeasurementVolume {
  double near_mm = 950.0;
  double far_mm = 2400.0;
  double half_angle_x_deg = 18.0;
  double half_angle_y_deg = 15.5;
};

/// Per-sample measurement noise of the tracker (datasheet figures).
struct TrackerNoise {
  double position_rms_mm = 0.12;  ///< 3D RMS (Polaris Vega: 0.12 mm RMS in its pyramid volume)
  double orientation_rms_deg = 0.05;
};

struct TrackerSpec {
  std::string bind_address = "127.0.0.1";
  std::uint16_t port = 18944;  ///< 0: a free port (reported when ready)
  double rate_hz = 60.0;
  /// Highest header version spoken; a client gets v1 until it sends a v2 message (PlusServer's rule).
  int max_header_version = 2;
  /// PlusServer's SendValidTransformsOnly: invalid tools are not sent at all; false sends them to v2
  /// clients with TransformStatus metadata.
  bool send_valid_transforms_only = true;
  TrackerNoise noise;
  MeasurementVolume volume;
  std::vector<Occluder> occluders;
};

/// The N-wire calibration phantom in its water bath.
struct NWirePhantomSpec {
  std::filesystem::path config;                       ///< PLUS device set with a PhantomDefinition
  std::string reference_tool = "ReferenceToTracker";  ///< the marker the phantom is fixed to
  Eigen::Isometry3d reference_T_phantom = Eigen::Isometry3d::Identity();
  double wire_radius_mm = 0.25;
  double bath_margin_mm = 30.0;  ///< the bath extends this far beyond the wires
};

/// A flat target at the bottom of a water tank, for the temporal calibration:
/// a plate whose top face is the plane z = 0 of `pose` (normal +z, towards
/// the probe), `half_size_mm` across, 10 mm thick, with water above it.
struct FlatTargetSpec {
  PoseFrame frame = PoseFrame::Tracker;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  Eigen::Vector2d half_size_mm = Eigen::Vector2d(100.0, 100.0);
  double water_depth_mm = 80.0;
};

/// The critical soft tissue (the vessel) as a statistical shape model whose
/// shape changes over time: the first `modes` coefficients follow seeded
/// sinusoids of `amplitude_sd` standard deviations around the mean, each with
/// a period of `period_s` times a factor drawn in [0.7, 1.3]. It replaces the
/// generated phantom's straight vessel or the label map's vessel labels.
/// A push (a retractor, the drill's pressure on nearby tissue) adds
/// `push_sd` (standard deviations per mode) to the coefficients, ramped in
/// smoothly over `push_ramp_s` from `push_start_s` and held.
struct SoftTissueSpec {
  std::filesystem::path shape_model;  ///< statismo .h5 (io::readStatismoModel)
  Eigen::Isometry3d ct_T_model = Eigen::Isometry3d::Identity();
  int modes = 3;
  double amplitude_sd = 1.0;
  double period_s = 20.0;
  std::vector<double> push_sd;  ///< empty: no push
  double push_start_s = 0.0;
  double push_ramp_s = 1.0;
};

/// The patient: the generated cervical phantom, or a CT's label map.
struct PatientSpec {
  bool generated = true;
  double phantom_spacing_mm = 0.8;
  std::filesystem::path labels;     ///< label map (any label != 0 is bone unless listed below)
  std::vector<int> vessel_labels;   ///< labels that are vessel lumen, not bone
  std::vector<int> ignored_labels;  ///< labels that are neither
  std::string reference_tool = "ReferenceToTracker";
  /// Where the CT sits relative to the reference marker (the truth a registration estimates).
  Eigen::Isometry3d reference_T_ct = Eigen::Isometry3d::Identity();
  std::optional<SoftTissueSpec> soft_tissue;
};

struct UltrasoundSpec {
  bool enabled = false;
  double rate_hz = 25.0;
  int width = 640;
  int height = 480;
  double spacing_x_mm = 0.1;
  double spacing_y_mm = 0.1;
  std::string probe_tool = "ProbeToTracker";
  /// Image pixels (mm, MF) -> probe marker (the truth a spatial calibration estimates).
  Eigen::Isometry3d probe_T_image = Eigen::Isometry3d::Identity();
  /// The video shows the world as it was this long before its timestamp (truth of temporal calibration).
  double video_lag_s = 0.0;
  /// PLUS device name of the IMAGE messages; the image is placed in the frame after "Image_" (PlusServer's
  /// Image_Reference) by the ImageToProbe the scenario declares as known to the server, or in its own frame.
  std::string device_name = "Image_Image";
  double attenuation_db_per_cm = 1.0;
  double speckle = 1.0;  ///< 0 disables speckle
};

struct RobotSpec {
  bool enabled = false;
  std::uint16_t rtde_port = 30004;
  std::uint16_t dashboard_port = 29999;
  std::uint16_t secondary_port = 30002;
  std::uint16_t realtime_port = 30003;
  Eigen::Isometry3d tracker_T_base = Eigen::Isometry3d::Identity();
  /// The tracked marker on the flange (truth of MarkerToFlange) and the drill tip in flange coordinates.
  Eigen::Isometry3d flange_T_marker = Eigen::Isometry3d::Identity();
  Eigen::Vector3d drill_tip_flange = Eigen::Vector3d(0.0, 0.0, 150.0);
  std::string marker_tool = "FlangeToTracker";
  std::array<double, 6> start_joints{0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0};
  /// The controller's safety configuration narrowing a joint's range (rad): a servo target beyond it is refused
  /// and the arm stays where it was (a station the arm cannot reach). Unset: the UR5's own +/-360 deg.
  std::array<std::optional<std::pair<double, double>>, 6> joint_limits{};
  /// The controller loses this many of the first stop commands it is sent (a fault: the workstation must
  /// repeat its stop until the arm is at rest).
  int stops_lost = 0;
  /// The operator guiding the arm by hand (freedrive). Each waypoint starts at `at_s` (the hand takes the arm
  /// from wherever it stands then) or, without it, where the previous one ended (the first at 0 from the start
  /// joints). A waypoint is either joints (rad) reached with a minimum-jerk profile over its duration, or a
  /// pivot of the drill about its tip held in a divot: the drill's axis circles a cone of `pivot_deg` half-angle
  /// `pivot_cycles` times over the duration (ramped in over the first quarter turn and out over the last),
  /// back to where it began; or a spin of the drill about its axis (the line from the flange to its tip). While guided, the arm follows the hand, not the controller's commands; after the
  /// waypoint the controller has it again.
  struct GuidedWaypoint {
    std::optional<double> at_s;
    std::array<double, 6> joints{};
    double pivot_deg = 0.0;  ///< > 0: a drill pivot (joints unused)
    int pivot_cycles = 2;
    /// > 0: the drill turned back and forth this far about its own axis, its tip held in the divot (a spin
    /// calibration; joints unused), `spin_cycles` times over the duration.
    double spin_deg = 0.0;
    int spin_cycles = 1;
    double duration_s = 1.0;
  };
  std::vector<GuidedWaypoint> hand_guided;
};

/// The emulated headset: a client of the workstation's hologram stream.
/// The operator's answer to a prompt the workstation sends to the headset:
/// when a prompt containing `prompt_contains` arrives, the headset sends the
/// confirmation `confirm` `after_s` later (the time to do what was asked).
struct HmdResponse {
  std::string prompt_contains;
  double after_s = 2.0;
  std::string confirm;
};

/// A confirmation the operator gives on the scenario's timeline.
struct HmdConfirmation {
  double at_s = 0.0;
  std::string confirm;
};

/// Where the operator's eyes are for one view of the HMD calibration (paper 001 §II.C.2: front, left,
/// right, ground), relative to the cube's hologram in the tracker frame. The depth misperception lies
/// along the line from the eyes to the cube.
struct CubeView {
  std::string name;
  Eigen::Vector3d eye_from_cube_mm = Eigen::Vector3d(0.0, 0.0, 500.0);
};

/// The operator of the HMD calibration: when the workstation asks (a prompt containing `prompt_contains`,
/// naming a view), the operator takes the tracked cube from where it rests, lines it up with the cube's
/// hologram as the headset displays it, holds it there with hand tremor, confirms on the headset after
/// `confirm_after_s` and keeps holding for `hold_s` before putting it back. The hologram's mesh is in the
/// cube marker's frame (the workstation's cube definition), so the marker goes where that frame is shown,
/// missed by the operator's perception of a hologram: a depth error along the view (a per-operator bias and
/// a per-match error), a lateral error and a small rotation. Defaults: hmd::CubeNoiseModel (paper 001's
/// HoloLens 2 situation). Needs a tracked headset (`marker_tool`): what is displayed where is its truth.
struct CubeOperatorSpec {
  bool enabled = false;
  std::string tool = "CubeToTracker";        ///< a scenario tool: where the cube rests when not held
  std::string hologram = "CalibrationCube";  ///< the hologram's device name on the stream
  std::string prompt_contains = "line up the cube";
  std::string confirm = "aligned";  ///< the confirmation's text
  /// False: the operator confirms with the workstation's foot pedal instead (which the room cannot press:
  /// a test does), so the headset sends nothing.
  bool confirm_on_headset = true;
  double align_s = 3.0;             ///< from the prompt to the cube on its hologram
  double confirm_after_s = 0.5;
  double hold_s = 4.0;  ///< held this long after confirming
  std::vector<CubeView> views;
  double depth_bias_mm = 1.5;
  double depth_error_mm = 1.0;
  double lateral_error_mm = 0.5;  ///< per axis across the view
  double rotation_deg = 0.3;      ///< per axis
  double tremor_mm = 0.5;         ///< per axis, sinusoid amplitude
  double tremor_min_hz = 8.0;
  double tremor_max_hz = 12.0;
  double tremor_rotation_deg = 0.1;
  double drift_mm_per_s = 0.25;  ///< slow drift during a hold, random direction
  double jerks_per_s = 1.0;      ///< sudden slips of the hand (Poisson)
  double jerk_min_mm = 2.0;
  double jerk_max_mm = 4.0;
  double jerk_duration_s = 0.05;
};

/// The headset's photo-video camera and its wearer, for paper 000's checkerboard hand-eye calibration: when
/// the workstation asks (a prompt containing `prompt_contains` and "view K of N"), the wearer walks to a view of
/// the tracked checkerboard (the camera 0.5-1.2 m from its centre, up to `max_tilt_deg` off its normal, rolled
/// up to `max_roll_deg`, the board whole in the image and the headset's marker in the tracker's volume), holds
/// the head still for `settle_s` with a slow sway, and the headset sends a photo (IMAGE "HmdCamera", rendered
/// by hmd::renderCheckerboard through the camera's distortion, with blur and sensor noise) and, in header v2,
/// its intrinsics as the device reports them (the factory calibration: the true ones off by a seeded
/// `intrinsics_focal_error_percent` and `intrinsics_principal_error_px`). The truth the calibration estimates
/// is `camera_to_marker` (the camera in the headset marker's frame); the printed pattern sits at
/// `grid_to_board` on the board's marker (what the board's CAD states, up to the print's placement).
struct HeadsetCameraSpec {
  bool enabled = false;
  Eigen::Isometry3d marker_T_camera = Eigen::Isometry3d::Identity();
  double fx = 1000.0, fy = 1000.0, cx = 640.0, cy = 360.0;
  std::array<double, 5> distortion{-0.05, 0.02, 0.0, 0.0, 0.0};
  int width = 1280, height = 720;
  bool send_intrinsics = true;
  double intrinsics_focal_error_percent = 0.3;
  double intrinsics_principal_error_px = 2.0;
  std::string board_tool = "BoardToTracker";
  int rows = 3, cols = 5;
  double square_mm = 40.0;
  Eigen::Isometry3d board_T_grid = Eigen::Isometry3d::Identity();
  std::string prompt_contains = "checkerboard";
  double move_s = 2.0;
  double settle_s = 1.0;
  double min_distance_mm = 500.0, max_distance_mm = 1200.0;
  double max_tilt_deg = 30.0, max_roll_deg = 20.0;
  double head_sway_mm = 0.2;  ///< per axis, a slow (0.3-0.7 Hz) sway of the head while it holds
  double blur_sigma_px = 0.7, noise_sigma = 2.0;
};

/// The operator digitising the tracked checkerboard's corners with the stylus (paper 000 §2.3), reading the
/// workstation's prompts on the headset: on one containing `prompt_contains` and "corner K of N" the stylus
/// (`tool`, keeping the orientation it rests in) goes in `travel_s` to `approach_mm` above corner K (the board of
/// `camera`: its marker, pattern and `grid_to_board`), down in `down_s`, and holds the tip on it for `dwell_s`
/// (placed `placement_error_mm` 3D RMS off the corner, with a tremor of `tremor_mm` per axis at 8-12 Hz), then
/// lifts back; any other prompt sends it back to where it rests. Needs `camera` and a tool with `tip_mm`.
struct BoardTouchSpec {
  bool enabled = false;
  std::string tool = "StylusToTracker";
  std::string prompt_contains = "touch corner";
  double travel_s = 1.2;
  double down_s = 0.4;
  double dwell_s = 1.6;
  double approach_mm = 20.0;
  double placement_error_mm = 0.25;
  double tremor_mm = 0.1;
  /// Corners touched at the wrong place the first time they are asked for (a fault): 1-based corner, offset in
  /// the board marker's frame (mm). Asked again, the operator touches it right.
  struct Misplaced {
    int corner = 1;
    Eigen::Vector3d offset_mm = Eigen::Vector3d::Zero();
  };
  std::vector<Misplaced> misplaced;
};

struct HmdSpec {
  CubeOperatorSpec cube;
  HeadsetCameraSpec camera;
  BoardTouchSpec board_touch;
  /// The headset's tracked marker (a scenario tool, e.g. HeadsetToTracker): the headset's world frame is
  /// anchored where the marker is when the room starts, at `world_to_marker` from it (the truth an HMD
  /// calibration estimates). Empty: the headset is not tracked.
  std::string marker_tool;
  Eigen::Isometry3d marker_T_world = Eigen::Isometry3d::Identity();
  std::vector<HmdResponse> responses;
  std::vector<HmdConfirmation> confirmations;
  bool enabled = false;
  std::string host = "127.0.0.1";
  std::uint16_t port = 18945;  ///< the workstation's hologram stream (`mrsns-cli serve`, the GUI's stream)
  bool unity = false;          ///< the stream is in the Unity convention
  double drift_mm_per_min = 0.0;
  double jitter_mm = 0.0;
};

enum class FaultKind { Occlusion, TrackerDisconnect, PatientShift, VideoFreeze, RobotProtectiveStop, HmdDisconnect };

struct Fault {
  FaultKind kind = FaultKind::Occlusion;
  double at_s = 0.0;
  double duration_s = 0.0;  ///< occlusion, tracker_disconnect, video_freeze, hmd_disconnect
  std::string tool;         ///< occlusion
  /// patient_shift: applied to the patient (and, unless relative_to_reference, to its reference marker).
  Eigen::Isometry3d shift = Eigen::Isometry3d::Identity();
  bool relative_to_reference = false;
};

struct ReplaySpec {
  std::filesystem::path sequence;  ///< PLUS sequence (.mha/.mhd/.nrrd) with transforms and optionally images
  double speed = 1.0;
  bool loop = false;
  /// Start the recording when the first client connects (so it misses no frame), not when the room starts.
  bool wait_for_client = false;
};

struct Scenario {
  std::string name = "unnamed";
  std::filesystem::path source;  ///< the file it was read from (for messages)
  std::uint64_t seed = 1;
  double duration_s = 0.0;  ///< 0: until stopped
  TrackerSpec tracker;
  std::vector<ToolSpec> tools;
  std::optional<NWirePhantomSpec> nwire_phantom;
  std::optional<FlatTargetSpec> flat_target;
  std::optional<PatientSpec> patient;
  UltrasoundSpec ultrasound;
  RobotSpec robot;
  HmdSpec hmd;
  std::vector<Fault> faults;
  std::optional<ReplaySpec> replay;
};

/// Parses a scenario. Relative paths resolve against `base_dir`; "data:x/y"
/// against the shared data directory (MRSNS_DATA_DIR). Throws
/// FormatError naming the key path ("tools[2].motion[0].kind") for unknown
/// keys, wrong types or values out of range, FileError for missing files.
[[nodiscard]] Scenario parseScenario(const std::string& json_text, const std::filesystem::path& base_dir,
                                     const std::string& source = "scenario");
/// Reads and parses a scenario file.
[[nodiscard]] Scenario readScenario(const std::filesystem::path& path);

[[nodiscard]] const char* toString(FaultKind kind);
[[nodiscard]] const char* toString(PoseFrame frame);

}  // namespace mrsns::simulation
