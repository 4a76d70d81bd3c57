#include "mrsns/hmd/cube_trial.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <string>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/units.h"
#include "mrsns/hmd/cube_calibration.h"
#include "mrsns/hmd/mr_chain.h"
#include "mrsns/hmd/multi_view.h"

namespace mrsns::hmd {
namespace {

struct Scene {
  Eigen::Isometry3d tracker_T_hologram;
  std::vector<Eigen::Vector3d> cube_hologram;  // P_i^Hol: the 8 hologram fiducials
  Eigen::Vector3d cube_centre_hologram;
  Eigen::Isometry3d tracker_T_patient;
  Eigen::Isometry3d patient_T_preop;
  Eigen::Isometry3d preop_T_virtual;
  std::vector<Eigen::Vector3d> fiducial_virtual;  // the 6 fiducials of Eq. 23
};

Scene makeScene(double edge) {
  Scene s;
  Vector6d xi;
  xi << 350.0, -120.0, 1650.0, 0.3, 2.4, -0.2;  // HoloLens world frame as seen by the tracker
  s.tracker_T_hologram = se3Exp(xi);
  s.cube_centre_hologram = Eigen::Vector3d(40.0, -250.0, 550.0);
  for (int i = 0; i < 8; ++i) {
    s.cube_hologram.push_back(s.cube_centre_hologram +
                              0.5 * edge * Eigen::Vector3d(i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1));
  }
  // The patient (cervical phantom) lies beside the cube, 80 mm away.
  Eigen::Isometry3d hologram_T_patient = Eigen::Isometry3d::Identity();
  hologram_T_patient.linear() = so3Exp(Eigen::Vector3d(0.2, -0.4, 1.0));
  hologram_T_patient.translation() = s.cube_centre_hologram + Eigen::Vector3d(80.0, 0.0, 20.0);
  s.tracker_T_patient = s.tracker_T_hologram * hologram_T_patient;
  s.patient_T_preop = se3Exp((Vector6d() << -15.0, 8.0, -30.0, 0.05, 0.02, -0.1).finished());
  s.preop_T_virtual = preopFromVirtualRasLps();
  // Six fiducials spread over the phantom (within 50 mm of its origin).
  s.fiducial_virtual = {{-40, 0, 10}, {40, 0, 10}, {0, 45, 0}, {0, -45, 0}, {-20, 20, 40}, {25, -15, -35}};
  for (auto& p : s.fiducial_virtual) p = (s.patient_T_preop * s.preop_T_virtual).inverse() * p;
  return s;
}

class Simulator {
 public:
  Simulator(const CubeTrialOptions& options, std::uint64_t seed) : o_(options), n_(options.noise), rng_(seed) {}

  double gauss(double sigma) { return sigma * std::normal_distribution<double>(0.0, 1.0)(rng_); }
  double uniform(double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng_); }
  Eigen::Vector3d gauss3(double sigma) { return {gauss(sigma), gauss(sigma), gauss(sigma)}; }
  Eigen::Vector3d unit() { return gauss3(1.0).normalized(); }

  // Offset of a perceived position: along the view axis (bias + random) and across it.
  Eigen::Vector3d perceptionOffset(const Eigen::Vector3d& view, double bias, double along, double across) {
    const Eigen::Vector3d across_vec = gauss3(across);
    return view * (bias + gauss(along)) + (across_vec - view * view.dot(across_vec));
  }

  // Where the user puts the cube when matching it to the hologram seen along `view` (hologram
  // frame, rigid about the cube centre): perception + SLAM anchor jitter.
  Eigen::Isometry3d alignmentError(const Eigen::Vector3d& view, double bias, const Eigen::Vector3d& centre) {
    const Eigen::Matrix3d R =
        so3Exp(gauss3(n_.alignment_rotation_deg * kDeg)) * so3Exp(gauss3(n_.slam_jitter_deg * kDeg));
    const Eigen::Vector3d t =
        perceptionOffset(view, bias, n_.depth_error_mm, n_.lateral_error_mm) + gauss3(n_.slam_jitter_mm);
    Eigen::Isometry3d E = Eigen::Isometry3d::Identity();
    E.linear() = R;
    E.translation() = centre - R * centre + t;
    return E;
  }

