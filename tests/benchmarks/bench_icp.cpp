// ICP: mrsns::registration::registerSurface against the two peers a user
// would pick instead, on the same problems in the same run:
// - Open3D's point-to-plane ICP (registration_icp, Python wheel open3d-cpu
//   in build/venv, installed by scripts/bench.sh; skipped with a message
//   when absent) onto a 100,000-point sampling of the surface with the
//   triangles' normals, max correspondence distance 20 mm;
// - VTK's vtkIterativeClosestPointTransform (rigid, closest points from its
//   vtkCellLocator).
// Cases (benchmark argument): 0-2, 20,000 points onto a 100,000-triangle
// non-symmetric vertebra-like surface (about 45 x 40 x 25 mm), sampled
// uniformly over its area with isotropic Gaussian noise of 0.2 mm per axis,
// starting 10 deg and 10 mm from the truth (3 noise/start seeds); 3, the
// femur of ../shared/data/bench/icp_femur (20,000 points, 0.2 mm noise, onto
// 151,456 triangles, 10 deg and 10 mm away). Times exclude reading files and
// Open3D's sampling of the surface; ours include building the BVH, Open3D's
// its k-d tree. Accuracy columns: rotation and translation error to the
// truth (at the points' centroid) and the RMS distance of the registered
// points to the true surface (exact closest points for every method).
// Run: scripts/bench.sh, or build/tests/benchmarks/mrsns_bench_icp
#include <benchmark/benchmark.h>
#include <vtkCellArray.h>
#include <vtkIterativeClosestPointTransform.h>
#include <vtkLandmarkTransform.h>
#include <vtkMatrix4x4.h>
#include <vtkNew.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkSmartPointer.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <unistd.h>

#include "../registration/surface_fixtures.h"
#include "mrsns/core/data_dir.h"
#include "mrsns/core/mesh_locator.h"
#include "mrsns/io/mesh_io.h"
#include "mrsns/registration/surface_registration.h"

