#pragma once
// Time series of timestamped values for tracking buffers and recordings:
// poses (Eigen::Isometry3d, interpolated by slerp of the rotation and linear
// interpolation of the translation, as PLUS does) and scalars (linear).
//
// Samples are kept sorted by strictly increasing time (seconds). Each carries
// a status: a tracker reports "tool not visible" as an invalid sample, and any
// interpolation that needs an invalid sample reports it instead of inventing
// a value. Queries (interpolate, nearest, timeRange) never throw, because they
// run inside the real-time loop; they return a status. Only building the
// series (append, resample arguments) throws InvalidArgumentError, and
// tryAppend() is the non-throwing form for the acquisition thread.
//
// With a capacity set, the series is a ring buffer that drops its oldest
// sample when full (std::deque: amortised O(1) at both ends, O(log n) lookup).
// Not thread-safe: guard it with the owner's mutex.
#include <Eigen/Geometry>
#include <cstddef>
#include <deque>
#include <limits>
#include <optional>
#include <utility>

namespace mrsns {

enum class SampleStatus { kValid, kInvalid };

template <typename T>
struct TimedSample {
  double time = 0.0;
  T value{};
  SampleStatus status = SampleStatus::kValid;
};

enum class InterpolationStatus {
  kOk,             // at a valid sample or between two valid samples closer than max_gap
  kExtrapolated,   // outside the time range, within max_extrapolation (as requested)
  kEmpty,          // the series has no samples
  kOutOfRange,     // before the first or after the last sample, beyond max_extrapolation
  kGapTooLarge,    // the samples around the query are further apart than max_gap
  kInvalidSample,  // a sample the result depends on is marked invalid
  kInvalidQuery,   // the query time is NaN or infinite
};

/// Short English name of the status, for logs and messages.
const char* toString(InterpolationStatus status);

template <typename T>
struct Interpolated {
  /// The value when ok(); otherwise the type's neutral value (identity pose, 0).
  T value{};
  InterpolationStatus status = InterpolationStatus::kEmpty;
  /// Time between the two samples used (0 at an exact sample or with one sample).
  double gap = 0.0;
  [[nodiscard]] bool ok() const {
    return status == InterpolationStatus::kOk || status == InterpolationStatus::kExtrapolated;
  }
};

struct TimeSeriesOptions {
  /// Interpolation between samples further apart than this (seconds) reports kGapTooLarge.
  double max_gap = std::numeric_limits<double>::infinity();
  /// How far beyond the first/last sample (seconds) interpolate() may extrapolate along the
  /// last two samples (or hold a single sample). 0: no extrapolation.
  double max_extrapolation = 0.0;
  /// Maximum number of samples kept; 0 means unbounded. When full, append drops the oldest.
  std::size_t capacity = 0;
};

template <typename T>
class TimeSeries {
 public:
  using Sample = TimedSample<T>;

  /// Throws InvalidArgumentError when max_gap <= 0 or max_extrapolation < 0 (or NaN).
  explicit TimeSeries(TimeSeriesOptions options = {});

  /// Adds a sample after the last one. Throws InvalidArgumentError when time is not finite or
  /// not strictly later than the last sample, or a valid sample's value is not finite. An
  /// invalid sample with a non-finite value is stored with the neutral value.
  void append(double time, const T& value, SampleStatus status = SampleStatus::kValid);

  /// Same checks as append(); returns false (and keeps the series unchanged) instead of throwing.
  bool tryAppend(double time, const T& value, SampleStatus status = SampleStatus::kValid) noexcept;

  /// Value at `time`: exact at samples, interpolated between them, optionally extrapolated.
  [[nodiscard]] Interpolated<T> interpolate(double time) const noexcept;

  /// The sample closest in time (ties go to the earlier one); with valid_only, the closest
  /// valid sample. nullopt when there is none or time is NaN.
  [[nodiscard]] std::optional<Sample> nearest(double time, bool valid_only = false) const noexcept;

  /// Times of the first and last sample; nullopt when empty.
  [[nodiscard]] std::optional<std::pair<double, double>> timeRange() const noexcept;

  /// The series sampled at start + k * step, k = 0..count-1, with this series' options except
  /// capacity (unbounded). Grid points where interpolate() is not ok() become invalid samples.
  /// Throws InvalidArgumentError when start or step is not finite or step <= 0.
  [[nodiscard]] TimeSeries resample(double start, double step, std::size_t count) const;

  /// resample() over timeRange(): from the first sample every `step` up to the last one.
  /// An empty series gives an empty series.
  [[nodiscard]] TimeSeries resample(double step) const;

  [[nodiscard]] std::size_t size() const noexcept { return samples_.size(); }
  [[nodiscard]] bool empty() const noexcept { return samples_.empty(); }
  [[nodiscard]] const Sample& operator[](std::size_t i) const { return samples_[i]; }
  [[nodiscard]] const Sample& front() const { return samples_.front(); }
  [[nodiscard]] const Sample& back() const { return samples_.back(); }
  [[nodiscard]] auto begin() const noexcept { return samples_.begin(); }
  [[nodiscard]] auto end() const noexcept { return samples_.end(); }
  [[nodiscard]] const TimeSeriesOptions& options() const noexcept { return options_; }
  void clear() noexcept { samples_.clear(); }

 private:
  enum class AppendCheck { kOk, kBadTime, kNotIncreasing, kBadValue };
  AppendCheck check(double time, const T& value, SampleStatus status) const noexcept;
  void push(double time, const T& value, SampleStatus status);
  TimeSeries resampleGrid(double start, double step, std::size_t count, double last_time) const;

  TimeSeriesOptions options_;
  std::deque<Sample> samples_;
};

using PoseTimeSeries = TimeSeries<Eigen::Isometry3d>;
using ScalarTimeSeries = TimeSeries<double>;

extern template class TimeSeries<Eigen::Isometry3d>;
extern template class TimeSeries<double>;

}  // namespace mrsns