  // Rigid hand motion over one hold (hologram frame, about the cube centre), one per sample.
  std::vector<Eigen::Isometry3d> holdMotion(const Eigen::Vector3d& centre) {
    const int count = static_cast<int>(std::lround(n_.hold_s * n_.sample_rate_hz));
    const double f = uniform(n_.tremor_min_hz, n_.tremor_max_hz);
    Eigen::Vector3d phase_t, phase_r;
    for (int a = 0; a < 3; ++a) {
      phase_t(a) = uniform(0.0, 2.0 * std::numbers::pi);
      phase_r(a) = uniform(0.0, 2.0 * std::numbers::pi);
    }
    const Eigen::Vector3d drift_dir = unit();
    std::vector<Eigen::Isometry3d> motion;
    for (int k = 0; k < count; ++k) {
      const double t = k / n_.sample_rate_hz;
      Eigen::Vector3d dt, dr;
      for (int a = 0; a < 3; ++a) {
        dt(a) = n_.tremor_amplitude_mm * std::sin(2.0 * std::numbers::pi * f * t + phase_t(a));
        dr(a) = n_.tremor_rotation_deg * kDeg * std::sin(2.0 * std::numbers::pi * f * t + phase_r(a));
      }
      // Drift centred on the hold so the user's aim is the middle of the drift.
      dt += drift_dir * n_.drift_mm_per_s * (t - 0.5 * n_.hold_s);
      if (uniform(0.0, 1.0) < n_.jerk_probability) dt += unit() * uniform(n_.jerk_min_mm, n_.jerk_max_mm);
      Eigen::Isometry3d M = Eigen::Isometry3d::Identity();
      M.linear() = so3Exp(dr);
      M.translation() = centre - M.linear() * centre + dt;
      motion.push_back(M);
    }
    return motion;
  }

  const CubeNoiseModel& noise() const { return n_; }
  std::mt19937_64& rng() { return rng_; }

 private:
  const CubeTrialOptions& o_;
  const CubeNoiseModel& n_;
  std::mt19937_64 rng_;
};

// Eq. 23 error and the per-axis components (hologram frame).
void score(const Scene& s, const Eigen::Isometry3d& tracker_T_hologram_est, MethodResult& out, Eigen::Vector3d& axis) {
  const Eigen::Isometry3d hologram_T_virtual =
      hologramFromVirtual(tracker_T_hologram_est, s.tracker_T_patient, s.patient_T_preop, s.preop_T_virtual);
  const Eigen::Isometry3d patient_T_virtual = s.patient_T_preop * s.preop_T_virtual;
  out.rms_mm.push_back(fusionRmsErrorMm(s.fiducial_virtual, hologram_T_virtual, s.tracker_T_hologram,
                                        s.tracker_T_patient, patient_T_virtual));
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& p : s.fiducial_virtual) {
    const Eigen::Vector3d shown = s.tracker_T_hologram * hologram_T_virtual * p;
    const Eigen::Vector3d truth = s.tracker_T_patient * patient_T_virtual * p;
    sum += (s.tracker_T_hologram.linear().transpose() * (shown - truth)).cwiseAbs();
  }
  axis += sum / static_cast<double>(s.fiducial_virtual.size());
}

void summarise(MethodResult& m, const Eigen::Vector3d& axis_sum) {
  const double n = static_cast<double>(m.rms_mm.size());
  double sum = 0.0;
  for (double e : m.rms_mm) sum += e;
  m.mean_rms_mm = sum / n;
  double var = 0.0;
  for (double e : m.rms_mm) var += (e - m.mean_rms_mm) * (e - m.mean_rms_mm);
  m.std_rms_mm = std::sqrt(var / (n - 1.0));
  m.mean_abs_axis_error_mm = axis_sum / n;
}

