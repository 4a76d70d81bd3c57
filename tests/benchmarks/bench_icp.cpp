// ICP: mrsns::registration::registerSurface against VTK's
// vtkIterativeClosestPointTransform (rigid, closest points from its
// vtkCellLocator) on the same problem: 20,000 points onto a 100,000-triangle
// non-symmetric vertebra-like surface (about 45 x 40 x 25 mm), points sampled
// uniformly over the area of the surface moved by the ground-truth
// transform, with isotropic Gaussian noise of 0.2 mm per axis; both start
// from the same pose, 10 deg and 10 mm away from the truth. Reported per
// method: wall time (including each method's locator build), rotation and
// translation error to the truth (at the points' centroid), RMS distance and
// iterations; then the means over 3 noise seeds and the time ratio.
// Run: build/tests/benchmarks/mrsns_bench_icp
#include <benchmark/benchmark.h>
#include <vtkCellArray.h>
#include <vtkIterativeClosestPointTransform.h>
#include <vtkLandmarkTransform.h>
#include <vtkMatrix4x4.h>
#include <vtkNew.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkSmartPointer.h>

#include <chrono>
#include <cstdio>
#include <map>
#include <memory>
#include <string>

#include "../registration/surface_fixtures.h"
#include "mrsns/registration/surface_registration.h"

namespace {

using mrsns::test::kDegree;

struct Problem {
  mrsns::TriangleMesh mesh = mrsns::test::vertebraLikeMesh(201, 250);  // 100,000 triangles
  Eigen::Isometry3d truth = mrsns::test::makePose(Eigen::Vector3d(0.3, -0.2, 0.5), Eigen::Vector3d(10, -20, 5));
  std::vector<Eigen::Vector3d> moving;
  Eigen::Isometry3d start;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  explicit Problem(int seed) {
    moving = mrsns::test::transformPoints(
        truth.inverse(), mrsns::test::sampleSurface(mesh, 20000, 0.2, 2026 + static_cast<unsigned>(seed)));
    std::mt19937_64 rng(7 + static_cast<unsigned>(seed));
    start = mrsns::test::randomPerturbation(rng, 10 * kDegree, 10.0, Eigen::Vector3d::Zero()) * truth;
    for (const auto& p : moving) centroid += p;
    centroid /= static_cast<double>(moving.size());
  }
};

// One problem per noise seed (the benchmark argument); the mesh is shared.
const Problem& problem(int seed) {
  static std::map<int, std::unique_ptr<Problem>> cache;
  auto& p = cache[seed];
  if (!p) p = std::make_unique<Problem>(seed);
  return *p;
}

struct Outcome {
  double seconds = 0.0;
  double rotation_deg = 0.0;
  double translation_mm = 0.0;
  double rms_mm = 0.0;
  int iterations = 0;
};
std::map<std::string, std::vector<Outcome>>& outcomes() {
  static std::map<std::string, std::vector<Outcome>> o;
  return o;
}

void report(benchmark::State& state, const std::string& name, const Eigen::Isometry3d& estimate, double seconds,
            double rms, int iterations) {
  const auto& p = problem(static_cast<int>(state.range(0)));
  const auto e = mrsns::test::poseError(estimate, p.truth, p.centroid);
  state.counters["rot_err_deg"] = e.rotation / kDegree;
  state.counters["trans_err_mm"] = e.translation;
  state.counters["rms_mm"] = rms;
  state.counters["iterations"] = iterations;
  outcomes()[name].push_back({seconds, e.rotation / kDegree, e.translation, rms, iterations});
}

void runMrsns(benchmark::State& state, mrsns::registration::IcpMethod method, const std::string& name) {
  const auto& p = problem(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    const mrsns::registration::IcpSurface surface(p.mesh);
    mrsns::registration::IcpOptions options;
    options.method = method;
    options.max_iterations = 200;
    const auto r = mrsns::registration::registerSurface(p.moving, surface, p.start, options);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    report(state, name, r.fixed_T_moving, s, r.rms_mm, r.iterations);
  }
}

void BM_IcpMrsnsPointToPlane(benchmark::State& state) {
  runMrsns(state, mrsns::registration::IcpMethod::PointToPlane, "mrsns point-to-plane");
}
void BM_IcpMrsnsPointToPoint(benchmark::State& state) {
  runMrsns(state, mrsns::registration::IcpMethod::PointToPoint, "mrsns point-to-point");
}

void BM_IcpVtk(benchmark::State& state) {
  const auto& p = problem(static_cast<int>(state.range(0)));
  vtkNew<vtkPoints> target_points;
  for (Eigen::Index i = 0; i < p.mesh.vertexCount(); ++i) {
    target_points->InsertNextPoint(p.mesh.vertices(i, 0), p.mesh.vertices(i, 1), p.mesh.vertices(i, 2));
  }
  vtkNew<vtkCellArray> polys;
  for (Eigen::Index f = 0; f < p.mesh.faceCount(); ++f) {
    const vtkIdType ids[3] = {p.mesh.faces(f, 0), p.mesh.faces(f, 1), p.mesh.faces(f, 2)};
    polys->InsertNextCell(3, ids);
  }
  vtkNew<vtkPolyData> target;
  target->SetPoints(target_points);
  target->SetPolys(polys);
  // The source starts where ours does: the moving points mapped by the start pose.
  vtkNew<vtkPoints> source_points;
  vtkNew<vtkCellArray> verts;
  for (const auto& q : p.moving) {
    const Eigen::Vector3d x = p.start * q;
    const vtkIdType id = source_points->InsertNextPoint(x.x(), x.y(), x.z());
    verts->InsertNextCell(1, &id);
  }
  vtkNew<vtkPolyData> source;
  source->SetPoints(source_points);
  source->SetVerts(verts);
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    vtkNew<vtkIterativeClosestPointTransform> icp;
    icp->SetSource(source);
    icp->SetTarget(target);
    icp->GetLandmarkTransform()->SetModeToRigidBody();
    icp->SetMaximumNumberOfLandmarks(static_cast<int>(p.moving.size()));  // all points, as ours
    icp->SetMaximumNumberOfIterations(200);
    icp->StartByMatchingCentroidsOff();
    icp->CheckMeanDistanceOn();
    icp->SetMeanDistanceModeToRMS();
    // Stop when an iteration moves the points by less than 1e-3 mm RMS
    // (10x stricter than VTK's default 0.01, 10x looser than ours).
    icp->SetMaximumMeanDistance(1e-3);
    icp->Modified();
    icp->Update();
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) m.matrix()(r, c) = icp->GetMatrix()->GetElement(r, c);
    }
    const Eigen::Isometry3d estimate = m * p.start;
    // RMS distance at VTK's result, measured with our exact closest points.
    const mrsns::MeshLocator locator(p.mesh);
    double sum = 0.0;
    for (const auto& q : p.moving) {
      const double d = locator.closestPoint(estimate * q).distance;
      sum += d * d;
    }
    report(state, "vtk", estimate, s, std::sqrt(sum / static_cast<double>(p.moving.size())),
           icp->GetNumberOfIterations());
  }
}

