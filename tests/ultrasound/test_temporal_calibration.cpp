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

// What else the images hold besides the moving target line.
struct Scene {
  double tilt = 0.0;                   ///< slope of the target line (px per px)
  double ringing_intensity = 0.0;      ///< a thin, bright static band at the top (transducer ringing)
  double static_band_intensity = 0.0;  ///< a thick static echo (another wall), rows 12..30
  double invalid_fraction = 0.0;       ///< frames marked ImageStatus INVALID, their pixels garbage
  double dropout_fraction = 0.0;       ///< columns where the target echo is missing (shadowing)
};

// The tracker reports at its time t the motion of time t - lag (it lags);
// the video shows the motion of its own time. px_per_mm < 0 makes the line
// rise as the tracker coordinate grows.
Recording simulate(double lag_s, double amplitude_mm, double px_per_mm, unsigned seed, const Scene& scene = {}) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
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
  std::vector<bool> dropped(static_cast<std::size_t>(w));
  for (int x = 0; x < w; ++x) dropped[static_cast<std::size_t>(x)] = u(rng) < scene.dropout_fraction;
  for (int i = 0; i < 12 * 25; ++i) {
    TrackedFrame f;
    f.timestamp = 100.0 + i / 25.0 + 0.003 * noise(rng);  // frame-grabber jitter
    const double line_y = 80.0 + px_per_mm * motion(f.timestamp, amplitude_mm);
    f.pixels.resize(static_cast<std::size_t>(w * h));
    const bool invalid = u(rng) < scene.invalid_fraction;
    f.image_status = invalid ? "INVALID" : "OK";
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const double target_y = line_y + scene.tilt * (x - w / 2.0);
        const double target =
            dropped[static_cast<std::size_t>(x)] ? 0.0 : 200.0 * std::exp(-0.5 * std::pow((y - target_y) / 2.0, 2));
        const double ringing = y < 3 ? scene.ringing_intensity : 0.0;
        const double band = (y >= 12 && y <= 30) ? scene.static_band_intensity : 0.0;
        double v = 20.0 + (target + band) * (0.7 + 0.3 * std::abs(noise(rng))) + ringing + 8.0 * std::abs(noise(rng));
        if (invalid) v = 255.0 * u(rng);
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

// A tilted target with a fifth of its columns shadowed (so the peaks found
// are not spread evenly across the image), a thin ringing band at the top
// and dropped frames: the largest echo per scanline and the line fitted
// through the peaks, read at the middle of the image, follow the target.
TEST(TemporalCalibration, TiltedTargetWithShadowsRingingAndDroppedFrames) {
  Scene scene;
  scene.tilt = 0.15;
  scene.ringing_intensity = 120.0;
  scene.dropout_fraction = 0.2;
  scene.invalid_fraction = 0.08;
  const auto rec = simulate(0.120, 8.0, 3.0, 5, scene);
  const auto video = videoLineSignal(rec.video);
  const auto result = calibrateTemporal(trackerPositionSignal(rec.tracker), video);
  std::printf("tilted, shadows, ringing, dropped frames: lag %.3f ms (true 120 ms), NCC %.4f, %zu frames with a line\n",
              1000.0 * result.tracker_lag_s, result.correlation, video.time_s.size());
  EXPECT_NEAR(result.tracker_lag_s, 0.120, 0.002);
  EXPECT_GT(result.correlation, 0.95);
  // Only the valid frames are used.
  std::size_t valid = 0;
  for (const auto& f : rec.video.frames) valid += f.image_status == "OK" ? 1 : 0;
  EXPECT_EQ(video.time_s.size(), valid);
  EXPECT_LT(valid, rec.video.frames.size());
}

// A thick static echo stronger than the target is what the largest-area
// rule follows: the image "line" stands still and the calibration is
// refused, saying to clip; clipped below it, the lag comes back.
TEST(TemporalCalibration, StaticEchoIsClippedAway) {
  Scene scene;
  scene.static_band_intensity = 230.0;
  const auto rec = simulate(0.064, 8.0, 3.0, 6, scene);
  try {
    (void)calibrateTemporal(trackerPositionSignal(rec.tracker), videoLineSignal(rec.video));
    FAIL() << "the static echo was taken for the target";
  } catch (const ComputationError& e) {
    EXPECT_NE(std::string(e.what()).find("clip"), std::string::npos) << e.what();
  }
  LineSignalOptions clip;
  clip.clip_x = 0;
  clip.clip_y = 40;
  clip.clip_width = 96;
  clip.clip_height = 120;
  const auto result = calibrateTemporal(trackerPositionSignal(rec.tracker), videoLineSignal(rec.video, clip));
  EXPECT_NEAR(result.tracker_lag_s, 0.064, 0.002);
}

// Frames without a target line (an N-wire recording, an empty tank) are
// refused before any correlation, and a tracker buffer is not a video.
TEST(TemporalCalibration, RefusesVideoWithoutATargetLine) {
  auto rec = simulate(0.0, 8.0, 3.0, 7);
  std::mt19937 rng(8);
  std::uniform_int_distribution<int> dark(0, 20);
  for (std::size_t i = 0; i < rec.video.frames.size(); i += 3) {
    for (std::size_t k = i; k < std::min(i + 2, rec.video.frames.size()); ++k) {
      for (auto& p : rec.video.frames[k].pixels) p = static_cast<std::uint8_t>(dark(rng));
    }
  }
  try {
    (void)videoLineSignal(rec.video);
    FAIL() << "a video showing the target in a third of its frames was accepted";
  } catch (const ComputationError& e) {
    EXPECT_NE(std::string(e.what()).find("found in"), std::string::npos) << e.what();
  }
  TrackedSequence tracker_buffer;
  tracker_buffer.geometry.size = {0, 0, 1};
  tracker_buffer.frames.resize(3);
  EXPECT_THROW((void)videoLineSignal(tracker_buffer), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::ultrasound
