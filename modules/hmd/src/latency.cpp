#include "mrsns/hmd/latency.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <string>

#include "mrsns/core/error.h"

namespace mrsns::hmd {
namespace {

struct Series {
  std::vector<double> t;
  std::vector<double> v;
};

void validate(std::span<const double> times, std::span<const Eigen::Vector3d> positions, const char* name) {
  if (times.size() != positions.size()) {
    throw InvalidArgumentError(std::string("estimateLatency: ") + name + " has " + std::to_string(times.size()) +
                               " times but " + std::to_string(positions.size()) + " positions");
  }
  if (times.size() < 20) {
    throw InvalidArgumentError(std::string("estimateLatency: ") + name + " has " + std::to_string(times.size()) +
                               " samples; record at least 20 (several seconds of motion)");
  }
  for (std::size_t i = 0; i < times.size(); ++i) {
    if (!std::isfinite(times[i]) || !positions[i].allFinite()) {
      throw InvalidArgumentError(std::string("estimateLatency: ") + name + " sample " + std::to_string(i) +
                                 " is not finite");
    }
    if (i > 0 && !(times[i] > times[i - 1])) {
      throw InvalidArgumentError(std::string("estimateLatency: ") + name +
                                 " times are not strictly increasing at sample " + std::to_string(i) +
                                 "; sort the recording and drop repeated frames");
    }
  }
}

// Projection on principal axis `component` (largest variance first); explained variance out.
std::vector<double> principalComponent(std::span<const Eigen::Vector3d> p, int component, Eigen::Vector3d& explained) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& x : p) mean += x;
  mean /= static_cast<double>(p.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& x : p) cov += (x - mean) * (x - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  const Eigen::Vector3d ev = eig.eigenvalues().cwiseMax(0.0);  // ascending
  const double total = ev.sum();
  explained = total > 0.0 ? Eigen::Vector3d(Eigen::Vector3d(ev(2), ev(1), ev(0)) / total) : Eigen::Vector3d::Zero();
  const Eigen::Vector3d axis = eig.eigenvectors().col(2 - component);
  std::vector<double> out;
  out.reserve(p.size());
  for (const auto& x : p) out.push_back(axis.dot(x - mean));
  return out;
}

double interpolate(const std::vector<double>& t, const std::vector<double>& v, double q) {
  const auto it = std::upper_bound(t.begin(), t.end(), q);
  if (it == t.begin()) return v.front();
  if (it == t.end()) return v.back();
  const auto i = static_cast<std::size_t>(it - t.begin());
  const double a = (q - t[i - 1]) / (t[i] - t[i - 1]);
  return (1.0 - a) * v[i - 1] + a * v[i];
}

double medianPeriod(std::span<const double> t) {
  std::vector<double> d;
  for (std::size_t i = 1; i < t.size(); ++i) d.push_back(t[i] - t[i - 1]);
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  return d[d.size() / 2];
}

// Uniform resampling of (t, v) from t0 with period h, n samples, then a centred moving average.
std::vector<double> resample(const std::vector<double>& t, const std::vector<double>& v, double t0, double h,
                             std::size_t n, int half_window) {
  std::vector<double> r(n);
  for (std::size_t i = 0; i < n; ++i) r[i] = interpolate(t, v, t0 + h * static_cast<double>(i));
  if (half_window <= 0) return r;
  std::vector<double> s(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t a = i >= static_cast<std::size_t>(half_window) ? i - static_cast<std::size_t>(half_window) : 0;
    const std::size_t b = std::min(n - 1, i + static_cast<std::size_t>(half_window));
    double sum = 0.0;
    for (std::size_t k = a; k <= b; ++k) sum += r[k];
    s[i] = sum / static_cast<double>(b - a + 1);
  }
  return s;
}

// Vertex offset of the parabola through (-1, a), (0, b), (1, c), in (-0.5, 0.5).
double parabolicOffset(double a, double b, double c) {
  const double den = a - 2.0 * b + c;
  if (std::abs(den) < 1e-300) return 0.0;
  return std::clamp(0.5 * (a - c) / den, -0.5, 0.5);
}

struct Extremum {
  double time;
  bool maximum;
};

std::vector<Extremum> extrema(const std::vector<double>& s, double t0, double h, int half_sep, double prominence_sd) {
  const double n = static_cast<double>(s.size());
  double mean = 0.0, var = 0.0;
  for (double x : s) mean += x / n;
  for (double x : s) var += (x - mean) * (x - mean) / n;
  const double threshold = prominence_sd * std::sqrt(var);
  std::vector<Extremum> out;
  const auto count = static_cast<int>(s.size());
  for (int i = half_sep; i + half_sep < count; ++i) {
    const double x = s[static_cast<std::size_t>(i)];
    const bool is_max = x > mean + threshold;
    const bool is_min = x < mean - threshold;
    if (!is_max && !is_min) continue;
    bool extreme = true;
    for (int k = i - half_sep; k <= i + half_sep && extreme; ++k) {
      if (k == i) continue;
      const double y = s[static_cast<std::size_t>(k)];
      // Ties go to the earlier sample so a flat top is one event.
      extreme = is_max ? (k < i ? y < x : y <= x) : (k < i ? y > x : y >= x);
    }
    if (!extreme) continue;
    const double off = parabolicOffset(s[static_cast<std::size_t>(i - 1)], x, s[static_cast<std::size_t>(i + 1)]);
    out.push_back({t0 + h * (i + off), is_max});
  }
  return out;
}

}  // namespace

