#pragma once
// The HMD emulator: a stand-in for the HoloLens app, connected as an
// OpenIGTLink client to the workstation's hologram stream
// (tracking::HologramStreamer, `mrsns-cli serve`), as the headset would be.
//
// What it receives (header v1 or v2, whatever the stream sends):
//  - POLYDATA per model (device name = model name): the mesh it displays.
//  - TRANSFORM per model: hologram_T_model, the model's pose in the headset's
//    hologram (world) frame. A TRANSFORM shows the model (the stream sends
//    one only while the model's chain is Ok).
//  - STATUS per model: code Ok keeps it shown, any other code (the stream's
//    NotReady "TrackingLost") hides it until the next TRANSFORM.
//  - STRING: a prompt to the operator, kept in order (the last kMaxPrompts).
//    Any other message type is counted in other_messages and dropped.
// A connection drop hides every model (status "Disconnected"); the client
// reconnects by itself and the stream sends the meshes again.
//
// With `unity`, the stream is in the Unity convention (left-handed metres,
// tracking/unity_convention.h) and the emulator converts meshes and poses
// back to MR-SNS millimetres; everything it reports is in mm. A v2 POLYDATA
// whose "Units" metadata disagrees with that option is counted
// (convention_mismatches) and logged: the option is then wrong.
//
// The headset's own world frame drifts and jitters like a real headset's
// inside-out tracking (translation only):
//
//   world_T_model = headset_world_T_hologram(t) * hologram_T_model
//   headset_world_T_hologram(t) = translation(u * drift_mm_per_min * t / 60 + j(floor(t * 60)))
//
// t: seconds on the headset's clock since the first start(); u: a unit
// direction drawn from the seed; j(k): per display frame (60 Hz) an
// independent zero-mean Gaussian offset of 3D RMS jitter_mm, from a
// counter-based generator keyed by (seed, k), so the function is pure and a
// test can recompute it.
//
// Sends nothing but the operator's confirmations (STRING, device "Confirm")
// and its camera's photos (IMAGE, device "HmdCamera", 8-bit grey; in header
// v2 with the metadata "CameraIntrinsics"), in the header version the stream
// last used (v1 before anything arrived).
// Thread-safe; the handlers run on the client's I/O thread.
#include <Eigen/Geometry>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "mrsns/core/mesh.h"

namespace mrsns::simulation {

struct HmdEmulatorOptions {
  std::string host = "127.0.0.1";
  std::uint16_t port = 18945;
  /// The stream is in the Unity convention (`serve --unity`): left-handed metres.
  bool unity = false;
  /// Slow drift of the headset's world frame (mm per minute, along a seeded direction).
  double drift_mm_per_min = 0.0;
  /// 3D RMS jitter of the headset's world frame (mm), independent per 60 Hz display frame.
  double jitter_mm = 0.0;
  std::uint64_t seed = 1;
  /// Longest wait between reconnection attempts after a drop (s).
  double reconnect_max_s = 1.0;
};

inline constexpr double kHmdDisplayRateHz = 60.0;
inline constexpr std::size_t kMaxPrompts = 1000;

struct DisplayedModel {
  std::string name;  ///< device name on the wire
  /// Shown: connected, posed, and no STATUS other than Ok since the last TRANSFORM.
  bool visible = false;
  std::size_t vertices = 0;                  ///< 0 until its POLYDATA arrived (or a pose-only device)
  std::shared_ptr<const TriangleMesh> mesh;  ///< mm, MR-SNS convention; null until received
  bool posed = false;                        ///< a TRANSFORM has arrived
  /// Last received pose in the hologram frame (mm, MR-SNS convention).
  Eigen::Isometry3d hologram_T_model = Eigen::Isometry3d::Identity();
  /// Where the headset displays it in its own drifting world frame.
  Eigen::Isometry3d world_T_model = Eigen::Isometry3d::Identity();
  /// Header timestamp of the last TRANSFORM (s since 1970 UTC; 0 when the sender left it unset).
  double sent_utc = std::numeric_limits<double>::quiet_NaN();
  /// Local wall-clock time it arrived (s since 1970 UTC): latency = received_utc - sent_utc.
  double received_utc = std::numeric_limits<double>::quiet_NaN();
  /// Headset clock (s since the first start()) at which world_T_model was computed.
  double headset_time_s = std::numeric_limits<double>::quiet_NaN();
  std::uint64_t updates = 0;  ///< TRANSFORMs displayed
  /// Last STATUS error name ("TrackingOk", "TrackingLost"), "TrackingOk" after
  /// a TRANSFORM, "Disconnected" after a drop; empty before any of these.
  std::string status;
};

struct HmdEmulatorStats {
  bool connected = false;
  std::uint64_t connects = 0;
  std::uint64_t meshes = 0;
  std::uint64_t transforms = 0;
  std::uint64_t statuses = 0;
  std::uint64_t prompts = 0;
  std::uint64_t other_messages = 0;
  /// Messages the client could not decode plus decoded ones that cannot be
  /// displayed (bad mesh, non-rigid or non-finite pose, content not matching its type).
  std::uint64_t malformed = 0;
  std::uint64_t convention_mismatches = 0;
  std::uint64_t confirmations = 0;
  std::uint64_t images_sent = 0;
};

class HmdEmulator {
 public:
  /// Throws InvalidArgumentError for an empty host, port 0, or a negative or
  /// non-finite drift, jitter or reconnect interval.
  explicit HmdEmulator(HmdEmulatorOptions options);
  ~HmdEmulator();
  HmdEmulator(const HmdEmulator&) = delete;
  HmdEmulator& operator=(const HmdEmulator&) = delete;

  /// Starts connecting (returns at once; it keeps retrying). The first call
  /// starts the headset clock. No-op while running. Throws NetworkError when
  /// the host name cannot be resolved.
  void start();
  /// Disconnects and stops retrying (models stay, hidden). Idempotent.
  void stop();

  /// Every model (and pose-only device) received so far, by name.
  [[nodiscard]] std::vector<DisplayedModel> displayed() const;
  [[nodiscard]] std::vector<std::string> prompts() const;
  /// The prompts received after the first `seen` of all (the count it returned last time, 0 at first), read
  /// with the count under one lock, so none is skipped or read twice; `seen` becomes the new count.
  [[nodiscard]] std::vector<std::string> promptsSince(std::uint64_t& seen) const;
  /// Sends the operator's confirmation (STRING, device "Confirm", e.g.
  /// "cube-aligned"). False when not connected (nothing is sent). Throws
  /// InvalidArgumentError for an empty text or one over 65535 bytes.
  bool confirm(const std::string& what);
  /// Sends a photo from the headset's camera (IMAGE, device "HmdCamera": `pixels` grey, row-major, width x
  /// height) with `intrinsics` as metadata "CameraIntrinsics" when not empty and the stream speaks v2. False
  /// when not connected. Throws InvalidArgumentError when the pixel count does not match or a side is 0 or over
  /// 65535.
  bool sendImage(int width, int height, const std::vector<std::uint8_t>& pixels, const std::string& intrinsics);
  [[nodiscard]] HmdEmulatorStats stats() const;

  /// The headset's world frame relative to the hologram frame at headset time
  /// t_s (see the formula above); a pure function of the options.
  [[nodiscard]] Eigen::Isometry3d headsetWorldTHologram(double t_s) const;

 private:
  struct Impl;
  std::shared_ptr<Impl> impl_;
};

}  // namespace mrsns::simulation
