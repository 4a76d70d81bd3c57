// The temporal calibration through the simulated operating room: the probe
// moved up and down over a flat target at the bottom of a water tank, the
// video lagging the tracking by a scenario-given amount; a client records the
// stream and the ultrasound module's temporal calibration finds the lag that
// only the truth knows.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <mutex>
#include <thread>

#include "mrsns/core/frame_poses.h"
#include "mrsns/core/rigid.h"
#include "mrsns/igtlink/client.h"
#include "mrsns/simulation/operating_room.h"
#include "mrsns/simulation/scenario.h"
#include "mrsns/ultrasound/temporal_calibration.h"

namespace mrsns::simulation {
namespace {

using namespace std::chrono_literals;

double measuredTrackerLag(double video_lag_s, int seed) {
  // The image plane looks down (depth along -z of the tracker) 35 mm above the plate; the probe goes up and
  // down by 10 mm at 0.5 Hz along the image's depth axis (the probe's y: ImageToProbe is the identity here).
  const std::string scenario_json = R"({"format": "mrsns-scenario/1", "seed": )" + std::to_string(seed) + R"(,
      "tracker": {"port": 0},
      "tools": [{"name": "ProbeToTracker", "hand": {"tremor_rms_mm": 0.2},
                 "start": {"matrix": [1, 0, 0, -32, 0, 0, 1, 0, 0, -1, 0, -1365, 0, 0, 0, 1]},
                 "motion": [{"kind": "up_down", "amplitude_mm": 10, "frequency_hz": 0.5, "axis": [0, 1, 0],
                             "duration_s": 12}]}],
      "flat_target": {"pose": {"translation_mm": [0, 0, -1400]}, "half_size_mm": [100, 100]},
      "ultrasound": {"rate_hz": 25, "width": 640, "height": 480, "spacing_mm": [0.1, 0.1],
                     "video_lag_s": )" +
                                    std::to_string(video_lag_s) +
                                    R"(},
      "duration_s": 10})";
  OperatingRoom room(parseScenario(scenario_json, "."));
  room.start();
  std::mutex mutex;
  std::vector<FramePose> poses;
  TrackedSequence video;
  video.geometry.size = {640, 480, 1};
  video.orientation = "MF";
  igtlink::ClientOptions o;
  o.port = room.endpoints().plus_port;
  igtlink::Client client(o);
  client.onMessage([&](const igtlink::Message& m) {
    std::lock_guard lock(mutex);
    if (const auto* t = m.as<igtlink::TransformContent>()) {
      poses.push_back(
          FramePose{poses.size(), m.header.timestampSeconds(), orthonormalize(t->matrix), TransformStatus::Ok});
    } else if (const auto* image = m.as<igtlink::ImageContent>()) {
      TrackedFrame f;
      f.timestamp = m.header.timestampSeconds();
      f.pixels = image->littleEndianPixels();
      video.frames.push_back(std::move(f));
    }
  });
  client.start();
  while (!room.finished()) std::this_thread::sleep_for(50ms);
  room.stop();
  client.stop();
  std::lock_guard lock(mutex);
  const auto result =
      ultrasound::calibrateTemporal(ultrasound::trackerPositionSignal(poses), ultrasound::videoLineSignal(video));
  std::printf(
      "[ figures ] seed %d: video lag %.0f ms -> tracker lag %.1f ms (correlation %.3f, %zu video, %zu "
      "tracker samples)\n",
      seed, video_lag_s * 1e3, result.tracker_lag_s * 1e3, result.correlation, result.video_samples,
      result.tracker_samples);
  return result.tracker_lag_s;
}

TEST(TemporalOverTheWire, TheLagOfTheVideoIsFoundFromAnUpDownMotionOverAFlatTarget) {
  const char* seed_env = std::getenv("MRSNS_SIM_SEED");
  const int seed = seed_env ? std::atoi(seed_env) : 1;
  // A video lagging the tracker by L is a tracker lag of -L (PLUS's TrackerLagSec). Noise model: video frames at
  // 25 Hz, the plate's line located at 0.1 mm pixels in speckle, tracker at 60 Hz with 0.12 mm noise, and 0.2 mm of
  // 8-12 Hz tremor that the 25 Hz video samples close to its Nyquist limit. Measured over seeds 1-3: -92.1, -89.8,
  // -79.5 ms for -80, and +0.9, +2.9, +7.2 ms for 0 (the same on an idle and a loaded machine: the room samples at
  // regular instants). The bound is half a video frame period (20 ms), beyond which the estimate would have locked
  // onto the wrong frame; the ~10 ms excess at 80 ms is reported, not explained yet.
  EXPECT_NEAR(measuredTrackerLag(0.080, seed), -0.080, 0.020);
  EXPECT_NEAR(measuredTrackerLag(0.0, seed), 0.0, 0.020);
}

}  // namespace
}  // namespace mrsns::simulation
