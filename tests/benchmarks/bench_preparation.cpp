// Preparation on a clinical-size CT (issue 17): import a 512 x 512 x 400 CT
// and its label map of 10 structures into a new session and mesh every label
// (large_ct_case.h: made from the real TotalSegmentator CT by resampling), as
// the user runs it: the steps import-ct, import-label-map and make-models
// (each model's volume checked against its voxels, a decimated copy for the
// headset, every file written into the session). The goal is under 10 s on
// 2 cores.
//
// The peer, in the same run: the pipeline of VTK's own example that a user
// would write instead (Examples/Medical "GenerateModelsFromLabels", with
// discrete flying edges, VTK's fastest): vtkNIFTIImageReader reads the CT and
// the labels, one vtkDiscreteFlyingEdges3D pass over the whole label map for
// all 10 values, vtkWindowedSincPolyDataFilter over the result (the same 15
// iterations and pass band 0.1 as ours), then one vtkThreshold +
// vtkGeometryFilter per label, each written as a .vtp. It checks nothing,
// makes no headset copy and keeps no session: less work than ours.
//
// Run: scripts/bench.sh, or build/tests/benchmarks/mrsns_bench_preparation
#include <benchmark/benchmark.h>
#include <unistd.h>
#include <vtkDataObject.h>
#include <vtkDataSetAttributes.h>
#include <vtkDiscreteFlyingEdges3D.h>
#include <vtkGeometryFilter.h>
#include <vtkImageData.h>
#include <vtkNIFTIImageReader.h>
#include <vtkNew.h>
#include <vtkPolyData.h>
#include <vtkThreshold.h>
#include <vtkWindowedSincPolyDataFilter.h>
#include <vtkXMLPolyDataWriter.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>

#include "large_ct_case.h"

