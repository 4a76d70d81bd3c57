// Query latency of the transform repository with 20 frames: a 3-edge path
// (ImageToReference through Probe and Tracker) by prepared query and by
// name, plus the writer's update cost. Run:
//   build/tests/benchmarks/mrsns_bench_transform_repository --benchmark_repetitions=5
// p50/p99 of single-query latency come from the Latency benchmark's counters.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <string>
#include <vector>

#include "mrsns/core/transform_repository.h"

namespace {

void fillRepository(mrsns::TransformRepository& repo) {
  repo.setTransform("ImageToProbe", Eigen::Isometry3d(Eigen::Translation3d(1, 2, 3)), mrsns::TransformStatus::Ok, 0.0,
                    true);
  repo.setTransform("ProbeToTracker", Eigen::Isometry3d(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX())));
  repo.setTransform("ReferenceToTracker", Eigen::Isometry3d(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY())));
  // 16 more frames: other tools on the tracker and a chain behind the reference.
  for (int i = 0; i < 8; ++i) {
    repo.setTransform("Tool" + std::string(1, static_cast<char>('A' + i)) + "ToTracker",
                      Eigen::Isometry3d(Eigen::Translation3d(i, 0, 0)));
  }
  std::string previous = "Reference";
  for (int i = 0; i < 8; ++i) {
    const std::string frame = "Model" + std::string(1, static_cast<char>('A' + i));
    repo.setTransform(frame, previous, Eigen::Isometry3d(Eigen::Translation3d(0, i, 0)));
    previous = frame;
  }
}

void BM_PreparedQuery3Edges(benchmark::State& state) {
  mrsns::TransformRepository repo;
  fillRepository(repo);
  auto query = repo.prepare("Image", "Reference");
  for (auto _ : state) {
    auto result = repo.evaluate(query);
    benchmark::DoNotOptimize(result);
  }
}
BENCHMARK(BM_PreparedQuery3Edges);

void BM_NamedQuery3Edges(benchmark::State& state) {
  mrsns::TransformRepository repo;
  fillRepository(repo);
  for (auto _ : state) {
    auto result = repo.getTransform("Image", "Reference");
    benchmark::DoNotOptimize(result);
  }
}
BENCHMARK(BM_NamedQuery3Edges);

void BM_NamedQuery10Edges(benchmark::State& state) {
  mrsns::TransformRepository repo;
  fillRepository(repo);
  for (auto _ : state) {
    auto result = repo.getTransform("ToolA", "ModelH");
    benchmark::DoNotOptimize(result);
  }
}
BENCHMARK(BM_NamedQuery10Edges);

void BM_WriterUpdate(benchmark::State& state) {
  mrsns::TransformRepository repo;
  fillRepository(repo);
  Eigen::Isometry3d pose(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()));
  double t = 0.0;
  for (auto _ : state) {
    repo.setTransform("Probe", "Tracker", pose, mrsns::TransformStatus::Ok, t);
    t += 1e-3;
  }
}
BENCHMARK(BM_WriterUpdate);

// Per-query latency distribution (each sample timed alone; steady_clock's
// own overhead, ~20 ns, is included).
void BM_PreparedQueryLatencyPercentiles(benchmark::State& state) {
  mrsns::TransformRepository repo;
  fillRepository(repo);
  auto query = repo.prepare("Image", "Reference");
  std::vector<double> samples;
  samples.reserve(1 << 20);
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    auto result = repo.evaluate(query);
    benchmark::DoNotOptimize(result);
    const auto stop = std::chrono::steady_clock::now();
    if (samples.size() < samples.capacity())
      samples.push_back(std::chrono::duration<double, std::nano>(stop - start).count());
  }
  std::sort(samples.begin(), samples.end());
  if (!samples.empty()) {
    state.counters["p50_ns"] = samples[samples.size() / 2];
    state.counters["p99_ns"] = samples[samples.size() * 99 / 100];
  }
}
BENCHMARK(BM_PreparedQueryLatencyPercentiles);

}  // namespace

BENCHMARK_MAIN();
