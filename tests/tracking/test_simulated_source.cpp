// Simulator: determinism, noise statistics, scripted motions, dropouts.
#include <gtest/gtest.h>

#include <cmath>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/tracking/simulated_source.h"

namespace mrsns::tracking {
namespace {

std::shared_ptr<TransformRepository> makeRepository() {
  return std::make_shared<TransformRepository>();
}

SimulatorOptions twoTools(std::uint64_t seed) {
  SimulatorOptions options;
  options.seed = seed;
  ToolScript stylus;
  stylus.name = "StylusToTracker";
  stylus.motion = PivotMotion{};
  stylus.tremor = Tremor{};
  ToolScript probe;
  probe.name = "ProbeToTracker";
  probe.motion = CircularSweep{};
  options.tools = {stylus, probe};
  options.noise.orientation_rms = 0.002;
  return options;
}

std::vector<Eigen::Matrix4d> record(SimulatedTrackingSource& source, int n, const std::string& name) {
  std::vector<Eigen::Matrix4d> poses;
  for (int i = 0; i < n; ++i) {
    source.step(0.01 * i);
    poses.push_back(source.repository().getTransform(name).to_T_from.matrix());
  }
  return poses;
}

TEST(Simulator, SameSeedGivesIdenticalSamplesAndAnotherSeedDoesNot) {
  SimulatedTrackingSource a(makeRepository(), twoTools(42));
  SimulatedTrackingSource b(makeRepository(), twoTools(42));
  SimulatedTrackingSource c(makeRepository(), twoTools(43));
  const auto pa = record(a, 50, "StylusToTracker");
  const auto pb = record(b, 50, "StylusToTracker");
  const auto pc = record(c, 50, "StylusToTracker");
  for (std::size_t i = 0; i < pa.size(); ++i) {
    EXPECT_EQ(pa[i], pb[i]) << "sample " << i;  // bit for bit
    EXPECT_NE(pa[i], pc[i]) << "sample " << i;
  }
}

// The measured 3D RMS of N noise samples (each the sum of 3 squared N(0, s^2))
// has relative standard error sqrt(Var(|e|^2)) / (2 E|e|^2 sqrt(N)) =
// sqrt(6 s^4) / (2 * 3 s^2 * sqrt(N)) = 1 / sqrt(6 N). 4 sigma bounds.
TEST(Simulator, PositionNoiseRmsMatchesTheConfiguredValueWithinSamplingError) {
  for (const double rms : {0.25, 0.35}) {
    SimulatorOptions options;
    options.seed = 7;
    options.noise.position_rms_mm = rms;
    ToolScript tool;
    tool.name = "ToolToTracker";
    options.tools = {tool};
    SimulatedTrackingSource source(makeRepository(), options);
    constexpr int kSamples = 20000;
    double sum_sq = 0.0;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Vector3d sum_sq_axis = Eigen::Vector3d::Zero();
    for (int i = 0; i < kSamples; ++i) {
      source.step(0.001 * i);
      const Eigen::Vector3d e = source.repository().getTransform("ToolToTracker").to_T_from.translation();
      sum_sq += e.squaredNorm();
      sum += e;
      sum_sq_axis += e.cwiseProduct(e);
    }
    const double measured = std::sqrt(sum_sq / kSamples);
    const double relative_se = 1.0 / std::sqrt(6.0 * kSamples);
    EXPECT_NEAR(measured / rms, 1.0, 4.0 * relative_se) << "rms " << rms;
    // Zero mean (per-axis sigma rms/sqrt(3), standard error of the mean sigma/sqrt(N)) and isotropy.
    const double sigma = rms / std::sqrt(3.0);
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(sum[a] / kSamples, 0.0, 4.0 * sigma / std::sqrt(kSamples)) << "axis " << a;
      // Per-axis variance: relative standard error sqrt(2/N).
      EXPECT_NEAR(sum_sq_axis[a] / kSamples / (sigma * sigma), 1.0, 4.0 * std::sqrt(2.0 / kSamples)) << "axis " << a;
    }
  }
}

TEST(Simulator, OrientationNoiseRmsMatchesTheConfiguredAngle) {
  SimulatorOptions options;
  options.seed = 11;
  options.noise.position_rms_mm = 0.0;
  options.noise.orientation_rms = 0.003;
  ToolScript tool;
  tool.name = "ToolToTracker";
  options.tools = {tool};
  SimulatedTrackingSource source(makeRepository(), options);
  constexpr int kSamples = 20000;
  double sum_sq = 0.0;
  for (int i = 0; i < kSamples; ++i) {
    source.step(0.001 * i);
    const auto pose = source.repository().getTransform("ToolToTracker").to_T_from;
    EXPECT_LT(pose.translation().norm(), 1e-12);
    sum_sq += so3Log(pose.linear()).squaredNorm();
  }
  // Same chi-square argument as for positions: relative standard error 1/sqrt(6N).
  EXPECT_NEAR(std::sqrt(sum_sq / kSamples) / 0.003, 1.0, 4.0 / std::sqrt(6.0 * kSamples));
}

TEST(Simulator, PivotMotionKeepsTheTipOnThePivotPoint) {
  SimulatorOptions options;
  options.noise.position_rms_mm = 0.0;
  ToolScript tool;
  tool.name = "StylusToTracker";
  PivotMotion pivot;
  pivot.pivot_tracker = Eigen::Vector3d(10.0, -20.0, -900.0);
  pivot.tip_tool = Eigen::Vector3d(1.0, 2.0, -160.0);
  tool.motion = pivot;
  options.tools = {tool};
  SimulatedTrackingSource source(makeRepository(), options);
  double max_angle = 0.0;
  for (int i = 0; i < 400; ++i) {
    source.step(0.01 * i);
    const auto pose = source.repository().getTransform("StylusToTracker").to_T_from;
    EXPECT_LT((pose * pivot.tip_tool - pivot.pivot_tracker).norm(), 1e-9);
    max_angle = std::max(max_angle, rotationAngle(pose.linear()));
  }
  EXPECT_GT(max_angle, 0.25);  // the tool really swings (amplitude 0.35 rad per axis)
}

TEST(Simulator, SweepsFollowTheirScripts) {
  SimulatorOptions options;
  options.noise.position_rms_mm = 0.0;
  ToolScript line;
  line.name = "LineToTracker";
  line.motion = LinearSweep{Eigen::Isometry3d::Identity(), Eigen::Vector3d(0.0, 2.0, 0.0), 100.0, 50.0};
  ToolScript circle;
  circle.name = "CircleToTracker";
  circle.motion = CircularSweep{Eigen::Vector3d(0.0, 0.0, -1000.0), Eigen::Vector3d::UnitZ(), 50.0, 4.0,
                                Eigen::Matrix3d::Identity()};
  options.tools = {line, circle};
  SimulatedTrackingSource source(makeRepository(), options);
  source.step(1.0);  // 50 mm along +y
  EXPECT_LT(
      (source.repository().getTransform("LineToTracker").to_T_from.translation() - Eigen::Vector3d(0, 50, 0)).norm(),
      1e-9);
  source.step(3.0);  // back at 100 - 50 = 50 mm (turned at 2 s)
  EXPECT_NEAR(source.repository().getTransform("LineToTracker").to_T_from.translation().y(), 50.0, 1e-9);
  source.step(2.0);
  EXPECT_NEAR(source.repository().getTransform("LineToTracker").to_T_from.translation().y(), 100.0, 1e-9);
  for (double t : {0.0, 0.7, 1.3, 3.9}) {
    source.step(t);
    const Eigen::Vector3d p = source.repository().getTransform("CircleToTracker").to_T_from.translation();
    EXPECT_NEAR((p - Eigen::Vector3d(0, 0, -1000)).norm(), 50.0, 1e-9);
    EXPECT_NEAR(p.z(), -1000.0, 1e-9);
  }
}

TEST(Simulator, TremorHasTheConfiguredRmsAndFrequencyBand) {
  SimulatorOptions options;
  options.noise.position_rms_mm = 0.0;
  ToolScript tool;
  tool.name = "HandToTracker";
  Tremor tremor;
  tremor.drift_mm = 0.0;
  tool.tremor = tremor;
  options.tools = {tool};
  SimulatedTrackingSource source(makeRepository(), options);
  // Over 10 s the sum of three sinusoids at 8-12 Hz averages to its RMS within
  // a fraction of a period's contribution: 1 / (2 pi f T) < 0.2 %.
  double sum_sq = 0.0;
  int zero_crossings = 0;
  double previous = 0.0;
  constexpr int kSamples = 10000;
  for (int i = 0; i < kSamples; ++i) {
    const Eigen::Vector3d p = source.truePose(0, 0.001 * i).translation();
    sum_sq += p.squaredNorm();
    if (i > 0 && (p.x() > 0.0) != (previous > 0.0)) ++zero_crossings;
    previous = p.x();
  }
  EXPECT_NEAR(std::sqrt(sum_sq / kSamples), 0.5, 0.01);
  // 8-12 Hz over 10 s: 160-240 zero crossings on one axis.
  EXPECT_GE(zero_crossings, 158);
  EXPECT_LE(zero_crossings, 242);
}

TEST(Simulator, DropoutGivesInvalidThenOkAndKeepsThePose) {
  SimulatorOptions options;
  ToolScript tool;
  tool.name = "StylusToTracker";
  tool.dropouts = {{0.5, 0.25}};
  options.tools = {tool};
  SimulatedTrackingSource source(makeRepository(), options);
  std::vector<TransformStatus> seen;
  source.setUpdateCallback([&](std::span<const ToolUpdate> updates) { seen.push_back(updates[0].status); });
  source.step(0.4);
  EXPECT_EQ(source.repository().getTransform("StylusToTracker").status, TransformStatus::Ok);
  const auto before = source.repository().getTransform("StylusToTracker").to_T_from.matrix();
  source.step(0.5);
  EXPECT_EQ(source.repository().getTransform("StylusToTracker").status, TransformStatus::Invalid);
  EXPECT_EQ(source.repository().getTransform("StylusToTracker").to_T_from.matrix(), before);
  source.step(0.74);
  EXPECT_EQ(source.repository().getTransform("StylusToTracker").status, TransformStatus::Invalid);
  source.step(0.75);
  EXPECT_EQ(source.repository().getTransform("StylusToTracker").status, TransformStatus::Ok);
  EXPECT_EQ(seen, (std::vector<TransformStatus>{TransformStatus::Ok, TransformStatus::Invalid, TransformStatus::Invalid,
                                                TransformStatus::Ok}));
}

TEST(Simulator, LatencyDelaysThePoseButNotTheTimestamp) {
  SimulatorOptions options;
  options.noise.position_rms_mm = 0.0;
  ToolScript tool;
  tool.name = "LineToTracker";
  tool.motion = LinearSweep{Eigen::Isometry3d::Identity(), Eigen::Vector3d::UnitX(), 100.0, 50.0};
  tool.latency_s = 0.1;
  options.tools = {tool};
  SimulatedTrackingSource source(makeRepository(), options);
  source.step(1.0);
  const auto result = source.repository().getTransform("LineToTracker");
  EXPECT_DOUBLE_EQ(result.timestamp, 1.0);
  EXPECT_NEAR(result.to_T_from.translation().x(), 45.0, 1e-9);  // the pose of t = 0.9 s
}

TEST(Simulator, RunsOnItsOwnThreadAtTheSetRate) {
  SimulatorOptions options;
  options.rate_hz = 500.0;
  ToolScript tool;
  tool.name = "ToolToTracker";
  options.tools = {tool};
  SimulatedTrackingSource source(makeRepository(), options);
  std::atomic<int> updates{0};
  source.setUpdateCallback([&](std::span<const ToolUpdate>) { ++updates; });
  source.start();
  EXPECT_EQ(source.status().state, SourceState::Running);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  source.stop();
  // 150 expected; a loaded CI machine may skip ticks, never add any.
  EXPECT_GT(updates.load(), 40);
  EXPECT_LE(updates.load(), 160);
  EXPECT_EQ(source.status().state, SourceState::Stopped);
}

TEST(Simulator, RefusesBadScripts) {
  EXPECT_THROW(SimulatedTrackingSource(makeRepository(), SimulatorOptions{}), InvalidArgumentError);
  SimulatorOptions options;
  ToolScript tool;
  tool.name = "NoSplit";
  options.tools = {tool};
  EXPECT_THROW(SimulatedTrackingSource(makeRepository(), options), InvalidArgumentError);
  tool.name = "AToB";
  options.tools = {tool, tool};
  EXPECT_THROW(SimulatedTrackingSource(makeRepository(), options), InvalidArgumentError);
  options.tools = {tool};
  options.noise.position_rms_mm = -1.0;
  EXPECT_THROW(SimulatedTrackingSource(makeRepository(), options), InvalidArgumentError);
  options.noise.position_rms_mm = 0.25;
  options.rate_hz = 0.0;
  EXPECT_THROW(SimulatedTrackingSource(makeRepository(), options), InvalidArgumentError);
  EXPECT_THROW(SimulatedTrackingSource(nullptr, SimulatorOptions{}), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::tracking
