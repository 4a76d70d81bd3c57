// The tracker lag estimated from the calibration frames themselves: frames
// simulated from a smooth freehand sweep whose recorded poses trail the
// images by a known lag; the property that a zero lag changes nothing; and
// the refusals.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/ultrasound/tracker_lag.h"
#include "synthetic_fcal.h"

namespace mrsns::ultrasound {
namespace {

struct LagCase {
  test::Truth truth;
  std::vector<NWirePattern> patterns = nwireGeometry(test::fcalPhantom());
  std::vector<CalibrationFrame> frames;
  std::vector<double> times;
  std::vector<FramePose> poses;
};

// A hand sweep: the image plane slides 20 mm along the wires and tilts by a
// few degrees, at unrelated frequencies, over 16 s at 12.5 frames/s. Each
// frame's recorded pose is the one of `lag_s` earlier (the tracker stamps
// an instant lag_s late). Dots carry Gaussian noise of `dot_noise_px`.
LagCase makeCase(double lag_s, double dot_noise_px, unsigned seed) {
  LagCase c;
  c.truth.probe_T_image_rigid.linear() = so3Exp(Eigen::Vector3d(0.1, -1.5, 0.05));
  c.truth.probe_T_image_rigid.translation() = Eigen::Vector3d(11.0, 46.0, -7.0);
  c.truth.reference_T_phantom.linear() = so3Exp(Eigen::Vector3d(0.3, 2.0, -0.4));
  c.truth.reference_T_phantom.translation() = Eigen::Vector3d(9.6, 36.0, 87.9);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, dot_noise_px);
  const auto plane_at = [](double t) {
    Eigen::Isometry3d p = test::nominalPlane(20.0 + 10.0 * std::sin(0.9 * t));
    p.linear() = p.linear() * so3Exp(Eigen::Vector3d(0.10 * std::sin(1.3 * t + 0.4), 0.07 * std::sin(0.7 * t + 1.1),
                                                     0.04 * std::sin(1.9 * t)));
    p.translation() += Eigen::Vector3d(2.0 * std::sin(1.1 * t + 2.0), 0.0, 1.5 * std::sin(0.5 * t + 0.3));
    return p;
  };
  const auto probe_pose = [&](const Eigen::Isometry3d& phantom_T_image) {
    return c.truth.reference_T_phantom * phantom_T_image * c.truth.probe_T_image_rigid.inverse();
  };
  for (int i = 0; i < 200; ++i) {
    const double t = i * 0.08;
    const Eigen::Isometry3d image_T_phantom = plane_at(t).inverse();
    CalibrationFrame f;
    f.frame_index = static_cast<std::size_t>(i);
    for (const auto& p : c.patterns) {
      for (int w = 0; w < 3; ++w) {
        const Eigen::Vector3d a = image_T_phantom * p.front[w];
        const Eigen::Vector3d d = image_T_phantom.linear() * p.direction[w];
        const Eigen::Vector3d hit = a - d * (a.z() / d.z());
        f.wire_points_px.emplace_back(hit.x() / c.truth.spacing.x() + noise(rng),
                                      hit.y() / c.truth.spacing.y() + noise(rng));
      }
    }
    f.reference_T_probe = probe_pose(plane_at(t - lag_s));
    c.frames.push_back(f);
    c.times.push_back(t);
    c.poses.push_back(FramePose{f.frame_index, t, f.reference_T_probe, TransformStatus::Ok});
  }
  return c;
}

TEST(TrackerLag, RecoversAKnownLagFromTheSweep) {
  // Noise model: 0.5 px dot noise (the wire blur of the real recording gives
  // ~0.6 px between two segmenters). The lag is recovered to a fraction of
  // the 80 ms frame period; 10 ms is an eighth of it.
  for (const double lag : {0.064, -0.12, 0.3}) {
    const auto c = makeCase(lag, 0.5, 3);
    TrackerLagOptions options;
    options.estimate = true;
    options.search_half_range_s = 0.5;
    const auto est =
        estimateTrackerLag(c.frames, c.times, c.poses, c.patterns, c.truth.reference_T_phantom, {}, options);
    EXPECT_TRUE(est.estimated);
    EXPECT_NEAR(est.lag_s, lag, 0.010) << "injected " << lag * 1e3 << " ms";
    EXPECT_GT(est.curvature_mm_per_s2, 0.0);
    EXPECT_EQ(est.curve.size(), 51u);
  }
}

TEST(TrackerLag, ZeroLagPairsEveryFrameWithItsOwnPose) {
  const auto c = makeCase(0.0, 0.0, 4);
  const auto paired = pairWithTrackerLag(c.frames, c.times, c.poses, 0.0);
  ASSERT_EQ(paired.size(), c.frames.size());
  for (std::size_t i = 0; i < paired.size(); ++i) {
    EXPECT_TRUE(paired[i].reference_T_probe.isApprox(c.frames[i].reference_T_probe, 1e-12));
  }
  // A margin drops the frames whose shifted window leaves the pose stream.
  const auto inner = pairWithTrackerLag(c.frames, c.times, c.poses, 0.0, 0.2);
  EXPECT_EQ(inner.size(), c.frames.size() - 2 * 3);  // 0.2 s at 80 ms: the first and last 3 frames
}

TEST(TrackerLag, GivenLagIsReturnedWithoutSearch) {
  const auto c = makeCase(0.0, 0.0, 5);
  TrackerLagOptions options;
  options.lag_s = 0.042;
  const auto est = estimateTrackerLag(c.frames, c.times, c.poses, c.patterns, c.truth.reference_T_phantom, {}, options);
  EXPECT_FALSE(est.estimated);
  EXPECT_DOUBLE_EQ(est.lag_s, 0.042);
  EXPECT_TRUE(est.curve.empty());
}

TEST(TrackerLag, MinimumAtTheSearchEdgeIsRefused) {
  const auto c = makeCase(0.3, 0.3, 6);
  TrackerLagOptions options;
  options.estimate = true;
  options.search_half_range_s = 0.1;
  EXPECT_THROW(estimateTrackerLag(c.frames, c.times, c.poses, c.patterns, c.truth.reference_T_phantom, {}, options),
               ComputationError);
  options.search_step_s = 0.0;
  EXPECT_THROW(estimateTrackerLag(c.frames, c.times, c.poses, c.patterns, c.truth.reference_T_phantom, {}, options),
               InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::ultrasound
