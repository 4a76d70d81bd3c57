// Reading real data through mrsns::io: the DICOM series (20 JPEG 2000
// slices), a NIfTI label map with its label statistics, STL and legacy VTK
// meshes. Run: build-*/tests/benchmarks/mrsns_bench_file_io
#include <benchmark/benchmark.h>

#include <filesystem>

#include "mrsns/core/data_dir.h"
#include "mrsns/io/image_io.h"
#include "mrsns/io/mesh_io.h"

namespace {

std::filesystem::path dataFile(const char* relative) {
  const auto found = mrsns::findDataFile(relative);
  return found ? *found : std::filesystem::path(MRSNS_BENCH_DATA_DIR) / relative;
}

template <typename F>
void runOrSkip(benchmark::State& state, const std::filesystem::path& path, F&& f) {
  if (!std::filesystem::exists(path)) {
    state.SkipWithError(("missing data file " + path.string()).c_str());
    return;
  }
  for (auto _ : state) f();
}

void BM_ReadDicomSeries(benchmark::State& state) {
  const auto path = dataFile("ct/totalsegmentator/example_ct_dicom");
  runOrSkip(state, path, [&] { benchmark::DoNotOptimize(mrsns::io::readImage(path)); });
}
BENCHMARK(BM_ReadDicomSeries)->Unit(benchmark::kMillisecond);

void BM_ReadNiftiLabelMapWithLabels(benchmark::State& state) {
  const auto path = dataFile("ct/verse/sub-verse004_seg-vert_msk.nii.gz");
  runOrSkip(state, path, [&] {
    const auto image = mrsns::io::readImage(path);
    benchmark::DoNotOptimize(mrsns::io::labelStatistics(image));
  });
}
BENCHMARK(BM_ReadNiftiLabelMapWithLabels)->Unit(benchmark::kMillisecond);

void BM_ReadStl(benchmark::State& state) {
  const auto path = dataFile("ssm/scalismo/0.stl");
  runOrSkip(state, path, [&] { benchmark::DoNotOptimize(mrsns::io::readMesh(path)); });
}
BENCHMARK(BM_ReadStl)->Unit(benchmark::kMillisecond);

void BM_ReadLegacyVtkFemur(benchmark::State& state) {
  const auto path = dataFile("ssm/statismo/femur_meshes/VSD001_femur.vtk");
  runOrSkip(state, path, [&] { benchmark::DoNotOptimize(mrsns::io::readMesh(path)); });
}
BENCHMARK(BM_ReadLegacyVtkFemur)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