namespace {

using mrsns::test::kDegree;

constexpr int kFemurCase = 3;

std::filesystem::path scratch() {
  static const std::filesystem::path dir = [] {
    auto d = std::filesystem::temp_directory_path() / ("mrsns-bench-icp-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

void writeCsv(const std::vector<Eigen::Vector3d>& points, const std::filesystem::path& path) {
  std::ofstream out(path);
  out.precision(17);
  out << "x,y,z\n";
  for (const auto& p : points) out << p.x() << ',' << p.y() << ',' << p.z() << '\n';
}

std::vector<Eigen::Vector3d> readCsv(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);  // header
  std::vector<Eigen::Vector3d> points;
  while (std::getline(in, line)) {
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream row(line);
    Eigen::Vector3d p;
    if (row >> p.x() >> p.y() >> p.z()) points.push_back(p);
  }
  return points;
}

Eigen::Matrix4d readMatrix(const std::filesystem::path& path) {
  std::ifstream in(path);
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) in >> m(r, c);
  }
  return m;
}

void writeMatrix(const Eigen::Matrix4d& m, const std::filesystem::path& path) {
  std::ofstream out(path);
  out.precision(17);
  for (int r = 0; r < 4; ++r) out << m(r, 0) << ' ' << m(r, 1) << ' ' << m(r, 2) << ' ' << m(r, 3) << '\n';
}

struct Problem {
  std::string family;
  mrsns::TriangleMesh mesh;
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
  std::vector<Eigen::Vector3d> moving;
  Eigen::Isometry3d start = Eigen::Isometry3d::Identity();
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  std::unique_ptr<mrsns::MeshLocator> truth_surface;  // for the RMS column
  // The same problem as files, for the Open3D peer.
  std::filesystem::path mesh_file, moving_file, start_file;
};

std::unique_ptr<Problem> vertebraProblem(int seed) {
  auto p = std::make_unique<Problem>();
  p->family = "vertebra-like (3 seeds)";
  static const mrsns::TriangleMesh mesh = mrsns::test::vertebraLikeMesh(201, 250);  // 100,000 triangles
  p->mesh = mesh;
  p->truth = mrsns::test::makePose(Eigen::Vector3d(0.3, -0.2, 0.5), Eigen::Vector3d(10, -20, 5));
  p->moving = mrsns::test::transformPoints(
      p->truth.inverse(), mrsns::test::sampleSurface(p->mesh, 20000, 0.2, 2026 + static_cast<unsigned>(seed)));
  std::mt19937_64 rng(7 + static_cast<unsigned>(seed));
  p->start = mrsns::test::randomPerturbation(rng, 10 * kDegree, 10.0, Eigen::Vector3d::Zero()) * p->truth;
  const auto dir = scratch();
  p->mesh_file = dir / "vertebra.stl";
  if (!std::filesystem::exists(p->mesh_file)) mrsns::io::writeMesh(p->mesh, p->mesh_file);
  p->moving_file = dir / ("vertebra_moving_" + std::to_string(seed) + ".csv");
  writeCsv(p->moving, p->moving_file);
  return p;
}

std::unique_ptr<Problem> femurProblem() {
  const auto dir = mrsns::findDataFile("bench/icp_femur");
  if (!dir) return nullptr;
  auto p = std::make_unique<Problem>();
  p->family = "femur (shared data)";
  p->mesh_file = *dir / "fixed.stl";
  p->moving_file = *dir / "moving.csv";
  p->mesh = mrsns::io::readMesh(p->mesh_file);
  p->moving = readCsv(p->moving_file);
  p->truth.matrix() = readMatrix(*dir / "moving_to_fixed_truth.txt");
  p->start = Eigen::Isometry3d::Identity();  // the points are already 10 deg and 10 mm away
  return p;
}

// One problem per case (the benchmark argument), built on first use.
const Problem* problem(int which) {
  static std::map<int, std::unique_ptr<Problem>> cache;
  auto& p = cache[which];
  if (!p) {
    p = which == kFemurCase ? femurProblem() : vertebraProblem(which);
    if (!p) return nullptr;
    for (const auto& q : p->moving) p->centroid += q;
    p->centroid /= static_cast<double>(p->moving.size());
    p->truth_surface = std::make_unique<mrsns::MeshLocator>(p->mesh);
    p->start_file = scratch() / ("start_" + std::to_string(which) + ".txt");
    writeMatrix(p->start.matrix(), p->start_file);
  }
  return p.get();
}

double rmsToSurface(const Problem& p, const Eigen::Isometry3d& estimate) {
  double sum = 0.0;
  for (const auto& q : p.moving) {
    const double d = p.truth_surface->closestPoint(estimate * q).distance;
    sum += d * d;
  }
  return std::sqrt(sum / static_cast<double>(p.moving.size()));
}

struct Outcome {
  double seconds = 0.0;
  double rotation_deg = 0.0;
  double translation_mm = 0.0;
  double rms_mm = 0.0;
  int iterations = 0;  // -1: the peer does not say
};
// (case family, method) -> one outcome per case run.
std::map<std::pair<std::string, std::string>, std::vector<Outcome>>& outcomes() {
  static std::map<std::pair<std::string, std::string>, std::vector<Outcome>> o;
  return o;
}

const Problem* problemOrSkip(benchmark::State& state) {
  const Problem* p = problem(static_cast<int>(state.range(0)));
  if (p == nullptr) state.SkipWithError("bench/icp_femur is not in the shared data (set MRSNS_DATA_DIR)");
  return p;
}

void report(benchmark::State& state, const Problem& p, const std::string& name, const Eigen::Isometry3d& estimate,
            double seconds, int iterations) {
  const auto e = mrsns::test::poseError(estimate, p.truth, p.centroid);
  const double rms = rmsToSurface(p, estimate);
  state.counters["rot_err_deg"] = e.rotation / kDegree;
  state.counters["trans_err_mm"] = e.translation;
  state.counters["rms_to_surface_mm"] = rms;
  state.counters["iterations"] = iterations;
  outcomes()[{p.family, name}].push_back({seconds, e.rotation / kDegree, e.translation, rms, iterations});
}

void runMrsns(benchmark::State& state, mrsns::registration::IcpMethod method, unsigned threads,
              const std::string& name) {
  const Problem* p = problemOrSkip(state);
  if (p == nullptr) return;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    const mrsns::registration::IcpSurface surface(p->mesh);
    mrsns::registration::IcpOptions options;
    options.method = method;
    options.max_iterations = 200;
    options.threads = threads;
    const auto r = mrsns::registration::registerSurface(p->moving, surface, p->start, options);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    state.PauseTiming();
    report(state, *p, name, r.fixed_T_moving, s, r.iterations);
    state.ResumeTiming();
  }
}

