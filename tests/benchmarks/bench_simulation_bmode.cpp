// One simulated 640 x 480 B-mode frame (renderBModeFrame), for the simulator's
// 30 frames/s budget (well under one core with everything else; target
// <= 8 ms a frame): a patient-like scene (a bone shell and a curved vessel
// whose distance functions cost ~1 us a call, like distances to meshes) and
// the fCal N-wire phantom in water.
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <vector>

#include "mrsns/simulation/bmode_renderer.h"

namespace {

using namespace mrsns::simulation;

double segmentDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (p - (a + t * ab)).norm();
}

/// A tube of `radius` around a polyline: min over its segments (signed:
/// negative inside), the cost of a distance to a sampled centreline.
struct Tube {
  std::vector<Eigen::Vector3d> points;
  double radius = 1.0;
  double operator()(const Eigen::Vector3d& p) const {
    double d = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k + 1 < points.size(); ++k) d = std::min(d, segmentDistance(p, points[k], points[k + 1]));
    return d - radius;
  }
};

// Sampled so that one call costs about a microsecond (measured below).
constexpr int kSegments = 120;

Tube vesselTube() {
  Tube t;
  t.radius = 3.0;
  for (int k = 0; k <= kSegments; ++k) {
    const double z = -30.0 + 60.0 * k / kSegments;
    t.points.emplace_back(32.0 + 2.0 * std::sin(z / 10.0), 15.0 + 1.5 * std::cos(z / 8.0), z);
  }
  return t;
}

// A cortical shell across the image at ~30 mm depth, bumpy like a lamina.
Tube boneTube() {
  Tube t;
  t.radius = 2.5;
  for (int k = 0; k <= kSegments; ++k) {
    const double s = -10.0 + 84.0 * k / kSegments;
    t.points.emplace_back(s, 32.0 + 4.0 * std::sin(s / 9.0), 8.0 * std::sin(s / 13.0));
  }
  return t;
}

std::atomic<long> g_calls{0};

EchoScene patientScene() {
  EchoScene scene;
  scene.bone_distance_mm = [bone = boneTube()](const Eigen::Vector3d& p) {
    g_calls.fetch_add(1, std::memory_order_relaxed);
    return bone(p);
  };
  scene.vessel_distance_mm = [vessel = vesselTube()](const Eigen::Vector3d& p) {
    g_calls.fetch_add(1, std::memory_order_relaxed);
    return vessel(p);
  };
  return scene;
}

// The fCal phantom's nine wires (PLUS fCal 1.2 3-NWire definition) in water,
// and fCal's image plane over them.
EchoScene nwireScene() {
  EchoScene scene;
  const double z[3] = {10.0, 5.0, 0.0};
  const double middle_front[3] = {40.0, 25.0, 45.0}, middle_back[3] = {25.0, 45.0, 25.0}, outer[3] = {45.0, 50.0, 50.0};
  for (int k = 0; k < 3; ++k) {
    scene.wires.push_back({Eigen::Vector3d(20, 0, z[k]), Eigen::Vector3d(20, 40, z[k]), 0.25});
    scene.wires.push_back({Eigen::Vector3d(middle_front[k], 0, z[k]), Eigen::Vector3d(middle_back[k], 40, z[k]), 0.25});
    scene.wires.push_back({Eigen::Vector3d(outer[k], 0, z[k]), Eigen::Vector3d(outer[k], 40, z[k]), 0.25});
  }
  EchoBox bath;
  bath.scene_T_box.translation() = Eigen::Vector3d(35.0, 20.0, 10.0);
  bath.half_extent_mm = Eigen::Vector3d(120.0, 120.0, 120.0);
  scene.water_bath = bath;
  return scene;
}

Eigen::Isometry3d fcalPlane() {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() << -1, 0, 0, 0, 0, -1, 0, -1, 0;
  t.linear().col(2) = t.linear().col(0).cross(t.linear().col(1));
  t.translation() = Eigen::Vector3d(66.4, 20.0, 31.5);
  return t;
}

void renderLoop(benchmark::State& state, const EchoScene& scene, const Eigen::Isometry3d& scene_T_image) {
  const BModeGeometry geometry{640, 480, 0.1, 0.1};
  const BModeNoiseModel noise;
  std::uint64_t seed = 1;
  g_calls = 0;
  for (auto _ : state) {
    auto pixels = renderBModeFrame(scene, scene_T_image, geometry, noise, seed++);
    benchmark::DoNotOptimize(pixels.data());
  }
  state.counters["frames_per_s"] = benchmark::Counter(1.0, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["distance_calls_per_frame"] =
      static_cast<double>(g_calls.load()) /
      static_cast<double>(std::max<benchmark::IterationCount>(1, state.iterations()));
}

void BM_BModePatientFrame640x480(benchmark::State& state) {
  // The plane cuts the vessel and the bone shell: x lateral, y depth.
  renderLoop(state, patientScene(), Eigen::Isometry3d::Identity());
}
BENCHMARK(BM_BModePatientFrame640x480)->Unit(benchmark::kMillisecond);

void BM_BModeNWireFrame640x480(benchmark::State& state) {
  renderLoop(state, nwireScene(), fcalPlane());
}
BENCHMARK(BM_BModeNWireFrame640x480)->Unit(benchmark::kMillisecond);

// What one call of the patient scene's distance functions costs.
void BM_BModeSceneDistanceCall(benchmark::State& state) {
  const Tube bone = boneTube();
  Eigen::Vector3d p(10.0, 20.0, 0.0);
  for (auto _ : state) {
    benchmark::DoNotOptimize(bone(p));
    p.x() += 1e-3;
  }
}
BENCHMARK(BM_BModeSceneDistanceCall)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
