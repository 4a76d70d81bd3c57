// Time series of poses and scalars: exact interpolation of a motion slerp+lerp represents
// exactly (constant angular velocity about a body axis, constant linear velocity), gaps,
// invalid samples, extrapolation limits, ring-buffer mode and resampling.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/time_series.h"

namespace mrsns {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// tracker_T_tool(t): rotating at a constant body angular velocity while the origin moves at a
// constant velocity. Slerp + linear interpolation reproduce this motion exactly.
Eigen::Isometry3d motion(double t) {
  const Eigen::Matrix3d R0 = so3Exp(Eigen::Vector3d(0.2, -0.7, 1.1));
  const Eigen::Vector3d omega(0.3, 0.5, -0.4);  // rad/s
  const Eigen::Vector3d p0(100.0, -20.0, 350.0);
  const Eigen::Vector3d v(12.0, 3.0, -8.0);  // mm/s
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R0 * so3Exp(t * omega);
  T.translation() = p0 + t * v;
  return T;
}

double poseError(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return std::max(rotationAngleBetween(a.linear(), b.linear()), (a.translation() - b.translation()).norm());
}

PoseTimeSeries sampledMotion(const std::vector<double>& times, TimeSeriesOptions options = {}) {
  PoseTimeSeries series(options);
  for (double t : times) series.append(t, motion(t));
  return series;
}

TEST(TimeSeries, AppendRejectsNanAndNonIncreasingTimes) {
  PoseTimeSeries series;
  series.append(1.0, motion(1.0));
  EXPECT_THROW(series.append(kNaN, motion(2.0)), InvalidArgumentError);
  EXPECT_THROW(series.append(1.0, motion(1.0)), InvalidArgumentError);  // duplicate time
  EXPECT_THROW(series.append(0.5, motion(0.5)), InvalidArgumentError);
  Eigen::Isometry3d nan_pose = motion(2.0);
  nan_pose.translation().x() = kNaN;
  EXPECT_THROW(series.append(2.0, nan_pose), InvalidArgumentError);
  EXPECT_FALSE(series.tryAppend(0.5, motion(0.5)));
  EXPECT_FALSE(series.tryAppend(2.0, nan_pose));
  EXPECT_EQ(series.size(), 1u);
  // A missing tool may be reported with a NaN pose if it is marked invalid.
  EXPECT_TRUE(series.tryAppend(2.0, nan_pose, SampleStatus::kInvalid));
  EXPECT_TRUE(series.back().value.matrix().allFinite());
  EXPECT_EQ(series.size(), 2u);

  ScalarTimeSeries scalars;
  EXPECT_THROW(scalars.append(0.0, kNaN), InvalidArgumentError);
  EXPECT_THROW(scalars.append(std::numeric_limits<double>::infinity(), 1.0), InvalidArgumentError);
  EXPECT_TRUE(scalars.empty());
}

TEST(TimeSeries, PoseInterpolationIsExactAtAndBetweenSamples) {
  const std::vector<double> times = {0.0, 0.1, 0.35, 0.4, 1.0, 2.5};
  const PoseTimeSeries series = sampledMotion(times);
  for (double t : times) {
    const Interpolated<Eigen::Isometry3d> r = series.interpolate(t);
    ASSERT_EQ(r.status, InterpolationStatus::kOk);
    EXPECT_EQ(r.gap, 0.0);
    EXPECT_TRUE(r.value.isApprox(motion(t), 0.0));  // the stored sample itself
  }
  for (double t = 0.0; t <= 2.5; t += 0.0137) {
    const Interpolated<Eigen::Isometry3d> r = series.interpolate(t);
    ASSERT_TRUE(r.ok()) << t;
    EXPECT_LT(poseError(r.value, motion(t)), 1e-9) << t;
  }
}

TEST(TimeSeries, ScrewMotionDeviatesByExactlyTheChordSagitta) {
  // A constant SE(3) twist moves the origin on a helix of radius r about the screw axis. Slerp
  // keeps the rotation exact; linear interpolation of the translation cuts the chord, whose
  // midpoint lies r (1 - cos(w dt / 2)) inside the arc (the axial part is linear, so exact).
  const double w = 0.8;      // rad/s
  const double r = 100.0;    // mm
  const double pitch = 5.0;  // mm/rad
  const double dt = 0.05;
  const Eigen::Vector3d axis = Eigen::Vector3d(1, 2, 2) / 3.0;
  const Eigen::Vector3d center = r * axis.cross(Eigen::Vector3d::UnitX()).normalized();  // on the axis, r from 0
  Vector6d xi;
  xi << -(w * axis).cross(center) + pitch * w * axis, w * axis;
  PoseTimeSeries series;
  for (int k = 0; k <= 20; ++k) series.append(k * dt, se3Exp(k * dt * xi));
  const double sagitta = r * (1.0 - std::cos(w * dt / 2.0));
  for (int k = 0; k < 20; ++k) {
    const double t = (k + 0.5) * dt;
    const Interpolated<Eigen::Isometry3d> r_t = series.interpolate(t);
    ASSERT_TRUE(r_t.ok());
    const Eigen::Isometry3d truth = se3Exp(t * xi);
    EXPECT_LT(rotationAngleBetween(r_t.value.linear(), truth.linear()), 1e-12);
    EXPECT_NEAR((r_t.value.translation() - truth.translation()).norm(), sagitta, 1e-9) << t;
  }
}

TEST(TimeSeries, ScalarInterpolationIsLinear) {
  ScalarTimeSeries series;
  series.append(0.0, 1.0);
  series.append(2.0, 5.0);
  series.append(3.0, -1.0);
  EXPECT_DOUBLE_EQ(series.interpolate(0.5).value, 2.0);
  EXPECT_DOUBLE_EQ(series.interpolate(2.5).value, 2.0);
  EXPECT_DOUBLE_EQ(series.interpolate(2.0).value, 5.0);
  EXPECT_EQ(series.interpolate(2.5).gap, 1.0);
}

TEST(TimeSeries, GapsLargerThanTheLimitAreNotBridged) {
  TimeSeriesOptions options;
  options.max_gap = 0.2;
  const PoseTimeSeries series = sampledMotion({0.0, 0.1, 0.5, 0.6}, options);
  EXPECT_EQ(series.interpolate(0.05).status, InterpolationStatus::kOk);
  const Interpolated<Eigen::Isometry3d> in_gap = series.interpolate(0.3);
  EXPECT_EQ(in_gap.status, InterpolationStatus::kGapTooLarge);
  EXPECT_FALSE(in_gap.ok());
  EXPECT_NEAR(in_gap.gap, 0.4, 1e-15);
  EXPECT_TRUE(in_gap.value.isApprox(Eigen::Isometry3d::Identity()));
  // The samples on either side of the gap are still exact.
  EXPECT_EQ(series.interpolate(0.1).status, InterpolationStatus::kOk);
  EXPECT_EQ(series.interpolate(0.5).status, InterpolationStatus::kOk);
  EXPECT_THROW(PoseTimeSeries(TimeSeriesOptions{.max_gap = 0.0}), InvalidArgumentError);
  EXPECT_THROW(PoseTimeSeries(TimeSeriesOptions{.max_extrapolation = -1.0}), InvalidArgumentError);
}

TEST(TimeSeries, NoExtrapolationUnlessAsked) {
  const PoseTimeSeries strict = sampledMotion({1.0, 1.1, 1.2});
  EXPECT_EQ(strict.interpolate(0.99).status, InterpolationStatus::kOutOfRange);
  EXPECT_EQ(strict.interpolate(1.2000001).status, InterpolationStatus::kOutOfRange);

  TimeSeriesOptions options;
  options.max_extrapolation = 0.1;
  const PoseTimeSeries lenient = sampledMotion({1.0, 1.1, 1.2}, options);
  const Interpolated<Eigen::Isometry3d> ahead = lenient.interpolate(1.25);
  EXPECT_EQ(ahead.status, InterpolationStatus::kExtrapolated);
  EXPECT_TRUE(ahead.ok());
  EXPECT_LT(poseError(ahead.value, motion(1.25)), 1e-9);  // same constant-velocity motion
  EXPECT_LT(poseError(lenient.interpolate(0.95).value, motion(0.95)), 1e-9);
  EXPECT_EQ(lenient.interpolate(1.31).status, InterpolationStatus::kOutOfRange);

  ScalarTimeSeries one(options);
  one.append(0.0, 7.0);
  EXPECT_EQ(one.interpolate(0.05).status, InterpolationStatus::kExtrapolated);
  EXPECT_EQ(one.interpolate(0.05).value, 7.0);  // a single sample is held
}

TEST(TimeSeries, InvalidSamplesPoisonOnlyTheirNeighbourhood) {
  PoseTimeSeries series;
  series.append(0.0, motion(0.0));
  series.append(0.1, motion(0.1));
  series.append(0.2, Eigen::Isometry3d::Identity(), SampleStatus::kInvalid);
  series.append(0.3, motion(0.3));
  series.append(0.4, motion(0.4));
  EXPECT_EQ(series.interpolate(0.05).status, InterpolationStatus::kOk);
  EXPECT_EQ(series.interpolate(0.15).status, InterpolationStatus::kInvalidSample);
  EXPECT_EQ(series.interpolate(0.2).status, InterpolationStatus::kInvalidSample);
  EXPECT_EQ(series.interpolate(0.25).status, InterpolationStatus::kInvalidSample);
  EXPECT_EQ(series.interpolate(0.1).status, InterpolationStatus::kOk);
  EXPECT_EQ(series.interpolate(0.3).status, InterpolationStatus::kOk);
  EXPECT_LT(poseError(series.interpolate(0.35).value, motion(0.35)), 1e-9);
  EXPECT_STREQ(toString(InterpolationStatus::kInvalidSample), "invalid sample");
}

TEST(TimeSeries, EmptySeriesAndBadQueriesReportStatus) {
  PoseTimeSeries series;
  EXPECT_EQ(series.interpolate(0.0).status, InterpolationStatus::kEmpty);
  EXPECT_FALSE(series.timeRange().has_value());
  EXPECT_FALSE(series.nearest(0.0).has_value());
  series.append(0.0, motion(0.0));
  EXPECT_EQ(series.interpolate(kNaN).status, InterpolationStatus::kInvalidQuery);
  EXPECT_EQ(series.interpolate(std::numeric_limits<double>::infinity()).status, InterpolationStatus::kInvalidQuery);
  EXPECT_FALSE(series.nearest(kNaN).has_value());
}

TEST(TimeSeries, NearestSampleAndTimeRange) {
  ScalarTimeSeries series;
  series.append(0.0, 0.0);
  series.append(1.0, 10.0);
  series.append(2.0, 20.0, SampleStatus::kInvalid);
  series.append(4.0, 40.0);
  EXPECT_EQ(series.nearest(-5.0)->time, 0.0);
  EXPECT_EQ(series.nearest(0.4)->time, 0.0);
  EXPECT_EQ(series.nearest(0.5)->time, 0.0);  // tie: the earlier
  EXPECT_EQ(series.nearest(0.6)->time, 1.0);
  EXPECT_EQ(series.nearest(2.2)->time, 2.0);
  EXPECT_EQ(series.nearest(2.2, true)->time, 1.0);
  EXPECT_EQ(series.nearest(2.9, true)->time, 4.0);
  EXPECT_EQ(series.nearest(100.0)->time, 4.0);
  const auto range = series.timeRange();
  ASSERT_TRUE(range.has_value());
  EXPECT_EQ(range->first, 0.0);
  EXPECT_EQ(range->second, 4.0);
}

TEST(TimeSeries, RingBufferDropsTheOldestSample) {
  TimeSeriesOptions options;
  options.capacity = 3;
  PoseTimeSeries series(options);
  for (int i = 0; i < 5; ++i) series.append(0.1 * i, motion(0.1 * i));
  EXPECT_EQ(series.size(), 3u);
  EXPECT_DOUBLE_EQ(series.front().time, 0.2);
  EXPECT_DOUBLE_EQ(series.back().time, 0.4);
  EXPECT_EQ(series.interpolate(0.15).status, InterpolationStatus::kOutOfRange);
  EXPECT_LT(poseError(series.interpolate(0.35).value, motion(0.35)), 1e-9);
  // Time order is still enforced after wrapping.
  EXPECT_FALSE(series.tryAppend(0.3, motion(0.3)));
}

TEST(TimeSeries, ResampleOnUniformGrid) {
  TimeSeriesOptions options;
  options.max_gap = 0.3;
  const PoseTimeSeries series = sampledMotion({0.0, 0.13, 0.31, 0.5, 1.0, 1.2}, options);
  const PoseTimeSeries grid = series.resample(0.1);
  ASSERT_EQ(grid.size(), 13u);  // 0.0, 0.1, ..., 1.2
  for (std::size_t k = 0; k < grid.size(); ++k) {
    const double t = 0.1 * static_cast<double>(k);
    EXPECT_NEAR(grid[k].time, t, 1e-15);
    const bool in_gap = grid[k].time > 0.5 && grid[k].time < 1.0;  // 0.5 s gap > max_gap
    EXPECT_EQ(grid[k].status, in_gap ? SampleStatus::kInvalid : SampleStatus::kValid) << t;
    if (!in_gap) {
      EXPECT_LT(poseError(grid[k].value, motion(grid[k].time)), 1e-9) << t;
    }
  }
  const PoseTimeSeries custom = series.resample(-1.0, 0.5, 4);  // -1, -0.5 out of range
  ASSERT_EQ(custom.size(), 4u);
  EXPECT_EQ(custom[0].status, SampleStatus::kInvalid);
  EXPECT_EQ(custom[2].status, SampleStatus::kValid);
  EXPECT_EQ(custom[3].status, SampleStatus::kValid);
  EXPECT_THROW((void)series.resample(0.0), InvalidArgumentError);
  EXPECT_THROW((void)series.resample(0.0, kNaN, 3), InvalidArgumentError);
  EXPECT_TRUE(PoseTimeSeries().resample(0.1).empty());
}

}  // namespace
}  // namespace mrsns
