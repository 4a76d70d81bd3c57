// Freehand volume reconstruction on PLUS's fCal calibration sweep (820 x 616
// frames, ~0.08 mm pixels, PLUS's own ImageToProbe from its results file)
// into a 0.5 mm grid: frames splatted per second by VolumeReconstructor (all
// cores, and one thread) beside the straightforward one-pixel-at-a-time splat
// it replaced (tests/support/reference_reconstruction.h), in the same run;
// then the hole filling of the result. Accuracy columns: voxels that differ
// from the straightforward splat's volume, and the largest difference (grey
// levels; float round-off of the summation order only).
// Run: build/tests/benchmarks/mrsns_bench_reconstruction
#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdio>
#include <map>
#include <memory>
#include <string>

#include "mrsns/core/data_dir.h"
#include "mrsns/core/frame_poses.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/ultrasound/probe_calibration.h"
#include "mrsns/ultrasound/volume_reconstruction.h"
#include "plus_reference.h"
#include "reference_reconstruction.h"

namespace {

using namespace mrsns;
using namespace mrsns::ultrasound;

struct Sweep {
  int width = 0, height = 0;
  std::vector<std::vector<std::uint8_t>> frames;
  std::vector<Eigen::Matrix4d> grid_T_image;
  ImageVolume grid;
};

// The whole recording in memory, so only the splat is timed.
const Sweep* sweep() {
  static const std::unique_ptr<Sweep> s = []() -> std::unique_ptr<Sweep> {
    const auto sequence_path = findDataFile("plus/fCal_Test_Calibration_3NWires.igs.mha");
    const auto results_path = findDataFile("plus/FreehandCalibration3NWires.results.xml");
    if (!sequence_path || !results_path) return nullptr;
    auto out = std::make_unique<Sweep>();
    const auto sequence = io::readSequence(*sequence_path);
    const Eigen::Matrix4d probe_T_image = test::readPlusReference(*results_path).image_to_probe;
    const auto poses = extractFramePoses(sequence.frames, "ProbeToReference").poses;
    out->width = sequence.geometry.size[0];
    out->height = sequence.geometry.size[1];
    std::vector<Eigen::Vector3d> corners;
    for (const auto& p : poses) {
      const Eigen::Matrix4d m = p.to_T_from.matrix() * probe_T_image;
      out->grid_T_image.push_back(m);
      out->frames.push_back(toMfPixels(sequence, sequence.frames[p.frame_index]));
      for (const auto& [u, v] : {std::pair{0, 0}, {out->width - 1, 0}, {0, out->height - 1},
                                 {out->width - 1, out->height - 1}}) {
        corners.push_back((m * Eigen::Vector4d(u, v, 0, 1)).head<3>());
      }
    }
    out->grid = gridAroundCorners(corners, 0.5, 1.0);
    return out;
  }();
  return s.get();
}

struct Outcome {
  double frames_per_s = 0.0;
  ImageVolume volume;
};
std::map<std::string, Outcome>& outcomes() {
  static std::map<std::string, Outcome> o;
  return o;
}

template <typename Reconstructor>
void run(benchmark::State& state, const std::string& name, Reconstructor make) {
  const Sweep* s = sweep();
  if (s == nullptr) {
    state.SkipWithError("the fCal recording is not in the shared data (set MRSNS_DATA_DIR)");
    return;
  }
  double seconds = 0.0;
  std::size_t frames = 0;
  for (auto _ : state) {
    auto r = make(s->grid);
    const auto t0 = std::chrono::steady_clock::now();
    for (std::size_t f = 0; f < s->frames.size(); ++f) r.addFrame({s->width, s->height, s->frames[f]}, s->grid_T_image[f]);
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    frames += s->frames.size();
    state.PauseTiming();
    outcomes()[name] = {static_cast<double>(frames) / seconds, r.result(1)};
    state.ResumeTiming();
  }
  state.counters["frames"] = static_cast<double>(s->frames.size());
  state.counters["frames_per_s"] = static_cast<double>(frames) / seconds;
  state.counters["width"] = s->width;
  state.counters["height"] = s->height;
}

void BM_SplatMrsns(benchmark::State& state) {
  run(state, "mrsns (all cores)", [](const ImageVolume& g) { return VolumeReconstructor(g); });
}
void BM_SplatMrsnsOneThread(benchmark::State& state) {
  run(state, "mrsns (1 thread)", [](const ImageVolume& g) { return VolumeReconstructor(g, 1); });
}
void BM_SplatStraightforward(benchmark::State& state) {
  run(state, "straightforward", [](const ImageVolume& g) { return test::ReferenceReconstructor(g); });
}

// The hole filling and conversion of result(), after the whole sweep.
void BM_ResultHoleFilling(benchmark::State& state) {
  const Sweep* s = sweep();
  if (s == nullptr) {
    state.SkipWithError("the fCal recording is not in the shared data");
    return;
  }
  VolumeReconstructor r(s->grid);
  for (std::size_t f = 0; f < s->frames.size(); ++f) r.addFrame({s->width, s->height, s->frames[f]}, s->grid_T_image[f]);
  for (auto _ : state) benchmark::DoNotOptimize(r.result(1).data.data());
  state.counters["voxels"] = static_cast<double>(s->grid.voxelCount());
}

BENCHMARK(BM_SplatMrsns)->Iterations(3)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SplatMrsnsOneThread)->Iterations(3)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SplatStraightforward)->Iterations(3)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ResultHoleFilling)->Iterations(3)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  const auto& o = outcomes();
  if (o.count("straightforward") == 0) return 0;
  const Outcome& peer = o.at("straightforward");
  std::printf("\n%-20s %12s %14s %14s %12s\n", "splat", "frames/s", "x straightfwd", "voxels differ", "max diff");
  for (const auto& [name, r] : o) {
    std::size_t differ = 0;
    int worst = 0;
    for (std::size_t n = 0; n < r.volume.data.size(); ++n) {
      const int d = std::abs(static_cast<int>(r.volume.data[n]) - static_cast<int>(peer.volume.data[n]));
      differ += d != 0;
      worst = std::max(worst, d);
    }
    std::printf("%-20s %12.1f %14.2f %14zu %12d\n", name.c_str(), r.frames_per_s, r.frames_per_s / peer.frames_per_s,
                differ, worst);
  }
  return 0;
}
