// Geometry kernels of mrsns::core: BVH build and closest-point queries on a
// ~100k-triangle icosphere against brute force, ray casts, plane cuts and
// KD-tree nearest neighbours. Run: build/tests/benchmarks/mrsns_bench_geometry
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "../core/mesh_fixtures.h"
#include "mrsns/core/mesh_locator.h"
#include "mrsns/core/plane_intersection.h"
#include "mrsns/core/point_locator.h"

namespace {

using mrsns::MeshLocator;
using mrsns::PointsN3;
using mrsns::TriangleMesh;

constexpr double kRadius = 50.0;

const TriangleMesh& sphere(int subdivisions) {
  // 20 * 4^s faces: s = 4 -> 5,120; s = 6 -> 81,920; s = 7 -> 327,680.
  static std::vector<TriangleMesh> cache(8);
  auto& mesh = cache[static_cast<std::size_t>(subdivisions)];
  if (mesh.empty()) mesh = mrsns::test::icosphere(kRadius, subdivisions);
  return mesh;
}

// Query points in a shell of radii [kRadius - shell, kRadius + shell]: a thin
// shell is the ICP / tool-tip case, a thick one reaches towards the centre,
// where most of the sphere is nearly equidistant (the hard case for a BVH).
std::vector<Eigen::Vector3d> queries(int n, double shell = 0.5 * kRadius) {
  std::mt19937 rng(42);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> radius(kRadius - shell, kRadius + shell);
  std::vector<Eigen::Vector3d> q(static_cast<std::size_t>(n));
  for (auto& p : q) p = radius(rng) * Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
  return q;
}

void BM_BvhBuild(benchmark::State& state) {
  const TriangleMesh& mesh = sphere(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    MeshLocator locator(mesh);
    benchmark::DoNotOptimize(locator);
  }
  state.SetItemsProcessed(state.iterations() * mesh.faceCount());
  state.counters["faces"] = static_cast<double>(mesh.faceCount());
}
BENCHMARK(BM_BvhBuild)->Arg(4)->Arg(6)->Arg(7)->Unit(benchmark::kMillisecond);

void BM_BvhClosestPoint(benchmark::State& state) {
  const TriangleMesh& mesh = sphere(static_cast<int>(state.range(0)));
  const MeshLocator locator(mesh);
  const auto q = queries(4096, static_cast<double>(state.range(1)));
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(locator.closestPoint(q[i++ & 4095]));
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["faces"] = static_cast<double>(mesh.faceCount());
}
// Args: subdivisions, shell half-thickness (mm).
BENCHMARK(BM_BvhClosestPoint)
    ->Args({4, 2})
    ->Args({4, 25})
    ->Args({6, 2})
    ->Args({6, 25})
    ->Args({7, 2})
    ->Args({7, 25})
    ->Unit(benchmark::kMicrosecond);

void BM_BvhSignedDistance(benchmark::State& state) {
  const MeshLocator locator(sphere(6));
  const auto q = queries(4096);
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(locator.signedClosestPoint(q[i++ & 4095]));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_BvhSignedDistance)->Unit(benchmark::kMicrosecond);

void BM_BruteForceClosestPoint(benchmark::State& state) {
  const TriangleMesh& mesh = sphere(static_cast<int>(state.range(0)));
  const MeshLocator locator(mesh);
  const auto q = queries(4096);
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(locator.closestPointBruteForce(q[i++ & 4095]));
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["faces"] = static_cast<double>(mesh.faceCount());
}
BENCHMARK(BM_BruteForceClosestPoint)->Arg(4)->Unit(benchmark::kMicrosecond);

void BM_RayIntersect(benchmark::State& state) {
  const MeshLocator locator(sphere(6));
  const auto q = queries(4096);
  std::size_t i = 0;
  for (auto _ : state) {
    // A needle line through a random point towards the centre region: two hits.
    const Eigen::Vector3d& o = q[i++ & 4095];
    benchmark::DoNotOptimize(locator.intersectLine(o, -o));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_RayIntersect)->Unit(benchmark::kMicrosecond);

void BM_PlaneCut(benchmark::State& state) {
  const TriangleMesh& mesh = sphere(6);
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        mrsns::intersectMeshWithPlane(mesh, Eigen::Vector3d(0, 0, 7.0), Eigen::Vector3d(0.1, 0.2, 1.0)));
  }
  state.SetItemsProcessed(state.iterations() * mesh.faceCount());
}
BENCHMARK(BM_PlaneCut)->Unit(benchmark::kMillisecond);

PointsN3 cloud(int n) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-kRadius, kRadius);
  PointsN3 p(n, 3);
  for (int i = 0; i < n; ++i) p.row(i) << u(rng), u(rng), u(rng);
  return p;
}

void BM_KdTreeBuild(benchmark::State& state) {
  const PointsN3 points = cloud(20000);
  for (auto _ : state) {
    mrsns::PointLocator locator(points);
    benchmark::DoNotOptimize(locator);
  }
  state.SetItemsProcessed(state.iterations() * points.rows());
}
BENCHMARK(BM_KdTreeBuild)->Unit(benchmark::kMillisecond);

void BM_KdTreeNearest(benchmark::State& state) {
  const mrsns::PointLocator locator(cloud(20000));
  const auto q = queries(4096);
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(locator.nearest(q[i++ & 4095]));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_KdTreeNearest)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
