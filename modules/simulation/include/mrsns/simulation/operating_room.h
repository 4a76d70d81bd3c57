#pragma once
// The simulated operating room: the world stepped in real time behind the
// devices' own protocols (a PlusServer for tracking and B-mode video, a UR
// controller for the arm; an emulated headset as a client of the workstation's
// hologram stream), faults fired on schedule, and the truth recorded
// for `mrsns-sim score` only. Or, in replay mode, a PLUS recording served on
// the same wire.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

#include "mrsns/simulation/scenario.h"

namespace mrsns::simulation {

struct OperatingRoomStats {
  double elapsed_s = 0.0;
  std::uint64_t tracker_samples = 0;
  std::uint64_t video_frames = 0;
  std::uint64_t frozen_frames = 0;
  std::uint64_t invalid_tool_samples = 0;
  std::uint64_t faults_fired = 0;
  std::uint64_t transform_messages = 0;
  std::uint64_t tdata_messages = 0;
  std::uint64_t image_messages = 0;
  std::uint64_t clients_connected = 0;
  double mean_frame_render_ms = 0.0;
  double max_frame_render_ms = 0.0;
  std::uint64_t tracker_overruns = 0;  ///< ticks that started later than one period after their time
  std::uint64_t replayed_frames = 0;
  bool hmd_connected = false;        ///< the emulated headset is connected to the hologram stream
  std::uint64_t hmd_meshes = 0;      ///< models it received
  std::uint64_t hmd_transforms = 0;  ///< poses it displayed
};

/// Where the devices listen once started (ports chosen by the OS when the scenario said 0).
struct OperatingRoomEndpoints {
  std::string host;
  std::uint16_t plus_port = 0;
  bool robot = false;
  std::uint16_t rtde_port = 0;
  std::uint16_t dashboard_port = 0;
  std::uint16_t secondary_port = 0;
  std::uint16_t realtime_port = 0;
};

class OperatingRoom {
 public:
  /// Builds the world (patient, phantom) from the scenario. Throws what
  /// World throws; nothing listens yet.
  explicit OperatingRoom(Scenario scenario);
  ~OperatingRoom();
  OperatingRoom(const OperatingRoom&) = delete;
  OperatingRoom& operator=(const OperatingRoom&) = delete;

  /// Binds every device and starts the clock (t = 0). Throws NetworkError
  /// for a port in use, InvalidArgumentError for a robot pose out of reach.
  void start();
  /// Stops every device and thread. Idempotent.
  void stop();
  /// True once the scenario's duration (or the replay) has run out.
  [[nodiscard]] bool finished() const;

  [[nodiscard]] OperatingRoomEndpoints endpoints() const;
  [[nodiscard]] OperatingRoomStats stats() const;

  /// Writes the truth recorded so far (JSON, format "mrsns-truth/1") atomically.
  void writeTruth(const std::filesystem::path& path) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mrsns::simulation
