// Posterior shape update per ultrasound frame (paper 001 Algorithm 1) for a
// ~20k-vertex vessel model with 19 modes, a 60-frame sweep repeated (~400
// observations kept by the 1.2 mm rule):
// - the whole frame (plane cut near the plane, Eq. 8 resampling,
//   correspondence, incremental normal equations and their solve) beside the
//   previous implementation of the same frame (previous_posterior_update.h:
//   cut of the whole evaluated mesh, Qp system rebuilt from every
//   observation, the 3N mean shape every frame), in the same run;
// - the posterior alone: one frame's 15 replaced observations and the solve,
//   beside the one-shot n x n computation over all observations and a
//   straightforward dense implementation that forms the 3N x 3k
//   cross-covariance and solves the 3k x 3k observation system.
// The ratios are printed at the end. Accuracy: the mean distance between the
// final shapes of the two frame pipelines (the same algorithm; round-off).
#include <benchmark/benchmark.h>

#include <Eigen/Cholesky>
#include <chrono>
#include <cstdio>
#include <map>
#include <random>
#include <string>

#include "mrsns/deformation/model_building.h"
#include "mrsns/deformation/shape_model_ops.h"
#include "mrsns/deformation/shape_tracker.h"
#include "mrsns/deformation/vessel_phantom.h"
#include "previous_posterior_update.h"