void BM_IcpMrsnsPointToPlane(benchmark::State& state) {
  runMrsns(state, mrsns::registration::IcpMethod::PointToPlane, 0, "mrsns point-to-plane");
}
void BM_IcpMrsnsPointToPlaneOneThread(benchmark::State& state) {
  runMrsns(state, mrsns::registration::IcpMethod::PointToPlane, 1, "mrsns point-to-plane 1 thread");
}
void BM_IcpMrsnsPointToPoint(benchmark::State& state) {
  runMrsns(state, mrsns::registration::IcpMethod::PointToPoint, 0, "mrsns point-to-point");
}

// The Python of build/venv (or MRSNS_BENCH_PYTHON) with open3d importable, or empty.
std::string open3dPython() {
  static const std::string python = []() -> std::string {
    std::string candidate = MRSNS_BENCH_BINARY_DIR "/venv/bin/python";
    if (const char* env = std::getenv("MRSNS_BENCH_PYTHON")) candidate = env;
    const std::string probe = "'" + candidate + "' -c 'import open3d' >/dev/null 2>&1";
    if (std::system(probe.c_str()) != 0) {
      std::fprintf(stderr,
                   "Open3D peer skipped: '%s' cannot import open3d (scripts/bench.sh installs open3d-cpu==0.20.0 "
                   "into build/venv; or set MRSNS_BENCH_PYTHON)\n",
                   candidate.c_str());
      return {};
    }
    return candidate;
  }();
  return python;
}

void BM_IcpOpen3d(benchmark::State& state) {
  const Problem* p = problemOrSkip(state);
  if (p == nullptr) return;
  const std::string python = open3dPython();
  if (python.empty()) {
    state.SkipWithError("open3d is not importable (run scripts/bench.sh)");
    return;
  }
  for (auto _ : state) {
    const std::string command = "'" + python + "' '" MRSNS_BENCH_SOURCE_DIR "/open3d_icp_peer.py' '" +
                                p->mesh_file.string() + "' '" + p->moving_file.string() + "' '" +
                                p->start_file.string() + "' 100000 20 1";
    std::string out;
    if (FILE* pipe = ::popen(command.c_str(), "r")) {
      char buffer[4096];
      std::size_t n = 0;
      while ((n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0) out.append(buffer, n);
      if (::pclose(pipe) != 0) out.clear();
    }
    if (out.empty()) {
      state.SkipWithError("the Open3D peer failed (run its command by hand to see why)");
      return;
    }
    const auto j = nlohmann::json::parse(out);
    Eigen::Isometry3d estimate = Eigen::Isometry3d::Identity();
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) estimate.matrix()(r, c) = j["fixed_T_moving"][r][c].get<double>();
    }
    state.SetIterationTime(j["seconds"].get<double>());
    state.counters["open3d_inlier_rmse_mm"] = j["inlier_rmse_mm"].get<double>();
    report(state, *p, "open3d " + j["open3d"].get<std::string>() + " point-to-plane", estimate,
           j["seconds"].get<double>(), -1);
  }
}