LatencyResult estimateLatency(std::span<const double> tracker_times, std::span<const Eigen::Vector3d> tracker_positions,
                              std::span<const double> hmd_times, std::span<const Eigen::Vector3d> hmd_positions,
                              const LatencyOptions& options) {
  validate(tracker_times, tracker_positions, "the tracker series");
  validate(hmd_times, hmd_positions, "the HMD series");
  if (options.component < 0 || options.component > 2) {
    throw InvalidArgumentError("estimateLatency: component must be 0, 1 or 2 (2 = the paper's third component)");
  }
  if (!(options.max_latency_s > 0.0) || !(options.min_event_separation_s > 0.0) || options.smoothing_s < 0.0 ||
      options.resample_rate_hz < 0.0 || options.min_event_prominence_sd < 0.0) {
    throw InvalidArgumentError(
        "estimateLatency: max_latency_s and min_event_separation_s must be positive and the "
        "other options non-negative");
  }
  LatencyResult r;
  Series w{{tracker_times.begin(), tracker_times.end()},
           principalComponent(tracker_positions, options.component, r.tracker_explained_variance)};
  Series s{{hmd_times.begin(), hmd_times.end()},
           principalComponent(hmd_positions, options.component, r.hmd_explained_variance)};

  const double rate = options.resample_rate_hz > 0.0
                          ? options.resample_rate_hz
                          : 2.0 / std::min(medianPeriod(tracker_times), medianPeriod(hmd_times));
  const double h = 1.0 / rate;
  r.grid_period_s = h;
  const double t0 = std::max(w.t.front(), s.t.front());
  const double t1 = std::min(w.t.back(), s.t.back());
  if (!(t1 - t0 > 4.0 * options.max_latency_s)) {
    throw InvalidArgumentError("estimateLatency: the two series overlap for " + std::to_string(std::max(0.0, t1 - t0)) +
                               " s; they must overlap for more than 4 x max_latency_s (are both clocks in seconds?)");
  }
  const auto n = static_cast<std::size_t>(std::floor((t1 - t0) / h)) + 1;
  const int half_window = static_cast<int>(std::lround(0.5 * options.smoothing_s / h));
  const std::vector<double> gw = resample(w.t, w.v, t0, h, n, half_window);
  const std::vector<double> gs = resample(s.t, s.v, t0, h, n, half_window);

  // Normalised cross-correlation over lags in grid steps: HMD at t + lag against tracker at t.
  const int max_lag = static_cast<int>(std::ceil(options.max_latency_s / h));
  auto ncc = [&](int lag) {
    double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
    int count = 0;
    for (int i = 0; i < static_cast<int>(n); ++i) {
      const int j = i + lag;
      if (j < 0 || j >= static_cast<int>(n)) continue;
      const double a = gw[static_cast<std::size_t>(i)], b = gs[static_cast<std::size_t>(j)];
      sa += a, sb += b, saa += a * a, sbb += b * b, sab += a * b;
      ++count;
    }
    const double cov = sab - sa * sb / count;
    const double den = std::sqrt((saa - sa * sa / count) * (sbb - sb * sb / count));
    return den > 0.0 ? cov / den : 0.0;
  };
  std::vector<double> c(static_cast<std::size_t>(2 * max_lag + 1));
  int best = 0;
  for (int lag = -max_lag; lag <= max_lag; ++lag) {
    c[static_cast<std::size_t>(lag + max_lag)] = ncc(lag);
    if (std::abs(c[static_cast<std::size_t>(lag + max_lag)]) > std::abs(c[static_cast<std::size_t>(best + max_lag)])) {
      best = lag;
    }
  }
  // A periodic motion (steady walking) correlates as well at a half period with the opposite sign
  // (PCA axes have no sign) as at the true lag: among peaks within 5 % of the best, take the
  // smallest |lag|, since latencies are short compared with a step.
  const double best_abs = std::abs(c[static_cast<std::size_t>(best + max_lag)]);
  for (int lag = -max_lag + 1; lag < max_lag; ++lag) {
    const double v = std::abs(c[static_cast<std::size_t>(lag + max_lag)]);
    const bool peak = v >= std::abs(c[static_cast<std::size_t>(lag + max_lag - 1)]) &&
                      v >= std::abs(c[static_cast<std::size_t>(lag + max_lag + 1)]);
    if (peak && v >= 0.95 * best_abs && std::abs(lag) < std::abs(best)) best = lag;
  }
  const double sign = c[static_cast<std::size_t>(best + max_lag)] < 0.0 ? -1.0 : 1.0;
  r.component_sign_flipped = sign < 0.0;
  r.xcorr_peak = sign * c[static_cast<std::size_t>(best + max_lag)];
  double refined = best;
  if (best > -max_lag && best < max_lag) {
    refined += parabolicOffset(sign * c[static_cast<std::size_t>(best + max_lag - 1)], r.xcorr_peak,
                               sign * c[static_cast<std::size_t>(best + max_lag + 1)]);
  }
  r.xcorr_latency_s = refined * h;

  // Events: extrema of each series, matched to the nearest HMD extremum of the same kind within
  // max_latency_s (each HMD event used once).
  std::vector<double> gs_signed = gs;
  for (double& x : gs_signed) x *= sign;
  const int half_sep = std::max(1, static_cast<int>(std::lround(0.5 * options.min_event_separation_s / h)));
  const auto ew = extrema(gw, t0, h, half_sep, options.min_event_prominence_sd);
  const auto es = extrema(gs_signed, t0, h, half_sep, options.min_event_prominence_sd);
  std::vector<bool> used(es.size(), false);
  for (const auto& e : ew) {
    int match = -1;
    double best_dt = options.max_latency_s;
    for (std::size_t k = 0; k < es.size(); ++k) {
      if (used[k] || es[k].maximum != e.maximum) continue;
      const double dt = std::abs(es[k].time - e.time);
      if (dt <= best_dt) {
        best_dt = dt;
        match = static_cast<int>(k);
      }
    }
    if (match < 0) continue;
    used[static_cast<std::size_t>(match)] = true;
    r.events.push_back({e.time, es[static_cast<std::size_t>(match)].time,
                        es[static_cast<std::size_t>(match)].time - e.time, e.maximum});
  }
  if (r.events.empty()) {
    throw ComputationError("estimateLatency: no matching events in the principal component " +
                           std::to_string(options.component + 1) +
                           "; the recording needs repeated up-down motion (walking, squats) seen by both systems");
  }
  const double m = static_cast<double>(r.events.size());
  std::vector<double> lat;
  for (const auto& e : r.events) {
    r.event_mean_s += e.latency_s / m;
    lat.push_back(e.latency_s);
  }
  if (r.events.size() > 1) {
    double var = 0.0;
    for (double l : lat) var += (l - r.event_mean_s) * (l - r.event_mean_s);
    r.event_std_s = std::sqrt(var / (m - 1.0));
  }
  std::sort(lat.begin(), lat.end());
  r.event_median_s = lat.size() % 2 ? lat[lat.size() / 2] : 0.5 * (lat[lat.size() / 2 - 1] + lat[lat.size() / 2]);
  return r;
}

}  // namespace mrsns::hmd