namespace {

using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

double secondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

fs::path scratch() {
  static const fs::path dir = [] {
    auto d = fs::temp_directory_path() / ("mrsns-bench-prep-" + std::to_string(::getpid()));
    fs::create_directories(d);
    return d;
  }();
  return dir;
}

double g_ours_s = 0.0;
double g_peer_s = 0.0;

void printRatio() {
  if (g_ours_s > 0.0 && g_peer_s > 0.0) {
    std::printf("import and mesh 512x512x400, 10 labels: MR-SNS steps %.2f s, VTK example pipeline %.2f s: "
                "ratio %.2f (below 1: ours faster)\n",
                g_ours_s, g_peer_s, g_ours_s / g_peer_s);
  }
}

void BM_ImportAndMeshLargeCt(benchmark::State& state) {
  std::string why;
  const auto c = mrsns::bench::largeCtCase(why);
  if (!c) {
    state.SkipWithError(why.c_str());
    return;
  }
  double import_ct_s = 0.0, labels_s = 0.0, models_s = 0.0, total_s = 0.0;
  double triangles = 0.0, worst_volume_ratio = 0.0;
  int n = 0;
  for (auto _ : state) {
    state.PauseTiming();
    const fs::path dir = scratch() / ("session-" + std::to_string(n));
    fs::remove_all(dir);
    auto session = mrsns::workflow::Session::create(dir);
    const mrsns::workflow::StepContext quiet;
    state.ResumeTiming();
    const auto t0 = Clock::now();
    const bool ct_ok = mrsns::workflow::runStep(session, "import-ct", {{"path", c->ct.string()}}, quiet).ok;
    const auto t1 = Clock::now();
    const bool labels_ok =
        ct_ok && mrsns::workflow::runStep(session, "import-label-map", {{"path", c->labels.string()}}, quiet).ok;
    const auto t2 = Clock::now();
    const auto models = labels_ok ? mrsns::workflow::runStep(session, "make-models", {{"label_map", "labels"}}, quiet)
                                  : mrsns::workflow::StepResult{};
    const double elapsed = secondsSince(t0);
    state.PauseTiming();
    if (!models.ok) {
      state.SkipWithError(("a step failed: " + models.summary).c_str());
      break;
    }
    import_ct_s += std::chrono::duration<double>(t1 - t0).count();
    labels_s += std::chrono::duration<double>(t2 - t1).count();
    models_s += elapsed - std::chrono::duration<double>(t2 - t0).count();
    total_s += elapsed;
    triangles = 0.0;
    for (const auto& m : session.models()) {
      triangles += static_cast<double>(m.triangles);
      if (m.volume_tolerance_ml > 0.0) {
        worst_volume_ratio =
            std::max(worst_volume_ratio, std::abs(m.volume_ml - m.voxel_volume_ml) / m.volume_tolerance_ml);
      }
    }
    if (session.models().size() != 10) state.SkipWithError("make-models did not make 10 models");
    fs::remove_all(dir);
    ++n;
    state.ResumeTiming();
  }
  if (n == 0) return;
  state.counters["import_ct_s"] = import_ct_s / n;
  state.counters["import_labels_s"] = labels_s / n;
  state.counters["make_models_s"] = models_s / n;
  state.counters["total_s"] = total_s / n;
  state.counters["triangles"] = triangles;
  // |mesh - voxel volume| over the voxel-size tolerance, worst model: below 1 is within it.
  state.counters["worst_volume_error_of_tolerance"] = worst_volume_ratio;
  g_ours_s = total_s / n;
  printRatio();
}
BENCHMARK(BM_ImportAndMeshLargeCt)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

void BM_PeerVtkGenerateModelsFromLabels(benchmark::State& state) {
  std::string why;
  const auto c = mrsns::bench::largeCtCase(why);
  if (!c) {
    state.SkipWithError(why.c_str());
    return;
  }
  double total_s = 0.0, triangles = 0.0;
  int n = 0;
  for (auto _ : state) {
    const auto t0 = Clock::now();
    vtkNew<vtkNIFTIImageReader> ct_reader;
    ct_reader->SetFileName(c->ct.c_str());
    ct_reader->Update();
    vtkNew<vtkNIFTIImageReader> reader;
    reader->SetFileName(c->labels.c_str());
    reader->Update();
    vtkNew<vtkDiscreteFlyingEdges3D> surfaces;
    surfaces->SetInputConnection(reader->GetOutputPort());
    for (int i = 0; i < 10; ++i) surfaces->SetValue(i, mrsns::bench::kLargeCtLabels[i]);
    surfaces->ComputeNormalsOff();
    surfaces->ComputeGradientsOff();
    surfaces->ComputeScalarsOn();
    vtkNew<vtkWindowedSincPolyDataFilter> smooth;
    smooth->SetInputConnection(surfaces->GetOutputPort());
    smooth->SetNumberOfIterations(15);
    smooth->SetPassBand(0.1);
    smooth->BoundarySmoothingOff();
    smooth->FeatureEdgeSmoothingOff();
    smooth->NonManifoldSmoothingOn();
    smooth->NormalizeCoordinatesOn();
    smooth->Update();
    triangles = 0.0;
    for (int i = 0; i < 10; ++i) {
      const double value = mrsns::bench::kLargeCtLabels[i];
      vtkNew<vtkThreshold> select;
      select->SetInputConnection(smooth->GetOutputPort());
      // Discrete flying edges puts each surface's label value on its points.
      select->SetInputArrayToProcess(0, 0, 0, vtkDataObject::FIELD_ASSOCIATION_POINTS, vtkDataSetAttributes::SCALARS);
      select->SetLowerThreshold(value);
      select->SetUpperThreshold(value);
      select->SetThresholdFunction(vtkThreshold::THRESHOLD_BETWEEN);
      vtkNew<vtkGeometryFilter> geometry;
      geometry->SetInputConnection(select->GetOutputPort());
      vtkNew<vtkXMLPolyDataWriter> writer;
      writer->SetInputConnection(geometry->GetOutputPort());
      writer->SetFileName((scratch() / ("peer_" + std::to_string(i) + ".vtp")).c_str());
      writer->Write();
      triangles += static_cast<double>(geometry->GetOutput()->GetNumberOfPolys());
    }
    total_s += secondsSince(t0);
    ++n;
  }
  state.counters["total_s"] = total_s / n;
  state.counters["triangles"] = triangles;
  g_peer_s = total_s / n;
  printRatio();
}
BENCHMARK(BM_PeerVtkGenerateModelsFromLabels)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

}  // namespace

BENCHMARK_MAIN();