void BM_IcpVtk(benchmark::State& state) {
  const Problem* p = problemOrSkip(state);
  if (p == nullptr) return;
  vtkNew<vtkPoints> target_points;
  for (Eigen::Index i = 0; i < p->mesh.vertexCount(); ++i) {
    target_points->InsertNextPoint(p->mesh.vertices(i, 0), p->mesh.vertices(i, 1), p->mesh.vertices(i, 2));
  }
  vtkNew<vtkCellArray> polys;
  for (Eigen::Index f = 0; f < p->mesh.faceCount(); ++f) {
    const vtkIdType ids[3] = {p->mesh.faces(f, 0), p->mesh.faces(f, 1), p->mesh.faces(f, 2)};
    polys->InsertNextCell(3, ids);
  }
  vtkNew<vtkPolyData> target;
  target->SetPoints(target_points);
  target->SetPolys(polys);
  // The source starts where ours does: the moving points mapped by the start pose.
  vtkNew<vtkPoints> source_points;
  vtkNew<vtkCellArray> verts;
  for (const auto& q : p->moving) {
    const Eigen::Vector3d x = p->start * q;
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
    icp->SetMaximumNumberOfLandmarks(static_cast<int>(p->moving.size()));  // all points, as ours
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
    state.PauseTiming();
    report(state, *p, "vtk", m * p->start, s, icp->GetNumberOfIterations());
    state.ResumeTiming();
  }
}

// Argument: the case (0-2 vertebra-like seeds, 3 the femur).
BENCHMARK(BM_IcpMrsnsPointToPlane)->DenseRange(0, 3)->Iterations(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_IcpMrsnsPointToPlaneOneThread)
    ->DenseRange(0, 3)
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_IcpMrsnsPointToPoint)->DenseRange(0, 3)->Iterations(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_IcpOpen3d)->DenseRange(0, 3)->Iterations(1)->Unit(benchmark::kMillisecond)->UseManualTime();
BENCHMARK(BM_IcpVtk)->DenseRange(0, 3)->Iterations(1)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  std::error_code ignored;
  std::filesystem::remove_all(scratch(), ignored);
  // Means over the cases run, per family.
  std::map<std::string, std::map<std::string, Outcome>> mean;
  for (const auto& [key, runs] : outcomes()) {
    Outcome m;
    for (const auto& r : runs) {
      const auto n = static_cast<double>(runs.size());
      m.seconds += r.seconds / n;
      m.rotation_deg += r.rotation_deg / n;
      m.translation_mm += r.translation_mm / n;
      m.rms_mm += r.rms_mm / n;
      m.iterations += r.iterations;
    }
    m.iterations /= static_cast<int>(runs.size());
    mean[key.first][key.second] = m;
  }
  for (const auto& [family, methods] : mean) {
    std::printf("\n%s: means over the cases run\n%-34s %9s %10s %10s %14s %6s\n", family.c_str(), "method", "time_s",
                "rot_deg", "trans_mm", "rms_surface_mm", "iters");
    for (const auto& [name, r] : methods) {
      std::printf("%-34s %9.3f %10.4f %10.4f %14.4f %6d\n", name.c_str(), r.seconds, r.rotation_deg,
                  r.translation_mm, r.rms_mm, r.iterations);
    }
    const auto ours = methods.find("mrsns point-to-plane");
    if (ours == methods.end()) continue;
    for (const auto& [name, r] : methods) {
      if (name.rfind("mrsns", 0) == 0) continue;
      std::printf("%s: mrsns point-to-plane takes %.2fx the time of %s (below 1 is faster)\n", family.c_str(),
                  ours->second.seconds / r.seconds, name.c_str());
    }
  }
  return 0;
}
