#include "mrsns/tracking/simulated_source.h"

#include <chrono>
#include <cmath>
#include <numbers>
#include <set>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/units.h"

namespace mrsns::tracking {
namespace {

Eigen::Isometry3d motionPose(const Motion& motion, double t) {
  return std::visit(
      [t](const auto& m) -> Eigen::Isometry3d {
        using M = std::decay_t<decltype(m)>;
        Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
        if constexpr (std::is_same_v<M, StaticMotion>) {
          pose = m.tracker_T_tool;
        } else if constexpr (std::is_same_v<M, PivotMotion>) {
          const double u = kTwoPi * m.frequency_hz * t;
          const Eigen::Vector3d phi(m.amplitude * std::sin(u), m.amplitude * std::sin(1.5 * u + 0.5), 0.0);
          pose.linear() = m.base_rotation * so3Exp(phi);
          pose.translation() = m.pivot_tracker - pose.linear() * m.tip_tool;
        } else if constexpr (std::is_same_v<M, LinearSweep>) {
          const double period = 2.0 * m.length_mm / m.speed_mm_s;
          const double phase = std::fmod(t, period) / period;  // t >= 0 in practice; fmod keeps the sign
          const double s = phase < 0.0 ? 0.0 : (phase < 0.5 ? 2.0 * phase : 2.0 - 2.0 * phase);
          pose = m.start;
          pose.translation() += s * m.length_mm * m.direction.normalized();
        } else if constexpr (std::is_same_v<M, CircularSweep>) {
          const Eigen::Vector3d n = m.normal.normalized();
          // Any unit vector perpendicular to n starts the circle.
          Eigen::Vector3d e1 = n.unitOrthogonal();
          const Eigen::Vector3d e2 = n.cross(e1);
          const double u = kTwoPi * t / m.period_s;
          pose.linear() = m.rotation;
          pose.translation() = m.centre_tracker + m.radius_mm * (std::cos(u) * e1 + std::sin(u) * e2);
        }
        return pose;
      },
      motion);
}

void validate(const SimulatorOptions& o) {
  if (o.tools.empty()) throw InvalidArgumentError("simulator: no tool scripts given; add at least one ToolScript");
  if (!(o.noise.position_rms_mm >= 0.0) || !(o.noise.orientation_rms >= 0.0)) {
    throw InvalidArgumentError("simulator: noise RMS must be >= 0 (position mm, orientation rad)");
  }
  if (!(o.rate_hz > 0.0 && o.rate_hz <= 10000.0)) {
    throw InvalidArgumentError("simulator: rate_hz must be in (0, 10000] Hz, got " + std::to_string(o.rate_hz));
  }
  std::set<std::string> names;
  for (const auto& tool : o.tools) {
    (void)TransformName::parse(tool.name);  // throws with the name when it is not "AToB"
    if (!names.insert(tool.name).second) {
      throw InvalidArgumentError("simulator: tool '" + tool.name + "' is scripted twice; give each tool one script");
    }
    if (!(tool.latency_s >= 0.0)) throw InvalidArgumentError("simulator: latency of '" + tool.name + "' is negative");
    for (const auto& d : tool.dropouts) {
      if (!(d.duration_s >= 0.0)) {
        throw InvalidArgumentError("simulator: a dropout of '" + tool.name + "' has a negative duration");
      }
    }
    if (const auto* sweep = std::get_if<LinearSweep>(&tool.motion)) {
      if (!(sweep->length_mm > 0.0 && sweep->speed_mm_s > 0.0) || sweep->direction.norm() == 0.0) {
        throw InvalidArgumentError("simulator: linear sweep of '" + tool.name +
                                   "' needs a length > 0, a speed > 0 and a non-zero direction");
      }
    }
    if (const auto* circle = std::get_if<CircularSweep>(&tool.motion)) {
      if (!(circle->period_s > 0.0) || circle->normal.norm() == 0.0) {
        throw InvalidArgumentError("simulator: circular sweep of '" + tool.name +
                                   "' needs a period > 0 and a non-zero normal");
      }
    }
  }
}

}  // namespace

SimulatedTrackingSource::SimulatedTrackingSource(std::shared_ptr<TransformRepository> repository,
                                                 SimulatorOptions options)
    : TrackingSource(std::move(repository)), options_(std::move(options)) {
  validate(options_);
  states_.resize(options_.tools.size());
  for (std::size_t i = 0; i < states_.size(); ++i) {
    auto& s = states_[i];
    // One stream per tool so adding a tool does not change the others' noise.
    s.rng.seed(options_.seed * 0x9E3779B97F4A7C15ULL + i);
    if (const auto& tremor = options_.tools[i].tremor) {
      std::uniform_real_distribution<double> hz(tremor->min_hz, tremor->max_hz);
      std::uniform_real_distribution<double> phase(0.0, kTwoPi);
      std::normal_distribution<double> normal;
      for (int a = 0; a < 3; ++a) {
        s.tremor_hz[a] = hz(s.rng);
        s.tremor_phase[a] = phase(s.rng);
      }
      s.drift_direction = Eigen::Vector3d(normal(s.rng), normal(s.rng), normal(s.rng)).normalized();
    }
  }
  batch_.resize(options_.tools.size());
  for (std::size_t i = 0; i < batch_.size(); ++i) batch_[i].name = options_.tools[i].name;
}

SimulatedTrackingSource::~SimulatedTrackingSource() {
  stop();
}

std::vector<std::string> SimulatedTrackingSource::toolNames() const {
  std::vector<std::string> names;
  for (const auto& tool : options_.tools) names.push_back(tool.name);
  return names;
}

Eigen::Isometry3d SimulatedTrackingSource::truePose(std::size_t index, double t) const {
  const auto& tool = options_.tools.at(index);
  Eigen::Isometry3d pose = motionPose(tool.motion, t);
  if (tool.tremor) {
    const auto& tremor = *tool.tremor;
    const auto& s = states_[index];
    // A sinusoid of amplitude A has RMS A/sqrt(2); three axes: 3D RMS = A*sqrt(3/2).
    const double amplitude = tremor.rms_mm * std::sqrt(2.0 / 3.0);
    Eigen::Vector3d offset;
    for (int a = 0; a < 3; ++a) offset[a] = amplitude * std::sin(kTwoPi * s.tremor_hz[a] * t + s.tremor_phase[a]);
    offset += tremor.drift_mm * std::sin(kTwoPi * tremor.drift_hz * t) * s.drift_direction;
    pose.translation() += offset;
  }
  return pose;
}

bool SimulatedTrackingSource::inDropout(std::size_t index, double t) const {
  for (const auto& d : options_.tools.at(index).dropouts) {
    if (t >= d.start_s && t < d.start_s + d.duration_s) return true;
  }
  return false;
}

void SimulatedTrackingSource::step(double t) noexcept {
  const double sigma_p = options_.noise.position_rms_mm / std::sqrt(3.0);
  const double sigma_r = options_.noise.orientation_rms / std::sqrt(3.0);
  for (std::size_t i = 0; i < options_.tools.size(); ++i) {
    auto& s = states_[i];
    auto& u = batch_[i];
    u.timestamp = t;
    Eigen::Isometry3d pose = truePose(i, t - options_.tools[i].latency_s);
    // Noise is drawn even during dropouts so a dropout does not shift the
    // noise of the samples after it (the same seed gives the same samples).
    std::normal_distribution<double> normal;
    const Eigen::Vector3d dp(normal(s.rng), normal(s.rng), normal(s.rng));
    const Eigen::Vector3d dr(normal(s.rng), normal(s.rng), normal(s.rng));
    pose.translation() += sigma_p * dp;
    if (sigma_r > 0.0) pose.linear() = pose.linear() * so3Exp(sigma_r * dr);
    if (inDropout(i, t)) {
      u.status = TransformStatus::Invalid;  // keep the last reported pose, as trackers do
    } else {
      u.status = TransformStatus::Ok;
      u.to_T_from = pose;
    }
  }
  publish(batch_);
}

void SimulatedTrackingSource::start() {
  if (running_.exchange(true)) return;
  setState(SourceState::Running);
  thread_ = std::thread([this] {
    using Clock = std::chrono::steady_clock;
    const auto t0 = Clock::now();
    const auto period = std::chrono::duration<double>(1.0 / options_.rate_hz);
    std::uint64_t tick = 0;
    while (running_.load()) {
      const auto due = t0 + std::chrono::duration_cast<Clock::duration>(period * static_cast<double>(tick));
      std::this_thread::sleep_until(due);
      if (!running_.load()) break;
      step(std::chrono::duration<double>(Clock::now() - t0).count());
      ++tick;
      // After a long stall (debugger, overloaded machine) skip the missed ticks instead of bursting.
      const auto late =
          Clock::now() - (t0 + std::chrono::duration_cast<Clock::duration>(period * static_cast<double>(tick)));
      if (late > std::chrono::duration_cast<Clock::duration>(period * 10.0)) {
        tick += static_cast<std::uint64_t>(late / std::chrono::duration_cast<Clock::duration>(period));
      }
    }
  });
}

void SimulatedTrackingSource::stop() {
  running_.store(false);
  if (thread_.joinable()) thread_.join();
  setState(SourceState::Stopped);
}

}  // namespace mrsns::tracking
