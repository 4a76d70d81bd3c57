// Temporal calibration on synthetic recordings with a known lag: a probe
// moved up and down over a flat target, the tracker stream delayed by a
// known time, the target rendered as a speckled line in the images.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "mrsns/core/error.h"
#include "mrsns/ultrasound/temporal_calibration.h"

namespace mrsns::ultrasound {
namespace {

// Quasi-periodic motion (two incommensurate frequencies), mm.
double motion(double t, double amplitude) {
  return amplitude *
         (std::sin(2.0 * std::numbers::pi * 0.8 * t) + 0.4 * std::sin(2.0 * std::numbers::pi * 0.37 * t + 1.0));
}

struct Recording {
  std::vector<FramePose> tracker;
  TrackedSequence video;
};

// The tracker reports at its time t the motion of time t - lag (it lags);
// the video shows the motion of its own time. px_per_mm < 0 makes the line
// rise as the tracker coordinate grows.
Recording simulate(double lag_s, double amplitude_mm, double px_per_mm, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  Recording r;
  const Eigen::Vector3d axis = Eigen::Vector3d(0.3, -0.2, 0.93).normalized();
  for (int i = 0; i < 12 * 60; ++i) {
    const double t = 100.0 + i / 60.0;
    FramePose p;
    p.frame_index = static_cast<std::size_t>(i);
    p.timestamp = t;
    p.to_T_from.translation() = Eigen::Vector3d(50, 20, -30) + axis * motion(t - lag_s, amplitude_mm) +
                                0.05 * Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    p.status = TransformStatus::Ok;
    r.tracker.push_back(p);
  }
  const int w = 96, h = 160;
  r.video.geometry.size = {w, h, 1};
  for (int i = 0; i < 12 * 25; ++i) {
    TrackedFrame f;
    f.timestamp = 100.0 + i / 25.0 + 0.003 * noise(rng);  // frame-grabber jitter
    const double line_y = 80.0 + px_per_mm * motion(f.timestamp, amplitude_mm);
    f.pixels.resize(static_cast<std::size_t>(w * h));
    for (int y = 0; y < h; ++y) {
      const double profile = 200.0 * std::exp(-0.5 * std::pow((y - line_y) / 2.0, 2));
      for (int x = 0; x < w; ++x) {
        const double v = 20.0 + profile * (0.7 + 0.3 * std::abs(noise(rng))) + 8.0 * std::abs(noise(rng));
        f.pixels[static_cast<std::size_t>(y * w + x)] = static_cast<std::uint8_t>(std::clamp(v, 0.0, 255.0));
      }
    }
    r.video.frames.push_back(std::move(f));
  }
  return r;
}

TEST(TemporalCalibration, RecoversKnownTrackerLag) {
  const auto rec = simulate(0.064, 8.0, 3.0, 1);
  const auto result = calibrateTemporal(trackerPositionSignal(rec.tracker), videoLineSignal(rec.video));
  std::printf("recovered tracker lag %.3f ms (true 64 ms), NCC %.4f\n", 1000.0 * result.tracker_lag_s,
              result.correlation);
  EXPECT_NEAR(result.tracker_lag_s, 0.064, 0.002);
  EXPECT_GT(result.correlation, 0.95);
  EXPECT_EQ(result.video_samples, 300u);
}

TEST(TemporalCalibration, NegativeLagAndReversedCoupling) {
  // Video lags (tracker leads): TrackerLagSec < 0; the line rises as the
  // probe coordinate grows (polarity is found, not assumed).
  const auto rec = simulate(-0.041, 6.0, -2.5, 2);
  const auto result = calibrateTemporal(trackerPositionSignal(rec.tracker), videoLineSignal(rec.video));
  EXPECT_NEAR(result.tracker_lag_s, -0.041, 0.002);
  EXPECT_GT(result.correlation, 0.95);
}

TEST(TemporalCalibration, ZeroLag) {
  const auto rec = simulate(0.0, 8.0, 3.0, 3);
  const auto result = calibrateTemporal(trackerPositionSignal(rec.tracker), videoLineSignal(rec.video));
  EXPECT_NEAR(result.tracker_lag_s, 0.0, 0.002);
}

TEST(TemporalCalibration, RefusesTooLittleMotion) {
  const auto rec = simulate(0.064, 0.3, 3.0, 4);
  try {
    (void)calibrateTemporal(trackerPositionSignal(rec.tracker), videoLineSignal(rec.video));
    FAIL() << "a 0.3 mm motion was accepted";
  } catch (const ComputationError& e) {
    EXPECT_NE(std::string(e.what()).find("too little motion"), std::string::npos) << e.what();
  }
}

TEST(TemporalCalibration, RefusesTooFewSamplesAndBadTimestamps) {
  TimedSignal a{{0.0, 0.1, 0.2}, {1.0, 2.0, 3.0}};
  EXPECT_THROW((void)calibrateTemporal(a, a), ComputationError);
  TimedSignal b{{0.0, 0.0}, {1.0, 2.0}};
  EXPECT_THROW((void)calibrateTemporal(b, b), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::ultrasound