// Argument: the noise/start seed (3 independent problems).
BENCHMARK(BM_IcpMrsnsPointToPlane)->DenseRange(0, 2)->Iterations(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_IcpMrsnsPointToPoint)->DenseRange(0, 2)->Iterations(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_IcpVtk)->DenseRange(0, 2)->Iterations(1)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  // Means over the seeds run.
  std::map<std::string, Outcome> mean;
  for (const auto& [name, runs] : outcomes()) {
    Outcome m;
    for (const auto& r : runs) {
      m.seconds += r.seconds / static_cast<double>(runs.size());
      m.rotation_deg += r.rotation_deg / static_cast<double>(runs.size());
      m.translation_mm += r.translation_mm / static_cast<double>(runs.size());
      m.rms_mm += r.rms_mm / static_cast<double>(runs.size());
      m.iterations += r.iterations;
    }
    m.iterations /= static_cast<int>(runs.size());
    mean[name] = m;
  }
  std::printf("\nmeans over the seeds run\n%-22s %10s %10s %10s %9s %6s\n", "method", "time_s", "rot_deg", "trans_mm",
              "rms_mm", "iters");
  for (const auto& [name, r] : mean) {
    std::printf("%-22s %10.3f %10.4f %10.4f %9.4f %6d\n", name.c_str(), r.seconds, r.rotation_deg, r.translation_mm,
                r.rms_mm, r.iterations);
  }
  if (mean.count("vtk") != 0) {
    for (const auto& [name, r] : mean) {
      if (name != "vtk")
        std::printf("speed-up of %s over VTK: %.1fx\n", name.c_str(), mean.at("vtk").seconds / r.seconds);
    }
  }
  return 0;
}
