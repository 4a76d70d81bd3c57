#include "cube_operator.h"

#include <cmath>
#include <limits>

#include "mrsns/core/minimum_jerk.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/units.h"

namespace mrsns::simulation {

namespace {

constexpr double kPutBackS = 1.0;  // from the hold back to where the cube rests

Eigen::Vector3d gaussian3(std::mt19937_64& rng, double sigma) {
  std::normal_distribution<double> n(0.0, 1.0);
  return sigma * Eigen::Vector3d(n(rng), n(rng), n(rng));
}

}  // namespace

CubeOperator::CubeOperator(CubeOperatorSpec spec, std::uint64_t seed)
    : spec_(std::move(spec)), rng_(seed * 2654435761ULL + 97ULL) {}

void CubeOperator::onPrompt(double t, const std::string& prompt) {
  if (prompt.find(spec_.prompt_contains) == std::string::npos || spec_.views.empty()) return;
  std::size_t view = next_view_ % spec_.views.size();
  for (std::size_t i = 0; i < spec_.views.size(); ++i) {
    if (prompt.find("(" + spec_.views[i].name + ")") != std::string::npos) view = i;
  }
  next_view_ = view + 1;
  Match m;
  m.view = view;
  m.prompt_t = t;
  // A match under way is abandoned where the cube is, and so is the way back to its rest: the new one starts
  // from there.
  if (match_ && match_->aligned) {
    m.from = hand(*match_, t);
  } else if (release_from_ && last_rest_) {
    m.from = interpolatePose(*release_from_, *last_rest_, minimumJerk((t - release_t_) / kPutBackS));
  }
  match_ = m;
  release_from_.reset();
  matches_.push_back({spec_.views[view].name, t, std::numeric_limits<double>::quiet_NaN(), {}, 0.0, false});
}

Eigen::Isometry3d CubeOperator::perceive(Match& m, const Eigen::Isometry3d& tracker_T_hologram) {
  // The eyes look at the cube from the view's side: depth is misjudged along that line, less so across it.
  const Eigen::Vector3d toward_cube = -spec_.views[m.view].eye_from_cube_mm.normalized();
  const Eigen::Vector3d across1 = toward_cube.unitOrthogonal();
  const Eigen::Vector3d across2 = toward_cube.cross(across1);
  std::normal_distribution<double> n(0.0, 1.0);
  const double depth = spec_.depth_bias_mm + spec_.depth_error_mm * n(rng_);
  const Eigen::Vector3d error = depth * toward_cube + spec_.lateral_error_mm * (n(rng_) * across1 + n(rng_) * across2);
  Eigen::Isometry3d aligned = tracker_T_hologram;
  aligned.linear() = aligned.linear() * so3Exp(gaussian3(rng_, spec_.rotation_deg * kDeg));
  aligned.translation() += error;
  matches_.back().perception_error_mm = error;
  matches_.back().depth_error_mm = depth;
  // The hand during the hold: tremor in the physiological band, a slow drift, sudden slips.
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int k = 0; k < 3; ++k) {
    m.tremor_hz[k] = spec_.tremor_min_hz + (spec_.tremor_max_hz - spec_.tremor_min_hz) * u(rng_);
    m.tremor_phase[k] = 2.0 * M_PI * u(rng_);
    m.rotation_hz[k] = spec_.tremor_min_hz + (spec_.tremor_max_hz - spec_.tremor_min_hz) * u(rng_);
    m.rotation_phase[k] = 2.0 * M_PI * u(rng_);
  }
  m.tremor_amplitude = Eigen::Vector3d::Constant(spec_.tremor_mm);
  m.rotation_amplitude = Eigen::Vector3d::Constant(spec_.tremor_rotation_deg * kDeg);
  m.drift_direction = gaussian3(rng_, 1.0).normalized();
  const double held = spec_.confirm_after_s + spec_.hold_s;
  if (spec_.jerks_per_s > 0.0) {
    std::exponential_distribution<double> gap(spec_.jerks_per_s);
    for (double s = gap(rng_); s < held; s += gap(rng_)) {
      const double size = spec_.jerk_min_mm + (spec_.jerk_max_mm - spec_.jerk_min_mm) * u(rng_);
      m.jerks.emplace_back(s, size * gaussian3(rng_, 1.0).normalized());
    }
  }
  return aligned;
}

Eigen::Isometry3d CubeOperator::hand(const Match& m, double t) const {
  const Eigen::Isometry3d& aligned = *m.aligned;
  if (t < m.hold_t) {
    const double s = minimumJerk((t - (m.hold_t - spec_.align_s)) / spec_.align_s);
    return m.from ? interpolatePose(*m.from, aligned, s) : aligned;
  }
  const double tau = t - m.hold_t;
  Eigen::Vector3d offset = tau * spec_.drift_mm_per_s * m.drift_direction;
  Eigen::Vector3d rotation = Eigen::Vector3d::Zero();
  for (int k = 0; k < 3; ++k) {
    offset[k] += m.tremor_amplitude[k] * std::sin(2.0 * M_PI * m.tremor_hz[k] * tau + m.tremor_phase[k]);
    rotation[k] = m.rotation_amplitude[k] * std::sin(2.0 * M_PI * m.rotation_hz[k] * tau + m.rotation_phase[k]);
  }
  for (const auto& [start, slip] : m.jerks) {
    if (tau >= start && tau < start + spec_.jerk_duration_s) offset += slip;
  }
  Eigen::Isometry3d p = aligned;
  p.linear() = p.linear() * so3Exp(rotation);
  p.translation() += offset;
  return p;
}

std::optional<Eigen::Isometry3d> CubeOperator::pose(double t, const Eigen::Isometry3d& tracker_T_rest,
                                                    const std::optional<Eigen::Isometry3d>& tracker_T_hologram) {
  if (!spec_.enabled) return std::nullopt;
  last_rest_ = tracker_T_rest;
  if (match_) {
    Match& m = *match_;
    if (!m.aligned) {
      if (!tracker_T_hologram) return std::nullopt;  // nothing to line up with yet: the cube stays where it is
      if (!m.from) m.from = tracker_T_rest;
      m.aligned = perceive(m, *tracker_T_hologram);
      m.hold_t = t + spec_.align_s;
      matches_.back().hold_t = m.hold_t;
    }
    const double end = m.hold_t + spec_.confirm_after_s + spec_.hold_s;
    if (t < end) return hand(m, t);
    release_from_ = hand(m, end);
    release_t_ = end;
    match_.reset();
  }
  if (release_from_) {
    const double s = (t - release_t_) / kPutBackS;
    if (s < 1.0) return interpolatePose(*release_from_, tracker_T_rest, minimumJerk(s));
    release_from_.reset();
  }
  return std::nullopt;
}

std::optional<std::string> CubeOperator::confirmationDue(double t) {
  if (!match_ || !match_->aligned || match_->confirmed || t < match_->hold_t + spec_.confirm_after_s) {
    return std::nullopt;
  }
  match_->confirmed = true;
  matches_.back().confirmed = true;
  if (!spec_.confirm_on_headset) return std::nullopt;  // the pedal at the workstation, pressed from outside
  return spec_.confirm;
}

}  // namespace mrsns::simulation