void validate(const CubeTrialOptions& o) {
  if (o.trials < 2) {
    throw InvalidArgumentError("runCubeTrial: trials is " + std::to_string(o.trials) +
                               "; at least 2 are needed for a standard deviation (the paper uses 12)");
  }
  if (o.uncompensated_matches < 1) {
    throw InvalidArgumentError("runCubeTrial: uncompensated_matches must be at least 1");
  }
  if (!(o.cube_edge_mm > 0.0) || !std::isfinite(o.cube_edge_mm)) {
    throw InvalidArgumentError("runCubeTrial: cube_edge_mm must be positive");
  }
  const CubeNoiseModel& n = o.noise;
  for (double v : {n.tremor_amplitude_mm, n.tremor_min_hz, n.tremor_max_hz, n.tremor_rotation_deg, n.drift_mm_per_s,
                   n.jerk_probability, n.jerk_min_mm, n.jerk_max_mm, n.depth_bias_mm, n.depth_error_mm,
                   n.lateral_error_mm, n.alignment_rotation_deg, n.slam_jitter_mm, n.slam_jitter_deg, n.tracking_mm,
                   n.pointer_depth_error_mm, n.pointer_lateral_error_mm, n.pointer_tip_error_mm}) {
    if (!(v >= 0.0) || !std::isfinite(v)) {
      throw InvalidArgumentError("runCubeTrial: every noise figure must be finite and non-negative");
    }
  }
  if (n.tremor_max_hz < n.tremor_min_hz || n.jerk_max_mm < n.jerk_min_mm) {
    throw InvalidArgumentError("runCubeTrial: a noise range has max < min");
  }
  if (!(n.sample_rate_hz > 0.0) || !(n.hold_s > 0.0) ||
      n.hold_s * n.sample_rate_hz < static_cast<double>(o.tremor.k_close + 1)) {
    throw InvalidArgumentError("runCubeTrial: hold_s * sample_rate_hz must give more than k_close samples per hold");
  }
}

}  // namespace