namespace {

using namespace mrsns;
using namespace mrsns::deformation;

struct Fixture {
  ShapeModel model;
  std::vector<Eigen::Isometry3d> poses;
  std::vector<std::vector<Polyline3d>> features;  // per frame, image coordinates
  std::vector<ModelPointObservation> observations;
};

const Fixture& fixture() {
  static const Fixture f = [] {
    Fixture fx;
    VesselPhantomOptions po;
    po.ring_vertices = 64;
    po.ring_spacing_mm = 0.3;  // 3 x 101 rings x 64 = 19 392 vertices
    std::mt19937_64 rng(1);
    std::vector<TriangleMesh> training;
    for (int i = 0; i < 20; ++i) training.push_back(makeVesselPhantom(randomVesselDeformation(rng), po));
    ShapeModelBuildOptions b;
    b.align = false;
    fx.model = buildShapeModel(training, b).model;
    const TriangleMesh truth = makeVesselPhantom(randomVesselDeformation(rng), po);
    for (int k = 0; k < 60; ++k) {
      Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
      m.linear() = Eigen::AngleAxisd(0.1 * std::sin(0.3 * k), Eigen::Vector3d::UnitX()).toRotationMatrix();
      m.translation() = Eigen::Vector3d(-16.0, -12.0, -27.0 + 54.0 * k / 59.0);
      std::vector<Polyline3d> fc;
      for (const auto& c : intersectMeshWithPlane(truth, m.translation(), m.linear().col(2))) {
        if (!c.closed) continue;
        Polyline3d p;
        p.closed = true;
        for (const auto& q : c.points) p.points.push_back(m.inverse() * q);
        fc.push_back(p);
      }
      fx.poses.push_back(m);
      fx.features.push_back(fc);
    }
    // The observation set a full sweep leaves (for the posterior-only benchmarks).
    PosteriorShapeTracker t(fx.model);
    for (std::size_t k = 0; k < fx.poses.size(); ++k) t.update(fx.poses[k], fx.features[k]);
    fx.observations = t.observations();
    return fx;
  }();
  return f;
}

// Mean milliseconds per call of each benchmark, and the final shapes.
std::map<std::string, double>& msPerCall() {
  static std::map<std::string, double> m;
  return m;
}
std::map<std::string, Eigen::VectorXd>& finalShapes() {
  static std::map<std::string, Eigen::VectorXd> m;
  return m;
}

void record(benchmark::State& state, const std::string& name, double seconds) {
  msPerCall()[name] = 1e3 * seconds / static_cast<double>(state.iterations());
}

void BM_FrameUpdate(benchmark::State& state) {
  const Fixture& f = fixture();
  PosteriorShapeTracker tracker(f.model);
  std::size_t k = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (auto _ : state) {
    const FrameUpdate u = tracker.update(f.poses[k], f.features[k]);
    benchmark::DoNotOptimize(u.observations);
    if (++k == f.poses.size()) k = 0;  // the sweep repeats; V^p stays bounded by the 1.2 mm rule
  }
  record(state, "frame", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  state.counters["vertices"] = static_cast<double>(f.model.pointCount());
  state.counters["modes"] = static_cast<double>(f.model.modeCount());
  state.counters["observations"] = static_cast<double>(tracker.observations().size());
  finalShapes()["frame"] = tracker.currentShape();
}
BENCHMARK(BM_FrameUpdate)->Iterations(600)->Unit(benchmark::kMillisecond);

void BM_FrameUpdatePrevious(benchmark::State& state) {
  const Fixture& f = fixture();
  previous::PreviousTracker tracker(f.model);
  std::size_t k = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (auto _ : state) {
    benchmark::DoNotOptimize(tracker.update(f.poses[k], f.features[k]));
    if (++k == f.poses.size()) k = 0;
  }
  record(state, "frame previous", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  state.counters["observations"] = static_cast<double>(tracker.observations.size());
  finalShapes()["frame previous"] = tracker.posterior.mean;
}
BENCHMARK(BM_FrameUpdatePrevious)->Iterations(600)->Unit(benchmark::kMillisecond);

// One frame's worth of change to V^p (15 observations replaced) and the solve.
void BM_PosteriorIncremental(benchmark::State& state) {
  const Fixture& f = fixture();
  PosteriorNormalEquations equations(f.model.modeCount());
  for (const auto& o : f.observations) equations.add(f.model, o);
  PosteriorOptions o;
  o.max_outlier_rounds = 0;
  std::size_t next = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (auto _ : state) {
    for (int i = 0; i < 15; ++i) {
      equations.replace(next, f.model, f.observations[next]);
      next = (next + 1) % f.observations.size();
    }
    const PosteriorResult p = equations.solve(o);
    benchmark::DoNotOptimize(p.coefficients.data());
  }
  record(state, "posterior incremental", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  state.counters["observations"] = static_cast<double>(f.observations.size());
}
BENCHMARK(BM_PosteriorIncremental)->Unit(benchmark::kMillisecond);

void BM_PosteriorMeanSmallSystem(benchmark::State& state) {
  const Fixture& f = fixture();
  PosteriorOptions o;
  o.max_outlier_rounds = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (auto _ : state) {
    const PosteriorResult p = previous::computePosterior(f.model, f.observations, o);
    benchmark::DoNotOptimize(p.mean.data());
  }
  record(state, "posterior previous", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  state.counters["observations"] = static_cast<double>(f.observations.size());
}
BENCHMARK(BM_PosteriorMeanSmallSystem)->Unit(benchmark::kMillisecond);

// Dense: K_{:,p} = Q Qp^T (3N x 3k) and (Qp Qp^T + s^2 I) (3k x 3k), the
// Gaussian-process form of Eq. 10 as one would write it from the covariance.
void BM_PosteriorMeanDense(benchmark::State& state) {
  const Fixture& f = fixture();
  const ShapeModel& m = f.model;
  const Eigen::MatrixXd q = m.basis * m.variances.cwiseSqrt().asDiagonal();
  const auto k = static_cast<Eigen::Index>(f.observations.size());
  for (auto _ : state) {
    Eigen::MatrixXd qp(3 * k, m.modeCount());
    Eigen::VectorXd d(3 * k);
    for (Eigen::Index i = 0; i < k; ++i) {
      qp.middleRows(3 * i, 3) = observationRows(m, f.observations[static_cast<std::size_t>(i)]);
      d.segment<3>(3 * i) = f.observations[static_cast<std::size_t>(i)].point -
                            observationMean(m, f.observations[static_cast<std::size_t>(i)]);
    }
    const Eigen::MatrixXd k_all_p = q * qp.transpose();
    Eigen::MatrixXd k_pp = qp * qp.transpose();
    k_pp.diagonal().array() += 1.0;
    const Eigen::VectorXd mean = m.mean + k_all_p * k_pp.ldlt().solve(d);
    benchmark::DoNotOptimize(mean.data());
  }
  state.counters["observations"] = static_cast<double>(k);
}
BENCHMARK(BM_PosteriorMeanDense)->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  const auto& ms = msPerCall();
  auto ratio = [&](const char* ours, const char* peer) {
    if (ms.count(ours) == 0 || ms.count(peer) == 0) return;
    std::printf("%-24s %8.3f ms   %-20s %8.3f ms   %.1fx faster\n", ours, ms.at(ours), peer, ms.at(peer),
                ms.at(peer) / ms.at(ours));
  };
  std::printf("\n");
  ratio("frame", "frame previous");
  ratio("posterior incremental", "posterior previous");
  const auto& shapes = finalShapes();
  if (shapes.count("frame") != 0 && shapes.count("frame previous") != 0) {
    std::printf("mean vertex distance between the two pipelines' final shapes: %.2e mm\n",
                meanVertexDistance(shapes.at("frame"), shapes.at("frame previous")));
  }
  return 0;
}
