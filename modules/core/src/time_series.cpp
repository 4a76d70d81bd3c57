#include "mrsns/core/time_series.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"

namespace mrsns {
namespace {

// Interpolation and neutral values per value type. The pose form repeats interpolatePose()
// without its argument check so that queries stay noexcept (times are validated on append).
Eigen::Isometry3d neutral(const Eigen::Isometry3d*) {
  return Eigen::Isometry3d::Identity();
}
double neutral(const double*) {
  return 0.0;
}

bool finiteValue(const Eigen::Isometry3d& T) {
  return T.matrix().allFinite();
}
bool finiteValue(double v) {
  return std::isfinite(v);
}

Eigen::Isometry3d blend(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const Eigen::Matrix3d Ra = a.linear();
  T.linear() = Ra * so3Exp(t * so3Log(Ra.transpose() * b.linear()));
  T.translation() = (1.0 - t) * a.translation() + t * b.translation();
  return T;
}
double blend(double a, double b, double t) {
  return (1.0 - t) * a + t * b;
}

template <typename T>
T neutralValue() {
  return neutral(static_cast<const T*>(nullptr));
}

}  // namespace

const char* toString(InterpolationStatus status) {
  switch (status) {
    case InterpolationStatus::kOk: return "ok";
    case InterpolationStatus::kExtrapolated: return "extrapolated";
    case InterpolationStatus::kEmpty: return "no samples";
    case InterpolationStatus::kOutOfRange: return "outside the time range";
    case InterpolationStatus::kGapTooLarge: return "gap between samples too large";
    case InterpolationStatus::kInvalidSample: return "invalid sample";
    case InterpolationStatus::kInvalidQuery: return "query time not finite";
  }
  return "unknown";
}

template <typename T>
TimeSeries<T>::TimeSeries(TimeSeriesOptions options) : options_(options) {
  if (!(options_.max_gap > 0.0)) {
    throw InvalidArgumentError("TimeSeries: max_gap must be > 0 seconds (infinity for no limit)");
  }
  if (!(options_.max_extrapolation >= 0.0)) {
    throw InvalidArgumentError("TimeSeries: max_extrapolation must be >= 0 seconds");
  }
}

template <typename T>
typename TimeSeries<T>::AppendCheck TimeSeries<T>::check(double time, const T& value,
                                                         SampleStatus status) const noexcept {
  if (!std::isfinite(time)) return AppendCheck::kBadTime;
  if (!samples_.empty() && !(time > samples_.back().time)) return AppendCheck::kNotIncreasing;
  if (status == SampleStatus::kValid && !finiteValue(value)) return AppendCheck::kBadValue;
  return AppendCheck::kOk;
}

template <typename T>
void TimeSeries<T>::push(double time, const T& value, SampleStatus status) {
  if (options_.capacity > 0 && samples_.size() >= options_.capacity) samples_.pop_front();
  Sample s;
  s.time = time;
  s.value = finiteValue(value) ? value : neutralValue<T>();
  s.status = status;
  samples_.push_back(s);
}

template <typename T>
void TimeSeries<T>::append(double time, const T& value, SampleStatus status) {
  switch (check(time, value, status)) {
    case AppendCheck::kOk: break;
    case AppendCheck::kBadTime: throw InvalidArgumentError("TimeSeries::append: the timestamp is NaN or infinite");
    case AppendCheck::kNotIncreasing:
      throw InvalidArgumentError("TimeSeries::append: timestamp " + std::to_string(time) +
                                 " s is not later than the last sample (" + std::to_string(samples_.back().time) +
                                 " s); samples must be appended in strictly increasing time");
    case AppendCheck::kBadValue:
      throw InvalidArgumentError("TimeSeries::append: the value at " + std::to_string(time) +
                                 " s contains NaN or infinity; append it with SampleStatus::kInvalid instead");
  }
  push(time, value, status);
}

template <typename T>
bool TimeSeries<T>::tryAppend(double time, const T& value, SampleStatus status) noexcept {
  if (check(time, value, status) != AppendCheck::kOk) return false;
  try {
    push(time, value, status);
  } catch (...) {  // allocation failure: report it as a refused sample
    return false;
  }
  return true;
}

template <typename T>
Interpolated<T> TimeSeries<T>::interpolate(double time) const noexcept {
  Interpolated<T> out;
  out.value = neutralValue<T>();
  if (!std::isfinite(time)) {
    out.status = InterpolationStatus::kInvalidQuery;
    return out;
  }
  if (samples_.empty()) {
    out.status = InterpolationStatus::kEmpty;
    return out;
  }
  const double first = samples_.front().time;
  const double last = samples_.back().time;

  // Pick the two samples to blend (i0 < i1) or the single one to return.
  std::size_t i0 = 0;
  std::size_t i1 = 0;
  bool outside = false;
  if (time < first || time > last) {
    if (std::max(first - time, time - last) > options_.max_extrapolation) {
      out.status = InterpolationStatus::kOutOfRange;
      return out;
    }
    outside = true;
    if (samples_.size() >= 2) {
      i0 = time < first ? 0 : samples_.size() - 2;
      i1 = i0 + 1;
    } else {
      i0 = i1 = 0;
    }
  } else {
    const auto it =
        std::lower_bound(samples_.begin(), samples_.end(), time, [](const Sample& s, double t) { return s.time < t; });
    i1 = static_cast<std::size_t>(it - samples_.begin());  // first sample with time >= query
    if (samples_[i1].time == time) {
      i0 = i1;
    } else {
      i0 = i1 - 1;  // i1 > 0 because time >= first
    }
  }

  const Sample& a = samples_[i0];
  const Sample& b = samples_[i1];
  if (a.status != SampleStatus::kValid || b.status != SampleStatus::kValid) {
    out.status = InterpolationStatus::kInvalidSample;
    return out;
  }
  if (i0 == i1) {
    out.value = a.value;
    out.status = outside ? InterpolationStatus::kExtrapolated : InterpolationStatus::kOk;
    return out;
  }
  out.gap = b.time - a.time;
  if (out.gap > options_.max_gap) {
    out.status = InterpolationStatus::kGapTooLarge;
    return out;
  }
  out.value = blend(a.value, b.value, (time - a.time) / out.gap);
  out.status = outside ? InterpolationStatus::kExtrapolated : InterpolationStatus::kOk;
  return out;
}

template <typename T>
std::optional<typename TimeSeries<T>::Sample> TimeSeries<T>::nearest(double time, bool valid_only) const noexcept {
  if (std::isnan(time) || samples_.empty()) return std::nullopt;
  const auto it =
      std::lower_bound(samples_.begin(), samples_.end(), time, [](const Sample& s, double t) { return s.time < t; });
  const auto ok = [&](const Sample& s) { return !valid_only || s.status == SampleStatus::kValid; };
  // Walk outwards from the insertion point; the first acceptable sample on each side competes.
  std::optional<Sample> before;
  std::optional<Sample> after;
  for (auto b = it; b != samples_.begin();) {
    --b;
    if (ok(*b)) {
      before = *b;
      break;
    }
  }
  for (auto a = it; a != samples_.end(); ++a) {
    if (ok(*a)) {
      after = *a;
      break;
    }
  }
  if (!before) return after;
  if (!after) return before;
  return (after->time - time) < (time - before->time) ? after : before;
}

template <typename T>
std::optional<std::pair<double, double>> TimeSeries<T>::timeRange() const noexcept {
  if (samples_.empty()) return std::nullopt;
  return std::make_pair(samples_.front().time, samples_.back().time);
}

template <typename T>
TimeSeries<T> TimeSeries<T>::resample(double start, double step, std::size_t count) const {
  if (!std::isfinite(start) || !std::isfinite(step) || step <= 0.0) {
    throw InvalidArgumentError(
        "TimeSeries::resample: start must be finite and step a finite positive number of "
        "seconds");
  }
  return resampleGrid(start, step, count, std::numeric_limits<double>::infinity());
}

template <typename T>
TimeSeries<T> TimeSeries<T>::resampleGrid(double start, double step, std::size_t count, double last_time) const {
  TimeSeriesOptions grid_options = options_;
  grid_options.capacity = 0;
  TimeSeries out(grid_options);
  for (std::size_t k = 0; k < count; ++k) {
    // Multiplying rather than accumulating keeps grid times free of drift.
    const double t = std::min(start + static_cast<double>(k) * step, last_time);
    const Interpolated<T> v = interpolate(t);
    out.push(t, v.value, v.ok() ? SampleStatus::kValid : SampleStatus::kInvalid);
  }
  return out;
}

template <typename T>
TimeSeries<T> TimeSeries<T>::resample(double step) const {
  if (!std::isfinite(step) || step <= 0.0) {
    throw InvalidArgumentError("TimeSeries::resample: step must be a finite positive number of seconds");
  }
  if (samples_.empty()) {
    TimeSeriesOptions grid_options = options_;
    grid_options.capacity = 0;
    return TimeSeries(grid_options);
  }
  const double first = samples_.front().time;
  const double span = samples_.back().time - first;
  // The small allowance keeps the last sample on the grid despite rounding of span / step.
  const auto count = static_cast<std::size_t>(std::floor(span / step * (1.0 + 1e-12) + 1e-9)) + 1;
  // 0.1 * 12 > 1.2 in floating point: the last grid point is clamped onto the last sample.
  return resampleGrid(first, step, count, samples_.back().time);
}

template class TimeSeries<Eigen::Isometry3d>;
template class TimeSeries<double>;

}  // namespace mrsns
