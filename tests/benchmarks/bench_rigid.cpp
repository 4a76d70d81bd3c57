// Cost of the rigid-body primitives used in real-time loops (tracking-buffer interpolation)
// and of the rotation averages used in calibration.
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "mrsns/core/rigid.h"
#include "mrsns/core/rotation_average.h"
#include "mrsns/core/time_series.h"

namespace {

std::vector<Eigen::Vector3d> randomRotationVectors(std::size_t n, double sigma) {
  std::mt19937 rng(42);
  std::normal_distribution<double> noise(0.0, sigma);
  std::vector<Eigen::Vector3d> out;
  for (std::size_t i = 0; i < n; ++i) out.emplace_back(noise(rng), noise(rng), noise(rng));
  return out;
}

void BM_So3Exp(benchmark::State& state) {
  const auto phis = randomRotationVectors(1024, 1.0);
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(mrsns::so3Exp(phis[i++ & 1023]));
  }
}
BENCHMARK(BM_So3Exp);

void BM_So3Log(benchmark::State& state) {
  std::vector<Eigen::Matrix3d> rotations;
  for (const auto& phi : randomRotationVectors(1024, 1.0)) rotations.push_back(mrsns::so3Exp(phi));
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(mrsns::so3Log(rotations[i++ & 1023]));
  }
}
BENCHMARK(BM_So3Log);

void BM_InterpolatePose(benchmark::State& state) {
  Eigen::Isometry3d a = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d b = Eigen::Isometry3d::Identity();
  b.linear() = mrsns::so3Exp(Eigen::Vector3d(0.1, 0.2, -0.3));
  b.translation() = Eigen::Vector3d(1.0, 2.0, 3.0);
  double t = 0.0;
  for (auto _ : state) {
    t = t > 1.0 ? 0.0 : t + 0.001;
    benchmark::DoNotOptimize(mrsns::interpolatePose(a, b, t));
  }
}
BENCHMARK(BM_InterpolatePose);

void BM_PoseTimeSeriesInterpolate(benchmark::State& state) {
  mrsns::TimeSeriesOptions options;
  options.capacity = 10000;  // a tracking buffer of ~3 min at 60 Hz
  mrsns::PoseTimeSeries series(options);
  const auto phis = randomRotationVectors(10000, 0.01);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (std::size_t i = 0; i < phis.size(); ++i) {
    T.linear() = T.linear() * mrsns::so3Exp(phis[i]);
    series.append(static_cast<double>(i) / 60.0, T);
  }
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> when(0.0, 9999.0 / 60.0);
  for (auto _ : state) {
    benchmark::DoNotOptimize(series.interpolate(when(rng)));
  }
}
BENCHMARK(BM_PoseTimeSeriesInterpolate);

void BM_RotationAverage(benchmark::State& state) {
  std::vector<Eigen::Matrix3d> rotations;
  for (const auto& phi : randomRotationVectors(100, 0.1)) rotations.push_back(mrsns::so3Exp(phi));
  mrsns::RotationAverageOptions options;
  options.method = static_cast<mrsns::RotationMeanMethod>(state.range(0));
  for (auto _ : state) {
    benchmark::DoNotOptimize(mrsns::averageRotations(rotations, options));
  }
  state.SetLabel(state.range(0) == 0 ? "Karcher L2, n=100" : state.range(0) == 1 ? "chordal L2, n=100" : "L1, n=100");
}
BENCHMARK(BM_RotationAverage)->Arg(0)->Arg(1)->Arg(2);

}  // namespace

BENCHMARK_MAIN();
