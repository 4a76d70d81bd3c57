#pragma once
// Latency compensation for the hologram stream: a pose measured at t is shown
// at t + latency, so the hologram trails a moving head or patient. A predictor
// extrapolates the pose latency_s ahead with a constant-velocity model on SE(3)
// (body twist from se3Log of consecutive poses):
// - kConstantVelocity: the twist of the last two samples;
// - kKalman: an error-state Kalman filter with state (pose, body twist),
//   white-noise acceleration process model, pose measurements (the residual is
//   se3Log(predicted^-1 * measured)), which smooths the twist against noise.
// Runs inside the streaming loop: update() and predict() never throw; bad
// samples are counted and ignored.
#include <Eigen/Geometry>
#include <span>

#include "mrsns/core/rigid.h"

namespace mrsns::hmd {

enum class PredictorModel { kNone, kConstantVelocity, kKalman };

struct PredictorOptions {
  PredictorModel model = PredictorModel::kKalman;
  /// Kalman: acceleration noise spectral densities (translation mm^2/s^3, rotation rad^2/s^3).
  double accel_noise_mm = 2.0e4;
  double accel_noise_rad = 0.5;
  /// Kalman: measurement noise standard deviations (mm, rad).
  double measurement_noise_mm = 0.3;
  double measurement_noise_rad = 0.003;
};

class PosePredictor {
 public:
  explicit PosePredictor(const PredictorOptions& options = {});
  /// Feeds the pose measured at time t. Samples with non-finite values or times not after the
  /// previous one are ignored (counted in rejected()).
  void update(double t, const Eigen::Isometry3d& pose) noexcept;
  /// Pose extrapolated to time t (normally last time + latency). Before the first sample:
  /// identity; with one sample (or model kNone): the last pose.
  [[nodiscard]] Eigen::Isometry3d predict(double t) const noexcept;
  [[nodiscard]] int samples() const { return samples_; }
  [[nodiscard]] int rejected() const { return rejected_; }
  /// Current body twist estimate [v (mm/s); w (rad/s)].
  [[nodiscard]] const Vector6d& twist() const { return twist_; }
  void reset();

 private:
  PredictorOptions options_;
  Eigen::Isometry3d pose_ = Eigen::Isometry3d::Identity();
  Vector6d twist_ = Vector6d::Zero();
  Eigen::Matrix<double, 12, 12> P_ = Eigen::Matrix<double, 12, 12>::Identity();
  double last_time_ = 0.0;
  int samples_ = 0;
  int rejected_ = 0;
};

struct PredictionEvaluation {
  int count = 0;
  /// RMS error against the true pose at t + latency, of the pose shown without prediction
  /// (the last measurement) and with the predictor.
  double rms_translation_none_mm = 0.0;
  double rms_rotation_none_rad = 0.0;
  double rms_translation_predicted_mm = 0.0;
  double rms_rotation_predicted_rad = 0.0;
};

/// Replays measured[k] (at times[k]) through a predictor and compares, for each k after the
/// first `warmup` samples, the pose shown at times[k] + latency_s with truth(times[k] +
/// latency_s) interpolated from `truth` (at `times`; measured may be truth plus noise).
/// Only k whose target time lies within the series are scored. Throws InvalidArgumentError on
/// mismatched sizes, fewer than warmup + 2 samples, a negative or non-finite latency.
PredictionEvaluation evaluatePredictor(std::span<const double> times, std::span<const Eigen::Isometry3d> measured,
                                       std::span<const Eigen::Isometry3d> truth, double latency_s,
                                       const PredictorOptions& options = {}, int warmup = 10);

}  // namespace mrsns::hmd
