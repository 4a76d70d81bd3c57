#pragma once
// A simulated tracker: each tool follows its own script (static, pivoting,
// linear or circular sweep), optionally with hand tremor, dropouts and added
// latency, plus a seeded noise model. Deterministic given the seed and the
// times it is stepped at. Runs on its own thread at a set rate, or is
// stepped by hand (step(t)) in tests.
#include <cstdint>
#include <memory>
#include <optional>
#include <random>
#include <thread>
#include <variant>
#include <vector>

#include "mrsns/tracking/tracking_source.h"

namespace mrsns::tracking {

/// The tool does not move.
struct StaticMotion {
  Eigen::Isometry3d tracker_T_tool = Eigen::Isometry3d::Identity();
};

/// Pivoting about a fixed point (a pointer tip in a divot): the tip, at
/// `tip_tool` in tool coordinates, stays at `pivot_tracker` while the tool
/// swings about the x and y axes of `base_rotation` by up to `amplitude` rad
/// (a Lissajous path: x at `frequency_hz`, y at 1.5 times it).
struct PivotMotion {
  Eigen::Vector3d pivot_tracker = Eigen::Vector3d(0.0, 0.0, -1000.0);
  Eigen::Vector3d tip_tool = Eigen::Vector3d(0.0, 0.0, -150.0);
  Eigen::Matrix3d base_rotation = Eigen::Matrix3d::Identity();
  double amplitude = 0.35;  ///< rad (20 degrees)
  double frequency_hz = 0.25;
};

/// Back and forth along a line at constant speed (triangle wave), orientation fixed.
struct LinearSweep {
  Eigen::Isometry3d start = Eigen::Isometry3d::Identity();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();  ///< tracker frame, normalised on use
  double length_mm = 100.0;
  double speed_mm_s = 50.0;
};

/// Round a circle at constant angular speed, orientation fixed.
struct CircularSweep {
  Eigen::Vector3d centre_tracker = Eigen::Vector3d(0.0, 0.0, -1000.0);
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< axis of the circle, normalised on use
  double radius_mm = 50.0;
  double period_s = 4.0;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
};

using Motion = std::variant<StaticMotion, PivotMotion, LinearSweep, CircularSweep>;

/// Physiological hand tremor: on each axis a sinusoid with a frequency drawn
/// (from the seed) in [min_hz, max_hz], scaled so the 3D RMS is rms_mm, plus a
/// slow drift of amplitude drift_mm at drift_hz (in a seeded direction).
struct Tremor {
  double rms_mm = 0.5;
  double min_hz = 8.0;
  double max_hz = 12.0;
  double drift_mm = 1.0;
  double drift_hz = 0.05;
};

/// The tool is invisible (status Invalid) for t in [start_s, start_s + duration_s).
struct Dropout {
  double start_s = 0.0;
  double duration_s = 0.0;
};

struct ToolScript {
  std::string name = "StylusToTracker";  ///< PLUS style transform name
  Motion motion = StaticMotion{};
  std::optional<Tremor> tremor;
  std::vector<Dropout> dropouts;
  /// The pose reported at time t is the tool's pose at t - latency_s (a delay
  /// the timestamps do not show, as temporal calibration has to find).
  double latency_s = 0.0;
};

/// Measurement noise, independent per sample. Position: isotropic Gaussian
/// with the given 3D RMS (per-axis sigma = rms / sqrt(3)); orientation: a
/// rotation vector with the given RMS angle (per-axis sigma = rms / sqrt(3)),
/// applied in the tool frame. 0.25 mm is the default, the Polaris Vega figure
/// is 0.35 mm.
struct NoiseModel {
  double position_rms_mm = 0.25;
  double orientation_rms = 0.0;  ///< rad
};

struct SimulatorOptions {
  std::vector<ToolScript> tools;
  NoiseModel noise;
  std::uint64_t seed = 1;
  double rate_hz = 60.0;  ///< for start(): thread rate
};

class SimulatedTrackingSource : public TrackingSource {
 public:
  /// Throws InvalidArgumentError for no tools, duplicate or non-PLUS names,
  /// negative noise, rate outside (0, 10000] Hz or negative durations.
  SimulatedTrackingSource(std::shared_ptr<TransformRepository> repository, SimulatorOptions options);
  ~SimulatedTrackingSource() override;

  /// Runs a thread that steps at rate_hz with t = seconds since start().
  void start() override;
  void stop() override;
  [[nodiscard]] std::string name() const override { return "simulator"; }
  [[nodiscard]] std::vector<std::string> toolNames() const override;

  /// Publishes every tool at time t (seconds). For tests: do not mix with start().
  void step(double t) noexcept;
  /// The noise-free pose of tool `index` as scripted at time t (no latency, no dropout).
  [[nodiscard]] Eigen::Isometry3d truePose(std::size_t index, double t) const;
  /// True when tool `index` is in a dropout at time t.
  [[nodiscard]] bool inDropout(std::size_t index, double t) const;

 private:
  struct ToolState {
    std::mt19937_64 rng;
    Eigen::Vector3d tremor_hz = Eigen::Vector3d::Zero();
    Eigen::Vector3d tremor_phase = Eigen::Vector3d::Zero();
    Eigen::Vector3d drift_direction = Eigen::Vector3d::UnitX();
  };
  SimulatorOptions options_;
  std::vector<ToolState> states_;
  std::vector<ToolUpdate> batch_;
  std::thread thread_;
  std::atomic<bool> running_{false};
};

}  // namespace mrsns::tracking
