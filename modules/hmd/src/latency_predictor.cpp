#include "mrsns/hmd/latency_predictor.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "mrsns/core/error.h"

namespace mrsns::hmd {

using Matrix12d = Eigen::Matrix<double, 12, 12>;

PosePredictor::PosePredictor(const PredictorOptions& options) : options_(options) {
  reset();
}

void PosePredictor::reset() {
  pose_ = Eigen::Isometry3d::Identity();
  twist_ = Vector6d::Zero();
  P_ = Matrix12d::Zero();
  samples_ = 0;
  rejected_ = 0;
  last_time_ = 0.0;
}

void PosePredictor::update(double t, const Eigen::Isometry3d& pose) noexcept {
  if (!std::isfinite(t) || !pose.matrix().allFinite() || (samples_ > 0 && !(t > last_time_))) {
    ++rejected_;
    return;
  }
  const double sm = options_.measurement_noise_mm, sr = options_.measurement_noise_rad;
  if (samples_ == 0) {
    pose_ = pose;
    twist_.setZero();
    P_.setZero();
    P_.diagonal().head<3>().setConstant(sm * sm);
    P_.diagonal().segment<3>(3).setConstant(sr * sr);
    // Unknown initial speed: large variance (1 m/s, 3 rad/s).
    P_.diagonal().segment<3>(6).setConstant(1e6);
    P_.diagonal().tail<3>().setConstant(9.0);
    last_time_ = t;
    ++samples_;
    return;
  }
  const double dt = t - last_time_;
  if (options_.model != PredictorModel::kKalman) {
    // Body twist of the last step: pose_ * exp(twist * dt) = pose.
    twist_ = se3Log(pose_.inverse() * pose) / dt;
    pose_ = pose;
  } else {
    // Predict: constant twist.
    pose_ = pose_ * se3Exp(twist_ * dt);
    Matrix12d F = Matrix12d::Identity();
    F.block<6, 6>(0, 6) = dt * Eigen::Matrix<double, 6, 6>::Identity();
    Matrix12d Q = Matrix12d::Zero();
    for (int i = 0; i < 6; ++i) {
      const double q = i < 3 ? options_.accel_noise_mm : options_.accel_noise_rad;
      Q(i, i) = q * dt * dt * dt / 3.0;
      Q(i, i + 6) = Q(i + 6, i) = q * dt * dt / 2.0;
      Q(i + 6, i + 6) = q * dt;
    }
    P_ = F * P_ * F.transpose() + Q;
    // Update with the measured pose.
    const Vector6d residual = se3Log(pose_.inverse() * pose);
    Eigen::Matrix<double, 6, 6> R = Eigen::Matrix<double, 6, 6>::Zero();
    R.diagonal() << sm * sm, sm * sm, sm * sm, sr * sr, sr * sr, sr * sr;
    const Eigen::Matrix<double, 6, 6> S = P_.topLeftCorner<6, 6>() + R;
    const Eigen::Matrix<double, 12, 6> K = P_.leftCols<6>() * S.inverse();
    const Eigen::Matrix<double, 12, 1> delta = K * residual;
    pose_ = pose_ * se3Exp(delta.head<6>());
    twist_ += delta.tail<6>();
    Matrix12d IKH = Matrix12d::Identity();
    IKH.leftCols<6>() -= K;
    P_ = IKH * P_;
    P_ = 0.5 * (P_ + P_.transpose());
  }
  last_time_ = t;
  ++samples_;
}

Eigen::Isometry3d PosePredictor::predict(double t) const noexcept {
  if (samples_ == 0) return Eigen::Isometry3d::Identity();
  if (samples_ == 1 || options_.model == PredictorModel::kNone || !std::isfinite(t)) return pose_;
  return pose_ * se3Exp(twist_ * (t - last_time_));
}

PredictionEvaluation evaluatePredictor(std::span<const double> times, std::span<const Eigen::Isometry3d> measured,
                                       std::span<const Eigen::Isometry3d> truth, double latency_s,
                                       const PredictorOptions& options, int warmup) {
  if (times.size() != measured.size() || times.size() != truth.size()) {
    throw InvalidArgumentError("evaluatePredictor: times, measured and truth must have the same length");
  }
  if (warmup < 0 || times.size() < static_cast<std::size_t>(warmup) + 2) {
    throw InvalidArgumentError("evaluatePredictor: " + std::to_string(times.size()) +
                               " samples; need more than the warm-up (" + std::to_string(warmup) + ") + 1");
  }
  if (!(latency_s >= 0.0) || !std::isfinite(latency_s)) {
    throw InvalidArgumentError("evaluatePredictor: latency_s must be finite and non-negative");
  }
  PosePredictor predictor(options);
  PredictionEvaluation e;
  double tn = 0, rn = 0, tp = 0, rp = 0;
  for (std::size_t k = 0; k < times.size(); ++k) {
    predictor.update(times[k], measured[k]);
    if (k < static_cast<std::size_t>(warmup)) continue;
    const double target = times[k] + latency_s;
    const auto it = std::lower_bound(times.begin(), times.end(), target);
    if (it == times.end()) break;
    const auto j = static_cast<std::size_t>(it - times.begin());
    const Eigen::Isometry3d want =
        j == 0 ? truth[0]
               : interpolatePose(truth[j - 1], truth[j], (target - times[j - 1]) / (times[j] - times[j - 1]));
    const Eigen::Isometry3d shown = predictor.predict(target);
    tn += (measured[k].translation() - want.translation()).squaredNorm();
    rn += std::pow(rotationAngleBetween(measured[k].linear(), want.linear()), 2);
    tp += (shown.translation() - want.translation()).squaredNorm();
    rp += std::pow(rotationAngleBetween(shown.linear(), want.linear()), 2);
    ++e.count;
  }
  if (e.count > 0) {
    e.rms_translation_none_mm = std::sqrt(tn / e.count);
    e.rms_rotation_none_rad = std::sqrt(rn / e.count);
    e.rms_translation_predicted_mm = std::sqrt(tp / e.count);
    e.rms_rotation_predicted_rad = std::sqrt(rp / e.count);
  }
  return e;
}

}  // namespace mrsns::hmd