CubeTrialResult runCubeTrial(const CubeTrialOptions& options) {
  validate(options);
  CubeTrialResult result;
  result.options = options;
  result.compensated.name = "compensated";
  result.uncompensated.name = "uncompensated";
  result.pointer.name = "pointer";
  result.front_only_compensated.name = "front_only_compensated";
  const Scene s = makeScene(options.cube_edge_mm);
  // View axes in the hologram frame: from the user's head to the cube.
  const std::vector<Eigen::Vector3d> views = {
      Eigen::Vector3d(0, 0.3, 1).normalized(),     // front (slightly from above)
      Eigen::Vector3d(1, 0.3, 0.2).normalized(),   // left: looking towards +x
      Eigen::Vector3d(-1, 0.3, 0.2).normalized(),  // right
      Eigen::Vector3d(0, 1, 0.15).normalized(),    // ground: looking down at the cube
  };
  Eigen::Vector3d axis_c = Eigen::Vector3d::Zero(), axis_u = axis_c, axis_p = axis_c, axis_f = axis_c;
  double dropped = 0.0, total = 0.0;
  for (int trial = 0; trial < options.trials; ++trial) {
    Simulator sim(options, options.seed * 1000003ULL + static_cast<std::uint64_t>(trial));
    const CubeNoiseModel& n = sim.noise();
    const double bias = sim.gauss(n.depth_bias_mm);
    const Eigen::Vector3d& c = s.cube_centre_hologram;

    // Physical vertex (tracker) during a hold: truth * alignment error * hand motion, + tracking.
    auto sampleHold = [&](const Eigen::Vector3d& view) {
      const Eigen::Isometry3d E = sim.alignmentError(view, bias, c);
      const auto motion = sim.holdMotion(c);
      std::vector<std::vector<Eigen::Vector3d>> samples(8);
      for (const auto& M : motion) {
        for (int i = 0; i < 8; ++i) {
          samples[static_cast<std::size_t>(i)].push_back(s.tracker_T_hologram *
                                                             (E * (M * s.cube_hologram[static_cast<std::size_t>(i)])) +
                                                         sim.gauss3(n.tracking_mm));
        }
      }
      return samples;
    };

    // (a) four views, tremor compensation, multi-view averaging.
    std::vector<Eigen::Isometry3d> per_view;
    for (const auto& view : views) {
      const auto samples = sampleHold(view);
      const auto v = calibrateViewWithTremorCompensation(samples, s.cube_hologram, options.tremor);
      per_view.push_back(v.calibration.tracker_T_hololens);
      for (std::size_t i = 0; i < samples.size(); ++i) {
        dropped += v.dropped_samples[i];
        total += static_cast<double>(samples[i].size());
      }
    }
    const MultiViewResult mv = averageViews(per_view);
    result.mean_view_spread_deg += mv.max_pairwise_rotation_rad / kDeg / options.trials;
    double spread_mm = 0.0;
    for (const auto& a : per_view) {
      for (const auto& b : per_view) spread_mm = std::max(spread_mm, (a * c - b * c).norm());
    }
    result.mean_view_spread_mm += spread_mm / options.trials;
    score(s, mv.tracker_T_hololens, result.compensated, axis_c);

    // (b) four matches from the front view, one sample per match (the confirmation instant).
    std::vector<Eigen::Isometry3d> matches;
    for (int m = 0; m < options.uncompensated_matches; ++m) {
      const auto samples = sampleHold(views[0]);
      const auto k = static_cast<std::size_t>(sim.uniform(0.0, static_cast<double>(samples[0].size()) - 1e-9));
      std::vector<Eigen::Vector3d> at_click;
      for (const auto& set : samples) at_click.push_back(set[k]);
      matches.push_back(calibrateCube(at_click, s.cube_hologram).tracker_T_hololens);
    }
    score(s, averageViews(matches).tracker_T_hololens, result.uncompensated, axis_u);

    // Ablation: the tremor filter alone (one view, four matches, compensated).
    std::vector<Eigen::Isometry3d> front_views;
    for (int m = 0; m < options.uncompensated_matches; ++m) {
      const auto samples = sampleHold(views[0]);
      front_views.push_back(
          calibrateViewWithTremorCompensation(samples, s.cube_hologram, options.tremor).calibration.tracker_T_hololens);
    }
    score(s, averageViews(front_views).tracker_T_hololens, result.front_only_compensated, axis_f);

    // (c) pointer: the stylus tip on each hologram fiducial, front view, one click each.
    const Eigen::Vector3d tip_error = sim.gauss3(n.pointer_tip_error_mm);
    std::vector<Eigen::Vector3d> tips;
    for (const auto& p : s.cube_hologram) {
      const auto motion = sim.holdMotion(c);
      const auto& M = motion[static_cast<std::size_t>(sim.uniform(0.0, static_cast<double>(motion.size()) - 1e-9))];
      const Eigen::Vector3d perceived =
          p + sim.perceptionOffset(views[0], bias, n.pointer_depth_error_mm, n.pointer_lateral_error_mm) +
          sim.gauss3(n.slam_jitter_mm);
      tips.push_back(s.tracker_T_hologram * (M * perceived) + s.tracker_T_hologram.linear() * tip_error +
                     sim.gauss3(n.tracking_mm));
    }
    score(s, calibrateCube(tips, s.cube_hologram).tracker_T_hololens, result.pointer, axis_p);
  }
  summarise(result.compensated, axis_c);
  summarise(result.uncompensated, axis_u);
  summarise(result.pointer, axis_p);
  summarise(result.front_only_compensated, axis_f);
  result.improvement_vs_uncompensated_percent =
      100.0 * (result.uncompensated.mean_rms_mm - result.compensated.mean_rms_mm) / result.uncompensated.mean_rms_mm;
  result.improvement_vs_pointer_percent =
      100.0 * (result.pointer.mean_rms_mm - result.compensated.mean_rms_mm) / result.pointer.mean_rms_mm;
  result.mean_dropped_fraction = total > 0.0 ? dropped / total : 0.0;
  return result;
}

}  // namespace mrsns::hmd
